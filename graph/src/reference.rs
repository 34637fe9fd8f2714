//! References from the same graph: [`reference()`] turns a pipeline's own expansion into its plain
//! Monte Carlo reference, driven by each pass's declared [`Reference`] role — so every node
//! combination, including nodes written outside wedge, gets a reference with no code of its own.
//!
//! - **Filters** (`Reference::Bypass { input }`) disappear: whatever read their output reads their
//!   input instead (a chain of filters collapses to the unfiltered value).
//! - **Count** passes (`Reference::Count`, per-pixel sample counts) are replaced by the shared kernel
//!   `fill.constant` writing the reference count `N` into each count buffer.
//! - **CountPerPrimary** passes (secondary samples per primary path) are replaced the same way by
//!   `fill.constant` writing 1: each of the reference's N paths takes one secondary sample.
//! - **Fill** passes (`Reference::Fill(v)`, a `u32` per-pixel decision such as a factoring flag) are
//!   replaced the same way by `fill.constant` writing `v` (a Ch. 5 reference composes every
//!   component's `L`: its flags are 0).
//! - A count or fill pass that also writes other outputs (a bandwidth pass that sets adaptive counts
//!   beside its filter widths, e.g. Environment with `adaptive`) keeps running for those outputs; only
//!   its `u32` writes are taken over by `fill.constant` (the pass writes them into buffers nothing
//!   reads).
//! - **Sample** passes take `count = N` and the reference's `sampling`; a **Continued** first pass
//!   takes `count = 0`, so the pass that continues it draws all `N` samples as one set: a stratified
//!   reference is N jointly stratified samples (per light, per component), an independent one N
//!   independent samples — not the pipeline's first set plus a separately stratified rest.
//! - Sink inputs written by `Bandwidth`/`Counts` passes (filter widths, ray counts: diagnostics of the
//!   filtering) are not handed back, so what only the filters needed is culled by the scheduler.
//!
//! A random pass without a sampling role (or `Bypass`: a filter drawing its own numbers), or a
//! `Filter`-stage pass without `Bypass`, is an error: a reference must never silently keep the
//! pipeline's adaptive counts or its filters.

use std::collections::BTreeMap;

use crate::decl::{Format, ParamValue};
use crate::expand::{BufferId, Expansion, Pass};
use crate::stage::{Reference, Stage};
use crate::GraphError;

/// The kernel that writes a constant into a per-pixel `u32` buffer (binding `out`, parameter `value`).
pub const FILL_CONSTANT: &str = "fill.constant";

/// Sample placement of a reference.
pub const REFERENCE_SAMPLING: [&str; 2] = ["stratified", "independent"];

/// The plain Monte Carlo reference of an expansion: `spp` samples per pixel (per light, per
/// component) placed by `sampling` (`stratified` or `independent`), filters bypassed.
pub fn reference(e: Expansion, spp: u32, sampling: &str) -> Result<Expansion, GraphError> {
    let err = |node: &str, message: String| GraphError::Expand { node: node.to_string(), message };
    if !REFERENCE_SAMPLING.contains(&sampling) {
        return Err(err("reference", format!("sampling `{sampling}` is not stratified or independent")));
    }
    if spp == 0 {
        return Err(err("reference", "a reference needs at least 1 sample per pixel".into()));
    }
    let Expansion { mut buffers, passes, outputs, sink_inputs, history } = e;

    // Every pass's role must make sense before anything is rewritten; report all problems at once.
    let mut problems: Vec<(String, String)> = Vec::new();
    for p in &passes {
        let role = p.reference;
        // A filter that draws its own numbers (light-field reconstruction rays) is bypassed in a
        // reference, so its numbers never reach one: `Bypass` is a role for a random pass too.
        if p.random && !matches!(role, Reference::Sample | Reference::Continued | Reference::Bypass { .. }) {
            problems.push((
                p.node.clone(),
                format!(
                    "pass `{}` draws random numbers but declares no sampling role for references; add \
                     `.reference(Reference::Sample)` (or `Continued` for a first pass a later pass continues)",
                    p.name
                ),
            ));
        }
        check_bypass(p, &buffers, &mut problems);
        if matches!(role, Reference::Count | Reference::CountPerPrimary | Reference::Fill(_))
            && !p.writes.iter().any(|(_, id)| buffers[id.0].format == Format::U32)
        {
            problems.push((
                p.node.clone(),
                format!("count or fill pass `{}` writes no u32 buffer: a count or decision it could stand for", p.name),
            ));
        }
    }
    report(problems)?;
    let alias = Bypasses::of(&passes);
    let resolve = |id| alias.resolve(id);

    let count = ParamValue::Int(i64::from(spp));
    let mut out_passes: Vec<Pass> = Vec::with_capacity(passes.len());
    let mut writer_stage: BTreeMap<BufferId, Stage> = BTreeMap::new();
    for p in passes {
        match p.reference {
            Reference::Bypass { .. } => continue,
            Reference::Count | Reference::CountPerPrimary | Reference::Fill(_) => {
                let value = match p.reference {
                    Reference::Count => count.clone(),
                    Reference::Fill(v) => ParamValue::Int(i64::from(v)),
                    _ => ParamValue::Int(1),
                };
                let counts: Vec<bool> = p.writes.iter().map(|(_, id)| buffers[id.0].format == Format::U32).collect();
                let many = p.writes.len() > 1;
                for ((binding, id), _) in p.writes.iter().zip(&counts).filter(|(_, c)| **c) {
                    let name = if many { format!("{}[{binding}]", p.name) } else { p.name.clone() };
                    let mut fill = Pass::new(&name, &p.node, FILL_CONSTANT, p.stage);
                    fill.writes.push(("out".into(), *id));
                    fill.params.insert("value".into(), value.clone());
                    writer_stage.insert(*id, p.stage);
                    out_passes.push(fill);
                }
                if counts.iter().all(|c| *c) {
                    continue;
                }
                // The pass's other outputs are still needed: it runs, its counts going nowhere.
                let mut p = p;
                for ((_, id), _) in p.writes.iter_mut().zip(&counts).filter(|(_, c)| **c) {
                    let mut spare = buffers[id.0].clone();
                    spare.name = format!("{}@unused_in_reference", spare.name);
                    buffers.push(spare);
                    *id = BufferId(buffers.len() - 1);
                }
                for (_, id) in p.reads.iter_mut() {
                    *id = resolve(*id);
                }
                for (_, id) in &p.writes {
                    writer_stage.insert(*id, p.stage);
                }
                out_passes.push(p);
                continue;
            }
            _ => {}
        }
        let mut p = p;
        for (_, id) in p.reads.iter_mut() {
            *id = resolve(*id);
        }
        match p.reference {
            Reference::Sample => {
                p.params.insert("count".into(), count.clone());
                p.params.insert("sampling".into(), ParamValue::Str(sampling.into()));
            }
            Reference::Continued => {
                p.params.insert("count".into(), ParamValue::Int(0));
                p.params.insert("sampling".into(), ParamValue::Str(sampling.into()));
            }
            _ => {}
        }
        for (_, id) in &p.writes {
            writer_stage.insert(*id, p.stage);
        }
        out_passes.push(p);
    }

    let outputs = outputs.into_iter().map(|(k, id)| (k, resolve(id))).collect();
    let sink_inputs = sink_inputs
        .into_iter()
        .map(|(node, port, id)| (node, port, resolve(id)))
        .filter(|(_, _, id)| !matches!(writer_stage.get(id), Some(Stage::Bandwidth | Stage::Counts)))
        .collect();
    Ok(Expansion { buffers, passes: out_passes, outputs, sink_inputs, history })
}

/// The pipeline's image at **equal rays without its filters**: every filter pass
/// (`Reference::Bypass`) removed and its readers reading its input, while the sampling passes, their
/// adaptive counts and every decision (factoring flags) stay as the pipeline made them. The baseline a
/// filter must beat (issue 34: "its filtered image has lower RMSE than its unfiltered one at equal
/// rays"); `wedge render --unfiltered` writes it for any pipeline, a user's nodes included.
pub fn unfiltered(e: Expansion) -> Result<Expansion, GraphError> {
    let Expansion { buffers, passes, outputs, sink_inputs, history } = e;
    let mut problems: Vec<(String, String)> = Vec::new();
    for p in &passes {
        check_bypass(p, &buffers, &mut problems);
    }
    report(problems)?;
    let alias = Bypasses::of(&passes);
    let passes = passes
        .into_iter()
        .filter(|p| !matches!(p.reference, Reference::Bypass { .. }))
        .map(|mut p| {
            for (_, id) in p.reads.iter_mut() {
                *id = alias.resolve(*id);
            }
            p
        })
        .collect();
    let outputs = outputs.into_iter().map(|(k, id)| (k, alias.resolve(id))).collect();
    let sink_inputs = sink_inputs.into_iter().map(|(node, port, id)| (node, port, alias.resolve(id))).collect();
    // A temporal filter's own output fed back as its history: the unfiltered value instead.
    let history = history
        .into_iter()
        .map(|h| crate::expand::History { buffer: h.buffer, source: alias.resolve(h.source) })
        .collect();
    Ok(Expansion { buffers, passes, outputs, sink_inputs, history })
}

/// A filter pass must say what it stands for without filtering (`Bypass`), and that input must
/// have the format and layers of every buffer it writes.
fn check_bypass(p: &Pass, buffers: &[crate::expand::BufferInfo], problems: &mut Vec<(String, String)>) {
    if p.stage == Stage::Filter && !matches!(p.reference, Reference::Bypass { .. }) {
        problems.push((
            p.node.clone(),
            format!("filter pass `{}` must declare `.reference(Reference::Bypass {{ input: .. }})`", p.name),
        ));
    }
    let Reference::Bypass { input } = p.reference else { return };
    let Some(from) = p.read(input) else {
        problems
            .push((p.node.clone(), format!("pass `{}` bypasses to binding `{input}`, which it does not read", p.name)));
        return;
    };
    for (binding, id) in &p.writes {
        let (a, b) = (buffers[from.0].format, buffers[id.0].format);
        if a != b || buffers[from.0].layers != buffers[id.0].layers {
            problems.push((
                p.node.clone(),
                format!("pass `{}` bypasses `{binding}` ({b}) to `{input}` ({a}): the formats differ", p.name),
            ));
        }
    }
}

/// Every problem found, in one error naming the first node.
fn report(problems: Vec<(String, String)>) -> Result<(), GraphError> {
    match problems.first() {
        None => Ok(()),
        Some((node, _)) => Err(GraphError::Expand {
            node: node.clone(),
            message: problems.iter().map(|(_, m)| m.as_str()).collect::<Vec<_>>().join("\n"),
        }),
    }
}

/// Buffers written by a bypassed filter → the buffer it reads at `input`.
struct Bypasses(BTreeMap<BufferId, BufferId>);

impl Bypasses {
    /// From passes already checked by [`check_bypass`].
    fn of(passes: &[Pass]) -> Bypasses {
        let mut alias = BTreeMap::new();
        for p in passes {
            if let Reference::Bypass { input } = p.reference {
                let from = p.read(input).expect("checked by check_bypass");
                for (_, id) in &p.writes {
                    alias.insert(*id, from);
                }
            }
        }
        Bypasses(alias)
    }

    /// The buffer standing for `id` once every filter is gone (chains followed).
    fn resolve(&self, mut id: BufferId) -> BufferId {
        // Each step moves to a buffer written earlier in the DAG, so this ends.
        while let Some(next) = self.0.get(&id) {
            id = *next;
        }
        id
    }
}
