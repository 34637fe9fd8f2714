//! Culling, ordering, lifetimes and the buffer pool plan.
//!
//! Passes form a DAG through their buffers (each buffer has exactly one writer; an edge runs from the
//! writer to every reader). Scheduling:
//! 1. **Cull** every pass from which no sink input is reachable: its work would be thrown away. This
//!    is what lets a pipeline keep a debug node around at no cost.
//! 0. **Check** the passes' declarations (before culling, so a debug branch is checked too): a pass
//!    reading a buffer written by a pass of a *later* [`Stage`] is an error naming both passes, and
//!    so are two random passes with the same stream (see [`crate::stage::stream_id`]) and a stream
//!    set by hand on a pass not declared random.
//! 2. **Order** the survivors by stage, then topologically inside a stage. Among ready passes the one
//!    of the earliest stage, then the one added first during expansion, runs first, so the schedule is
//!    deterministic and follows the pipeline's own order. (Because no pass reads a later stage, this
//!    runs every pass of a stage before any pass of the next.)
//! 3. **Lifetimes**: a buffer lives from the pass that writes it to the last pass that reads it (sink
//!    inputs to the end, since the run hands them back).
//! 4. **Pool plan**: buffers of the same format whose lifetimes do not overlap share a physical slot
//!    (greedy interval colouring in order of first write). A buffer may reuse a slot only if the
//!    previous occupant's last use is strictly before the buffer's first write, so a pass never reads
//!    and writes the same storage.
//! 5. **Memory estimate** ([`Schedule::buffer_bytes`], [`Schedule::peak_bytes`]): what the plan
//!    costs at a given image size, so a run too large for the machine is refused before it allocates.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashSet};
use std::fmt::Write as _;

use petgraph::graph::{DiGraph, NodeIndex};
use petgraph::visit::{Dfs, Reversed};

use crate::decl::Format;
use crate::expand::{BufferId, BufferInfo, Expansion, Pass};
use crate::stage::Stage;
use crate::GraphError;

/// Indices into [`Schedule::passes`] of a buffer's first write and last use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lifetime {
    pub first: usize,
    pub last: usize,
}

impl Lifetime {
    pub fn overlaps(&self, other: &Lifetime) -> bool {
        self.first <= other.last && other.first <= self.last
    }
}

/// The passes to run, in order, and how their buffers map onto storage.
#[derive(Clone, Debug)]
pub struct Schedule {
    pub passes: Vec<Pass>,
    /// All buffers of the expansion, indexed by [`BufferId`] (culled ones included).
    pub buffers: Vec<BufferInfo>,
    /// Per buffer; `None` for buffers of culled passes.
    pub lifetimes: Vec<Option<Lifetime>>,
    /// Buffer → physical slot; `None` where the lifetime is `None`.
    pub slots: Vec<Option<usize>>,
    /// Format of each physical slot.
    pub slot_formats: Vec<Format>,
    /// Elements per pixel of each physical slot ([`BufferInfo::layers`]): a slot is shared only by
    /// buffers of the same format and layers.
    pub slot_layers: Vec<u32>,
    pub sink_inputs: Vec<(String, String, BufferId)>,
    /// Previous-frame buffers read by a scheduled pass, with their sources ([`crate::History`]): the
    /// runner fills each before the run (from the previous frame's run, else zeros), and a run hands
    /// every source back.
    pub history: Vec<crate::History>,
    /// Names of the culled passes, in expansion order.
    pub culled: Vec<String>,
}

/// Cull, order, and plan the storage of an expansion (the module doc's steps, one function each).
pub fn schedule(e: Expansion) -> Result<Schedule, GraphError> {
    let Expansion { buffers, passes, sink_inputs, history, .. } = e;
    let writer = writers(&passes, buffers.len())?;
    check_stages_and_streams(&passes, &buffers, &writer)?;
    let dag = PassDag::new(&passes, &buffers, &writer, &history)?;
    let live = dag.live(&passes, &buffers, &writer, &sink_inputs, &history)?;
    let culled: Vec<String> =
        passes.iter().enumerate().filter(|(i, _)| !live[*i]).map(|(_, p)| p.name.clone()).collect();
    let order = dag.order(&passes, &live)?;
    let (lifetimes, live_history) = lifetimes(&passes, buffers.len(), &writer, &live, &order, &sink_inputs, &history);
    let (slots, slot_formats, slot_layers) = pool_plan(&buffers, &lifetimes);
    let passes_in_order: Vec<Pass> = order.iter().map(|&i| passes[i].clone()).collect();
    Ok(Schedule {
        passes: passes_in_order,
        buffers,
        lifetimes,
        slots,
        slot_formats,
        slot_layers,
        sink_inputs,
        history: live_history,
        culled,
    })
}

/// The writer of every buffer (expansion guarantees at most one); a write to a buffer that does not
/// exist is an error.
fn writers(passes: &[Pass], nb: usize) -> Result<Vec<Option<usize>>, GraphError> {
    let mut writer: Vec<Option<usize>> = vec![None; nb];
    for (pi, p) in passes.iter().enumerate() {
        for (_, id) in &p.writes {
            if id.0 >= nb {
                return Err(GraphError::Expand {
                    node: p.node.clone(),
                    message: format!("pass `{}` writes buffer #{} that does not exist", p.name, id.0),
                });
            }
            writer[id.0] = Some(pi);
        }
    }
    Ok(writer)
}

/// The pass DAG: an edge writer → reader per buffer read (previous-frame buffers have none: the
/// runner fills them before the first pass).
struct PassDag {
    g: DiGraph<usize, BufferId>,
    idx: Vec<NodeIndex>,
}

impl PassDag {
    fn new(
        passes: &[Pass],
        buffers: &[BufferInfo],
        writer: &[Option<usize>],
        history: &[crate::History],
    ) -> Result<PassDag, GraphError> {
        let nb = buffers.len();
        let is_history = |id: BufferId| history.iter().any(|h| h.buffer == id);
        let mut g: DiGraph<usize, BufferId> = DiGraph::new();
        let idx: Vec<NodeIndex> = (0..passes.len()).map(|i| g.add_node(i)).collect();
        for (pi, p) in passes.iter().enumerate() {
            for (binding, id) in &p.reads {
                if is_history(*id) {
                    continue;
                }
                let w = (id.0 < nb).then(|| writer[id.0]).flatten().ok_or_else(|| GraphError::Expand {
                    node: p.node.clone(),
                    message: format!(
                        "pass `{}` reads `{}` (binding `{binding}`), which no pass writes",
                        p.name,
                        buffers.get(id.0).map_or("<no such buffer>", |b| b.name.as_str())
                    ),
                })?;
                g.add_edge(idx[w], idx[pi], *id);
            }
        }
        Ok(PassDag { g, idx })
    }

    /// Mark live every pass from which `w`'s pass is reachable (walking edges backwards).
    fn mark_needed(&self, w: usize, live: &mut [bool]) {
        let rev = Reversed(&self.g);
        let mut dfs = Dfs::new(rev, self.idx[w]);
        while let Some(n) = dfs.next(rev) {
            live[n.index()] = true;
        }
    }

    /// Step 1, culling: the passes from which a sink input is reachable are live; a previous-frame
    /// buffer read by a live pass keeps its source's writer (and what it needs) live, which may make
    /// more previous-frame buffers read — repeated until nothing changes.
    fn live(
        &self,
        passes: &[Pass],
        buffers: &[BufferInfo],
        writer: &[Option<usize>],
        sink_inputs: &[(String, String, BufferId)],
        history: &[crate::History],
    ) -> Result<Vec<bool>, GraphError> {
        let nb = buffers.len();
        let mut live = vec![false; passes.len()];
        for (node, port, id) in sink_inputs {
            let w = (id.0 < nb).then(|| writer[id.0]).flatten().ok_or_else(|| GraphError::Expand {
                node: node.clone(),
                message: format!("sink input `{port}` is a buffer that no pass writes"),
            })?;
            if buffers[id.0].layers != 1 {
                return Err(GraphError::Expand {
                    node: node.clone(),
                    message: format!(
                        "sink input `{port}` is `{}`, a per-sample buffer ({} elements per pixel), not an image; \
                         connect an image output of its node instead",
                        buffers[id.0].name, buffers[id.0].layers
                    ),
                });
            }
            if !live[w] {
                self.mark_needed(w, &mut live);
            }
        }
        loop {
            let mut changed = false;
            for h in history {
                let read =
                    passes.iter().enumerate().any(|(i, p)| live[i] && p.reads.iter().any(|(_, id)| *id == h.buffer));
                let Some(w) = writer.get(h.source.0).copied().flatten() else {
                    if read {
                        return Err(GraphError::Expand {
                            node: buffers[h.buffer.0].name.clone(),
                            message: format!(
                                "asks for the previous frame of `{}`, which no pass writes",
                                buffers[h.source.0].name
                            ),
                        });
                    }
                    continue;
                };
                if read && !live[w] {
                    self.mark_needed(w, &mut live);
                    changed = true;
                }
            }
            if !changed {
                return Ok(live);
            }
        }
    }

    /// Step 2: a deterministic topological order of the live passes (Kahn; the ready set ordered by
    /// stage, then expansion index); a cycle is an error naming a pass on it.
    fn order(&self, passes: &[Pass], live: &[bool]) -> Result<Vec<usize>, GraphError> {
        let mut indeg = vec![0usize; passes.len()];
        for e in self.g.raw_edges() {
            if live[e.source().index()] && live[e.target().index()] {
                indeg[e.target().index()] += 1;
            }
        }
        let key = |i: usize| Reverse((passes[i].stage, i));
        let mut ready: BinaryHeap<Reverse<(Stage, usize)>> =
            (0..passes.len()).filter(|&i| live[i] && indeg[i] == 0).map(key).collect();
        let mut order: Vec<usize> = Vec::new();
        while let Some(Reverse((_, i))) = ready.pop() {
            order.push(i);
            for n in self.g.neighbors(self.idx[i]) {
                let t = n.index();
                // `neighbors` yields one entry per edge, matching the per-edge in-degree count.
                indeg[t] -= 1;
                if indeg[t] == 0 {
                    ready.push(key(t));
                }
            }
        }
        let live_count = live.iter().filter(|&&l| l).count();
        if order.len() != live_count {
            let stuck = (0..passes.len()).find(|&i| live[i] && indeg[i] > 0).unwrap();
            return Err(GraphError::Expand {
                node: passes[stuck].node.clone(),
                message: format!("pass `{}` is part of a cycle of passes", passes[stuck].name),
            });
        }
        Ok(order)
    }
}

/// Step 3: every live buffer's lifetime — from its writer to its last reader; sink inputs to the end
/// (a run hands them back); previous-frame buffers from the start (filled before pass 0) to their
/// last reader and their sources to the end (handed back for the next frame). Also the
/// previous-frame buffers a scheduled pass reads.
#[allow(clippy::too_many_arguments)]
fn lifetimes(
    passes: &[Pass],
    nb: usize,
    writer: &[Option<usize>],
    live: &[bool],
    order: &[usize],
    sink_inputs: &[(String, String, BufferId)],
    history: &[crate::History],
) -> (Vec<Option<Lifetime>>, Vec<crate::History>) {
    let mut position = vec![usize::MAX; passes.len()];
    for (pos, &pi) in order.iter().enumerate() {
        position[pi] = pos;
    }
    let mut lifetimes: Vec<Option<Lifetime>> = vec![None; nb];
    for (b, w) in writer.iter().enumerate() {
        if let Some(w) = *w {
            if live[w] {
                lifetimes[b] = Some(Lifetime { first: position[w], last: position[w] });
            }
        }
    }
    for &pi in order {
        for (_, id) in &passes[pi].reads {
            if let Some(l) = lifetimes[id.0].as_mut() {
                l.last = l.last.max(position[pi]);
            }
        }
    }
    let end = order.len().saturating_sub(1);
    for (_, _, id) in sink_inputs {
        if let Some(l) = lifetimes[id.0].as_mut() {
            l.last = end;
        }
    }
    let reads = |pi: usize, h: &crate::History| passes[pi].reads.iter().any(|(_, id)| *id == h.buffer);
    let live_history: Vec<crate::History> =
        history.iter().copied().filter(|h| order.iter().any(|&pi| reads(pi, h))).collect();
    for h in &live_history {
        let last = order.iter().rposition(|&pi| reads(pi, h)).unwrap_or(0);
        lifetimes[h.buffer.0] = Some(Lifetime { first: 0, last });
        if let Some(l) = lifetimes[h.source.0].as_mut() {
            l.last = end;
        }
    }
    (lifetimes, live_history)
}

/// Step 4, the pool plan: greedy interval colouring per format and layers, buffers in order of first
/// write; a slot is reused only after its occupant's last use. Returns each buffer's slot and each
/// slot's format and layers.
fn pool_plan(buffers: &[BufferInfo], lifetimes: &[Option<Lifetime>]) -> (Vec<Option<usize>>, Vec<Format>, Vec<u32>) {
    let nb = buffers.len();
    let mut by_first: Vec<usize> = (0..nb).filter(|&b| lifetimes[b].is_some()).collect();
    by_first.sort_by_key(|&b| (lifetimes[b].unwrap().first, b));
    let mut slots: Vec<Option<usize>> = vec![None; nb];
    let mut slot_formats: Vec<Format> = Vec::new();
    let mut slot_layers: Vec<u32> = Vec::new();
    let mut slot_last: Vec<usize> = Vec::new(); // last use of the slot's current occupant
    for b in by_first {
        let l = lifetimes[b].unwrap();
        let (f, n) = (buffers[b].format, buffers[b].layers);
        let free =
            (0..slot_formats.len()).find(|&s| slot_formats[s] == f && slot_layers[s] == n && slot_last[s] < l.first);
        let s = free.unwrap_or_else(|| {
            slot_formats.push(f);
            slot_layers.push(n);
            slot_last.push(0);
            slot_formats.len() - 1
        });
        slot_last[s] = l.last;
        slots[b] = Some(s);
    }
    (slots, slot_formats, slot_layers)
}

/// Stage order and stream uniqueness over every pass (culled or not), all problems in one error.
fn check_stages_and_streams(
    passes: &[Pass],
    buffers: &[BufferInfo],
    writer: &[Option<usize>],
) -> Result<(), GraphError> {
    let mut problems: Vec<(String, String)> = Vec::new();
    for p in passes {
        for (binding, id) in &p.reads {
            let Some(w) = writer.get(id.0).copied().flatten() else {
                continue; // reported below as "no pass writes"
            };
            let w = &passes[w];
            if w.stage > p.stage {
                problems.push((
                    p.node.clone(),
                    format!(
                        "pass `{}` (stage {}) reads `{}` (binding `{binding}`), written by pass `{}` of the later \
                         stage {}; a stage may only read earlier stages (move one of the two passes)",
                        p.name, p.stage, buffers[id.0].name, w.name, w.stage
                    ),
                ));
            }
        }
    }
    for p in passes.iter().filter(|p| !p.random && p.params.contains_key("stream")) {
        problems.push((
            p.node.clone(),
            format!(
                "pass `{}` sets `stream` by hand; declare `.random()` and the graph assigns it from the pass's name",
                p.name
            ),
        ));
    }
    let mut streams: Vec<(u32, &Pass)> = passes
        .iter()
        .filter(|p| p.random)
        .filter_map(|p| match p.params.get("stream") {
            Some(crate::ParamValue::Int(s)) => Some((*s as u32, p)),
            _ => None,
        })
        .collect();
    streams.sort_by_key(|(s, p)| (*s, p.name.clone()));
    for w in streams.windows(2) {
        // A pass continuing another's sequences takes its stream on purpose.
        let continuing = |a: &Pass, b: &Pass| a.continues.as_deref() == Some(b.name.as_str());
        if w[0].0 == w[1].0 && !continuing(w[0].1, w[1].1) && !continuing(w[1].1, w[0].1) {
            problems.push((
                w[1].1.node.clone(),
                format!(
                    "random passes `{}` and `{}` hash to the same stream {:#010x}; rename one of them",
                    w[0].1.name, w[1].1.name, w[0].0
                ),
            ));
        }
    }
    match problems.len() {
        0 => Ok(()),
        _ => Err(GraphError::Expand {
            node: problems[0].0.clone(),
            message: problems.into_iter().map(|(_, m)| m).collect::<Vec<_>>().join("\n"),
        }),
    }
}

/// Bytes one pixel of `format` takes in a buffer: 4 bytes per component, tightly packed (the CPU
/// backend's `Vec<[f32; N]>` and the wgpu backend's storage buffers alike; no vec3 padding).
pub fn bytes_per_pixel(format: Format) -> u64 {
    format.components() as u64 * 4
}

/// The buffer memory of a schedule at one image size, in bytes, by what holds it. Each figure is
/// `pixels × bytes per pixel` summed over the buffers named; see [`Schedule::peak_bytes`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BufferBytes {
    /// The pool: one buffer per physical slot (all slots are filled by the end of a run).
    pub pool: u64,
    /// The most one pass writes: a pass's outputs exist before its slots' previous occupants are
    /// dropped, so for a moment they come on top of the pool.
    pub pass_outputs: u64,
    /// The copies of the sink inputs a run hands back.
    pub sinks: u64,
    /// Every live buffer at once, without pooling (the parity harness keeps them all).
    pub unpooled: u64,
    /// The most one pass binds (reads + writes): what running a single pass on a device holds.
    pub pass_bindings: u64,
    /// The previous-frame copies a run hands back for the next frame ([`Schedule::history`]'s sources):
    /// what a sequence keeps between two frames besides the sink copies.
    pub history: u64,
}

impl Schedule {
    /// The buffer memory of this schedule at `width × height` (saturating, never overflowing).
    pub fn buffer_bytes(&self, width: u32, height: u32) -> BufferBytes {
        let pixels = u64::from(width) * u64::from(height);
        let of = |f: Format, layers: u32| pixels.saturating_mul(u64::from(layers)).saturating_mul(bytes_per_pixel(f));
        let of_buffer = |id: &BufferId| self.buffers.get(id.0).map_or(0, |b| of(b.format, b.layers));
        let sum = |it: &mut dyn Iterator<Item = u64>| it.fold(0u64, u64::saturating_add);
        BufferBytes {
            pool: sum(&mut self.slot_formats.iter().zip(&self.slot_layers).map(|(f, n)| of(*f, *n))),
            pass_outputs: self
                .passes
                .iter()
                .map(|p| sum(&mut p.writes.iter().map(|(_, id)| of_buffer(id))))
                .max()
                .unwrap_or(0),
            sinks: sum(&mut self.sink_inputs.iter().map(|(_, _, id)| of_buffer(id))),
            unpooled: sum(&mut self.live_buffers().map(|id| of_buffer(&id))),
            pass_bindings: self
                .passes
                .iter()
                .map(|p| sum(&mut p.reads.iter().chain(&p.writes).map(|(_, id)| of_buffer(id))))
                .max()
                .unwrap_or(0),
            history: sum(&mut self.history.iter().map(|h| of_buffer(&h.source))),
        }
    }

    /// Peak bytes of the buffers of one run at `width × height` on a backend that follows the pool
    /// plan: the pool, plus one pass's outputs in flight, plus the sink copies handed back. Scene
    /// data and image files come on top; the caller (who knows them) adds them.
    pub fn peak_bytes(&self, width: u32, height: u32) -> u64 {
        let b = self.buffer_bytes(width, height);
        b.pool.saturating_add(b.pass_outputs).saturating_add(b.sinks)
    }

    /// Number of physical buffers the pool plan needs.
    pub fn physical_allocations(&self) -> usize {
        self.slot_formats.len()
    }

    /// The buffer handed to sink `node`'s input `port`, if connected.
    pub fn sink(&self, node: &str, port: &str) -> Option<BufferId> {
        self.sink_inputs.iter().find(|(n, p, _)| n == node && p == port).map(|(_, _, id)| *id)
    }

    /// Buffers that are scheduled (not culled), in id order.
    pub fn live_buffers(&self) -> impl Iterator<Item = BufferId> + '_ {
        (0..self.buffers.len()).filter(|&b| self.lifetimes[b].is_some()).map(BufferId)
    }

    /// Human-readable schedule: passes, buffers with lifetimes and slots, culled passes.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let name_w = self.passes.iter().map(|p| p.name.len()).max().unwrap_or(4).max(4);
        let kern_w = self.passes.iter().map(|p| p.kernel.len()).max().unwrap_or(6).max(6);
        let bname = |id: &BufferId| self.buffers.get(id.0).map_or("?", |b| b.name.as_str()).to_string();
        let _ = writeln!(s, "passes ({}):", self.passes.len());
        let _ = writeln!(s, "  {:>3}  {:12}  {:name_w$}  {:kern_w$}  reads -> writes", "#", "stage", "pass", "kernel");
        for (i, p) in self.passes.iter().enumerate() {
            let reads: Vec<String> = p.reads.iter().map(|(b, id)| format!("{b}={}", bname(id))).collect();
            let writes: Vec<String> = p.writes.iter().map(|(b, id)| format!("{b}={}", bname(id))).collect();
            let random = if p.random { "  (random)" } else { "" };
            let _ = writeln!(
                s,
                "  {i:>3}  {:12}  {:name_w$}  {:kern_w$}  [{}] -> [{}]{random}",
                p.stage.name(),
                p.name,
                p.kernel,
                reads.join(", "),
                writes.join(", ")
            );
        }
        let buf_w = self.buffers.iter().map(|b| b.name.len()).max().unwrap_or(6).max(6);
        let _ =
            writeln!(s, "buffers ({} logical, {} physical):", self.live_buffers().count(), self.physical_allocations());
        let _ = writeln!(s, "  {:buf_w$}  {:9}  {:9}  slot", "buffer", "format", "lifetime");
        for (b, info) in self.buffers.iter().enumerate() {
            let (life, slot) = match (self.lifetimes[b], self.slots[b]) {
                (Some(l), Some(sl)) => (format!("{}..={}", l.first, l.last), sl.to_string()),
                _ => ("culled".to_string(), "-".to_string()),
            };
            let sink = if self.sink_inputs.iter().any(|(_, _, id)| id.0 == b) { "  (sink)" } else { "" };
            let _ = writeln!(s, "  {:buf_w$}  {:9}  {:9}  {slot}{sink}", info.name, info.shape(), life);
        }
        if !self.culled.is_empty() {
            let _ = writeln!(s, "culled ({}): {}", self.culled.len(), self.culled.join(", "));
        }
        s
    }

    /// Graphviz DOT: passes as boxes (`name\nkernel`), live buffers as ellipses with their format,
    /// edges writer → buffer → reader, sink inputs as double ellipses.
    pub fn to_dot(&self) -> String {
        fn esc(s: &str) -> String {
            s.replace('\\', "\\\\").replace('"', "\\\"")
        }
        let mut s = String::from("digraph wedge {\n  rankdir=LR;\n");
        let mut shown: HashSet<usize> = HashSet::new();
        for (i, p) in self.passes.iter().enumerate() {
            let _ = writeln!(s, "  p{i} [shape=box, label=\"{}\\n{}\\n[{}]\"];", esc(&p.name), esc(&p.kernel), p.stage);
            for (_, id) in p.reads.iter().chain(&p.writes) {
                shown.insert(id.0);
            }
        }
        let mut shown: Vec<usize> = shown.into_iter().collect();
        shown.sort_unstable();
        for b in shown {
            let info = &self.buffers[b];
            let sink = self.sink_inputs.iter().any(|(_, _, id)| id.0 == b);
            let slot = self.slots[b].map(|s| format!(" [slot {s}]")).unwrap_or_default();
            let _ = writeln!(
                s,
                "  b{b} [shape={}, label=\"{}\\n{}{slot}\"];",
                if sink { "ellipse, peripheries=2" } else { "ellipse" },
                esc(&info.name),
                info.shape()
            );
        }
        for (i, p) in self.passes.iter().enumerate() {
            for (binding, id) in &p.reads {
                let _ = writeln!(s, "  b{} -> p{i} [label=\"{}\"];", id.0, esc(binding));
            }
            for (binding, id) in &p.writes {
                let _ = writeln!(s, "  p{i} -> b{} [label=\"{}\"];", id.0, esc(binding));
            }
        }
        s.push_str("}\n");
        s
    }
}

/// What a change re-runs (issue 38, `wedge view`): passes downstream of a change, from the passes'
/// buffer reads and writes. Buffers are matched across schedules by name, which is unique in a
/// pipeline and stable across rebuilds (a pass's buffer ids are not).
impl Schedule {
    /// Per scheduled pass, whether it must run again when the passes `changed` picks do: those
    /// passes and every pass reading, transitively, a buffer one of them writes. Passes are in
    /// dependency order, so one sweep sees every writer before its readers.
    pub fn downstream(&self, changed: impl Fn(&Pass) -> bool) -> Vec<bool> {
        let mut dirty_buffer = vec![false; self.buffers.len()];
        self.passes
            .iter()
            .map(|p| {
                let dirty = changed(p) || p.reads.iter().any(|(_, id)| dirty_buffer[id.0]);
                if dirty {
                    p.writes.iter().for_each(|(_, id)| dirty_buffer[id.0] = true);
                }
                dirty
            })
            .collect()
    }

    /// The passes of node `node` and every pass downstream of them.
    pub fn downstream_of_node(&self, node: &str) -> Vec<bool> {
        self.downstream(|p| p.node == node)
    }

    /// Per pass of this schedule, whether it must run again after `old` ran: a pass with no equal
    /// in `old` (by name: kernel, parameters, stage, randomness and bindings, with the bound
    /// buffers' names, formats and layers) and everything downstream of one. The others, run with
    /// the same scene, camera, size, seed and frame, write what they wrote in `old`'s run.
    pub fn changed_since(&self, old: &Schedule) -> Vec<bool> {
        self.downstream(|p| !old.passes.iter().any(|q| q.name == p.name && self.same_pass(p, old, q)))
    }

    /// Pass `p` of this schedule and pass `q` of `other` do the same work on the same buffers.
    fn same_pass(&self, p: &Pass, other: &Schedule, q: &Pass) -> bool {
        let same_buffer = |a: &BufferId, b: &BufferId| {
            let (a, b) = (&self.buffers[a.0], &other.buffers[b.0]);
            a.name == b.name && a.format == b.format && a.layers == b.layers
        };
        let same_bindings = |x: &[(String, BufferId)], y: &[(String, BufferId)]| {
            x.len() == y.len() && x.iter().zip(y).all(|((n, a), (m, b))| n == m && same_buffer(a, b))
        };
        p.kernel == q.kernel
            && p.params == q.params
            && p.stage == q.stage
            && p.random == q.random
            && p.continues == q.continues
            && same_bindings(&p.reads, &q.reads)
            && same_bindings(&p.writes, &q.writes)
    }
}
