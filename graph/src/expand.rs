//! Expansion of validated effect nodes into passes (kajiya-rg style: a small fluent builder).
//!
//! A pass is started with its stage, `ctx.pass(name, kernel, Stage::Filter)`, so none is without
//! one; the builder then takes bindings, parameters, `.random()` (the graph assigns the pass's
//! `stream`: [`crate::stage::stream_id`] of `<node>.<pass>`; effect files never write a stream
//! number) and `.reference(role)` (what the pass does in the pipeline's Monte Carlo reference,
//! [`crate::reference()`]; `Reference::Keep` when not given).
//!
//! Every buffer is written by exactly one pass (single assignment), so the pass DAG follows from the
//! buffers alone: an edge runs from a buffer's writer to each of its readers. A node sees its inputs as
//! buffer handles resolved from the wiring, creates node-local buffers by writing them, and binds each
//! declared output port to one of its buffers.

use std::collections::BTreeMap;

use crate::decl::{Format, ParamValue};
use crate::factoring::Factoring;
use crate::sampler::{CountRequest, SamplerPass, SamplerPlan, SamplerRequest};
use crate::stage::{stream_id, Reference, Stage};
use crate::GraphError;

/// Handle to a buffer in an [`Expansion`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BufferId(pub usize);

#[derive(Clone, Debug)]
pub struct BufferInfo {
    /// `<node>.<name>`, unique in the pipeline.
    pub name: String,
    pub format: Format,
    /// Elements per pixel: 1 for an image; `n` for a per-sample buffer (`n` records per pixel, pixel
    /// `p`'s at `p·n .. p·n + n`, e.g. a node's stored samples) or a structure sized by the image
    /// (a tree over those samples). See [`ExpandCtx::layered_buffer`].
    pub layers: u32,
}

impl BufferInfo {
    /// The element format, with ` × N per pixel` for a per-sample buffer (schedule tables, DOT).
    pub fn shape(&self) -> String {
        if self.layers == 1 {
            self.format.to_string()
        } else {
            format!("{} × {} per pixel", self.format, self.layers)
        }
    }
    /// An image buffer (one element per pixel).
    pub fn new(name: impl Into<String>, format: Format) -> BufferInfo {
        BufferInfo { name: name.into(), format, layers: 1 }
    }
}

/// One kernel invocation with its bindings and parameter block.
#[derive(Clone, Debug)]
pub struct Pass {
    /// `<node>.<pass>`, unique in the pipeline.
    pub name: String,
    pub node: String,
    /// Registered kernel name, e.g. `filter.gaussian_x`.
    pub kernel: String,
    /// Binding name (as the kernel declares it) → buffer.
    pub reads: Vec<(String, BufferId)>,
    pub writes: Vec<(String, BufferId)>,
    pub params: BTreeMap<String, ParamValue>,
    /// The stage it runs in; the scheduler orders by stage first.
    pub stage: Stage,
    /// Draws random numbers: its `stream` parameter is [`stream_id`] of `name`, set by the graph.
    pub random: bool,
    /// What it does in a reference render.
    pub reference: Reference,
    /// The full name of the earlier pass whose random sequences this one continues (it takes that
    /// pass's stream, so the two passes' samples are one progressive set); `None` for its own stream.
    pub continues: Option<String>,
}

impl Pass {
    /// A pass with no bindings or parameters (tools and tests; effects use [`ExpandCtx::pass`]).
    pub fn new(name: &str, node: &str, kernel: &str, stage: Stage) -> Pass {
        Pass {
            name: name.to_string(),
            node: node.to_string(),
            kernel: kernel.to_string(),
            reads: Vec::new(),
            writes: Vec::new(),
            params: BTreeMap::new(),
            stage,
            random: false,
            reference: Reference::Keep,
            continues: None,
        }
    }
    pub fn read(&self, binding: &str) -> Option<BufferId> {
        self.reads.iter().find(|(b, _)| b == binding).map(|(_, id)| *id)
    }
    pub fn write(&self, binding: &str) -> Option<BufferId> {
        self.writes.iter().find(|(b, _)| b == binding).map(|(_, id)| *id)
    }
}

/// A buffer that holds, in a sequence of frames, another buffer's contents from the previous frame
/// ([`ExpandCtx::previous_frame`]): no pass writes it; whoever runs the frames fills it before the run
/// (zeros for the first frame) from what the previous run handed back for `source`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct History {
    pub buffer: BufferId,
    pub source: BufferId,
}

/// All passes and buffers of a pipeline, before culling and scheduling.
#[derive(Clone, Debug, Default)]
pub struct Expansion {
    pub buffers: Vec<BufferInfo>,
    pub passes: Vec<Pass>,
    /// `(node, port)` → buffer, for every output port bound by its node.
    pub outputs: BTreeMap<(String, String), BufferId>,
    /// Sink inputs: `(sink node, input port)` → buffer. These are the roots of culling and what a
    /// run hands back.
    pub sink_inputs: Vec<(String, String, BufferId)>,
    /// Previous-frame buffers and the buffers they are copied from between frames.
    pub history: Vec<History>,
}

impl Expansion {
    pub fn buffer(&self, id: BufferId) -> &BufferInfo {
        &self.buffers[id.0]
    }
    pub fn find_buffer(&self, name: &str) -> Option<BufferId> {
        self.buffers.iter().position(|b| b.name == name).map(BufferId)
    }
}

/// What [`crate::NodeKind::expand`] sees of the pipeline: its own name, parameters (validated,
/// defaults filled in), the buffers wired to its inputs, and a builder for its passes.
pub struct ExpandCtx<'a> {
    pub(crate) node: &'a str,
    pub(crate) params: &'a BTreeMap<String, ParamValue>,
    pub(crate) inputs: &'a BTreeMap<String, BufferId>,
    pub(crate) expansion: &'a mut Expansion,
    /// The shared sampler's requests so far ([`crate::sampler`]); `None` outside [`crate::expand()`].
    pub(crate) sampler: Option<&'a mut SamplerPlan>,
    /// The pipeline's factoring node ([`crate::factoring`]), if any, and its kind.
    pub(crate) factoring: Option<(&'a Factoring, &'a dyn crate::NodeKind)>,
    /// The light terms the validator worked out for every output ([`crate::terms`]); `None` for a
    /// context built by hand.
    pub(crate) terms: Option<&'a crate::terms::TermReport>,
    /// The pipeline's `camera:` block and the loaded scene's facts ([`ExpandCtx::own_camera`]).
    pub(crate) camera: (Option<&'a crate::pipeline::CameraSpec>, Option<crate::factoring::SceneFacts>),
    /// Parameters the node read without declaring them ([`ExpandCtx::param`]); the expansion fails
    /// naming them ([`ExpandCtx::check_params`]) instead of panicking.
    undeclared: std::cell::RefCell<Vec<String>>,
}

/// The pipeline's sampler plan, or the refusal of a node that `does` something with it outside a
/// pipeline expansion (a context built by hand without [`ExpandCtx::with_sampler`]).
fn in_expansion<'p>(
    node: &str,
    plan: Option<&'p mut SamplerPlan>,
    does: &str,
) -> Result<&'p mut SamplerPlan, GraphError> {
    plan.ok_or_else(|| GraphError::Expand {
        node: node.to_string(),
        message: format!("{does} outside a pipeline expansion"),
    })
}

/// What [`ExpandCtx::param`] hands a node for an undeclared name while the expansion runs on to
/// its error (never used: the expansion is refused).
static UNDECLARED: ParamValue = ParamValue::Str(String::new());

impl<'a> ExpandCtx<'a> {
    /// Build a context by hand (tests, tools). Normally [`crate::expand()`] makes these.
    pub fn new(
        node: &'a str,
        params: &'a BTreeMap<String, ParamValue>,
        inputs: &'a BTreeMap<String, BufferId>,
        expansion: &'a mut Expansion,
    ) -> Self {
        ExpandCtx {
            node,
            params,
            inputs,
            expansion,
            sampler: None,
            factoring: None,
            terms: None,
            camera: (None, None),
            undeclared: Default::default(),
        }
    }
    /// Refuse an expansion that read parameters its node does not declare (a bug in the node kind,
    /// reported with the fix rather than a panic).
    pub fn check_params(&self) -> Result<(), GraphError> {
        let undeclared = self.undeclared.borrow();
        if undeclared.is_empty() {
            return Ok(());
        }
        let declared: Vec<&str> = self.params.keys().map(String::as_str).collect();
        Err(GraphError::Expand {
            node: self.node.to_string(),
            message: format!(
                "reads undeclared parameter(s) {}: declare them in the node kind's params() (declared: {})",
                undeclared.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", "),
                if declared.is_empty() { "none".to_string() } else { declared.join(", ") }
            ),
        })
    }
    /// A context that sees the pipeline's factoring node and its kind (tests, tools;
    /// [`crate::expand()`] sets it).
    pub fn with_factoring(mut self, factoring: Option<(&'a Factoring, &'a dyn crate::NodeKind)>) -> Self {
        self.factoring = factoring;
        self
    }
    /// The pipeline's factoring node and its settings ([`crate::factoring`]): a component node
    /// that sees one renders its component for it instead of filtering on its own.
    pub fn factoring(&self) -> Option<&'a Factoring> {
        self.factoring.map(|(f, _)| f)
    }
    /// A context that sees the pipeline's camera block and the scene's facts (tests, tools;
    /// [`crate::expand()`] sets it).
    pub fn with_camera(
        mut self,
        camera: Option<&'a crate::pipeline::CameraSpec>,
        scene: Option<crate::factoring::SceneFacts>,
    ) -> Self {
        self.camera = (camera, scene);
        self
    }
    /// The camera this node's own camera paths take ([`crate::factoring::CameraSettings::own_paths`]):
    /// the factoring node's, else the pipeline's camera block's lens and shutter.
    pub fn own_camera(&self) -> crate::factoring::CameraSettings {
        crate::factoring::CameraSettings::own_paths(self.factoring(), self.camera.0, self.camera.1.as_ref())
    }
    /// The camera block samples a lens or a shutter and no factoring node filters them
    /// ([`crate::factoring::CameraSettings::unfiltered`]).
    pub fn plain_camera(&self) -> bool {
        crate::factoring::CameraSettings::unfiltered(self.factoring(), self.camera.0, self.camera.1.as_ref())
    }
    /// A context that sees the validator's light terms (tests, tools; [`crate::expand()`] sets it).
    pub fn with_terms(mut self, terms: &'a crate::terms::TermReport) -> Self {
        self.terms = Some(terms);
        self
    }
    /// The light terms this node's output `port` declares ([`crate::NodeKind::terms`], as the
    /// validator checked them), so an expansion renders what its declaration says — e.g. a factoring
    /// node adds the emission its camera rays see only where its image declares that term. `None`:
    /// no terms declared, or a context built without them.
    pub fn output_terms(&self, port: &str) -> Option<&'a crate::terms::Terms> {
        self.terms?.of(self.node, port)
    }
    /// Render lighting component `component` of this node for the pipeline's factoring node: its
    /// kind's [`crate::NodeKind::expand_component`] adds the passes and binds this node's ports.
    pub fn component(&mut self, component: &crate::factoring::Component) -> Result<(), GraphError> {
        let Some((f, kind)) = self.factoring else {
            return Err(GraphError::Expand {
                node: self.node.to_string(),
                message: format!(
                    "declares lighting component `{}` but the pipeline has no factoring node",
                    component.name
                ),
            });
        };
        kind.expand_component(self, f, component)
    }
    /// A context whose node can ask for the shared sampler ([`ExpandCtx::sampler`]).
    pub fn with_sampler(mut self, plan: &'a mut SamplerPlan) -> Self {
        self.sampler = Some(plan);
        self
    }
    fn plan(&mut self) -> Result<&mut SamplerPlan, GraphError> {
        in_expansion(self.node, self.sampler.as_deref_mut(), "asks for the shared sampler")
    }
    /// Ask for the shared sampler with these estimators and settings (merged with other nodes':
    /// identical settings shared, a conflicting one an error naming both nodes).
    pub fn sampler(&mut self, request: SamplerRequest) -> Result<(), GraphError> {
        let node = self.node;
        self.plan()?.request(node, request)
    }
    /// A handle to one of the sampler's resolved outputs after its first or its final pass.
    pub fn sampler_output(&mut self, pass: SamplerPass, name: &str) -> Result<BufferId, GraphError> {
        let node = self.node;
        in_expansion(node, self.sampler.as_deref_mut(), "reads a sampler output")?.output(
            node,
            self.expansion,
            pass,
            name,
        )
    }
    /// Submit this node's per-pixel counts for the adaptive pass (buffers it writes in
    /// `Stage::Bandwidth`).
    pub fn sampler_counts(&mut self, request: CountRequest) -> Result<(), GraphError> {
        let node = self.node;
        in_expansion(node, self.sampler.as_deref_mut(), "submits sampler counts")?.counts(node, self.expansion, request)
    }
    /// Publish a lighting component's first-pass factoring flag (a u32 buffer, nonzero where the
    /// component's radiance factors, thesis eq. 5.30) for the factoring node: called from the
    /// factoring node kind's `expand_component`, which renders the component. The factoring node
    /// expands after the components wired into it and reads them with
    /// [`ExpandCtx::factoring_flags`].
    pub fn publish_factoring_flag(&mut self, flag: BufferId) -> Result<(), GraphError> {
        let node = self.node;
        in_expansion(node, self.sampler.as_deref_mut(), "publishes a factoring flag")?.publish_flag(
            node,
            self.expansion,
            flag,
        )
    }
    /// The factoring flags the components published ([`ExpandCtx::publish_factoring_flag`]), in
    /// expansion order: every component wired into the node asking has published by then.
    pub fn factoring_flags(&self) -> Vec<BufferId> {
        self.sampler.as_deref().map_or_else(Vec::new, |p| p.factoring_flags.iter().map(|(_, b)| *b).collect())
    }
    pub fn node(&self) -> &str {
        self.node
    }
    /// The buffer wired to an input port; `None` for an unconnected optional input.
    pub fn input(&self, port: &str) -> Option<BufferId> {
        self.inputs.get(port).copied()
    }
    /// The buffer wired to a required input port (validation guarantees it is there).
    pub fn required(&self, port: &str) -> Result<BufferId, GraphError> {
        self.input(port).ok_or_else(|| GraphError::Expand {
            node: self.node.to_string(),
            message: format!("input `{port}` is not connected"),
        })
    }
    /// A declared parameter's value (validated, default filled in). An undeclared name is recorded
    /// and fails the node's expansion ([`ExpandCtx::check_params`]).
    pub fn param(&self, name: &str) -> &ParamValue {
        self.params.get(name).unwrap_or_else(|| {
            self.undeclared.borrow_mut().push(name.to_string());
            &UNDECLARED
        })
    }
    pub fn params(&self) -> &BTreeMap<String, ParamValue> {
        self.params
    }
    pub fn format_of(&self, id: BufferId) -> Format {
        self.expansion.buffers[id.0].format
    }
    /// A node-local buffer, named `<node>.<name>`.
    pub fn buffer(&mut self, name: &str, format: Format) -> BufferId {
        self.layered_buffer(name, format, 1)
    }
    /// A node-local buffer of `layers` elements per pixel (at least 1): per-sample records (`n`
    /// samples per pixel) or a structure over them (a tree of at most `2n` nodes per pixel). Kernels
    /// index element `s` of pixel `p` as `p·layers + s`. Such a buffer stays inside its node: an
    /// output port or a sink input must be an image (the scheduler refuses a layered one).
    pub fn layered_buffer(&mut self, name: &str, format: Format, layers: u32) -> BufferId {
        let full = format!("{}.{name}", self.node);
        self.expansion.buffers.push(BufferInfo { name: full, format, layers: layers.max(1) });
        BufferId(self.expansion.buffers.len() - 1)
    }
    /// Elements per pixel of a buffer ([`BufferInfo::layers`]).
    pub fn layers_of(&self, id: BufferId) -> u32 {
        self.expansion.buffers[id.0].layers
    }
    /// Start a pass named `<node>.<name>` running `kernel` in `stage`.
    pub fn pass(&mut self, name: &str, kernel: &str, stage: Stage) -> PassBuilder<'_, 'a> {
        PassBuilder { ctx: self, pass: Pass::new("", "", kernel, stage), local_name: name.to_string() }
    }
    /// A buffer holding `source`'s contents from the previous frame of a sequence (all zeros in the
    /// first frame and in single images: a kernel reading it must treat zeros as "no history", e.g.
    /// through a position whose `w` marks no hit). No pass writes it; the runner fills it between
    /// frames, so the pass writing `source` is kept (not culled) while this buffer is read. Asking
    /// twice for the same source gives the same buffer.
    pub fn previous_frame(&mut self, source: BufferId) -> BufferId {
        if let Some(h) = self.expansion.history.iter().find(|h| h.source == source) {
            return h.buffer;
        }
        let BufferInfo { name, format, layers } = self.expansion.buffers[source.0].clone();
        self.expansion.buffers.push(BufferInfo { name: format!("{name}@previous_frame"), format, layers });
        let buffer = BufferId(self.expansion.buffers.len() - 1);
        self.expansion.history.push(History { buffer, source });
        buffer
    }
    /// Bind a declared output port to a buffer.
    pub fn output(&mut self, port: &str, id: BufferId) {
        self.expansion.outputs.insert((self.node.to_string(), port.to_string()), id);
    }
}

/// Fluent builder for one pass; `finish()` adds it.
pub struct PassBuilder<'c, 'a> {
    ctx: &'c mut ExpandCtx<'a>,
    pass: Pass,
    local_name: String,
}

impl PassBuilder<'_, '_> {
    pub fn read(mut self, binding: &str, id: BufferId) -> Self {
        self.pass.reads.push((binding.to_string(), id));
        self
    }
    /// Read an optional input if it is connected.
    pub fn read_opt(self, binding: &str, id: Option<BufferId>) -> Self {
        match id {
            Some(id) => self.read(binding, id),
            None => self,
        }
    }
    /// Write a buffer made by [`ExpandCtx::buffer`]. Each buffer has exactly one writer.
    pub fn write(mut self, binding: &str, id: BufferId) -> Self {
        self.pass.writes.push((binding.to_string(), id));
        self
    }
    pub fn param(mut self, name: &str, value: ParamValue) -> Self {
        self.pass.params.insert(name.to_string(), value);
        self
    }
    pub fn float(self, name: &str, v: f64) -> Self {
        self.param(name, ParamValue::Float(v))
    }
    pub fn int(self, name: &str, v: i64) -> Self {
        self.param(name, ParamValue::Int(v))
    }
    /// Forward the node's own parameters (already validated) into the pass's parameter block.
    pub fn node_params(mut self, names: &[&str]) -> Self {
        for n in names {
            let v = self.ctx.param(n).clone();
            self.pass.params.insert((*n).to_string(), v);
        }
        self
    }
    /// The pass draws random numbers: the graph sets its `stream` parameter (see [`stream_id`]).
    pub fn random(mut self) -> Self {
        self.pass.random = true;
        self
    }
    /// The pass draws random numbers continuing the sequences of this node's earlier pass `first`
    /// (local name): it takes `first`'s stream, so its samples extend that pass's progressive set
    /// (e.g. an adaptive pass continuing a first pass's record).
    pub fn random_continuing(mut self, first: &str) -> Self {
        self.pass.random = true;
        self.pass.continues = Some(format!("{}.{first}", self.ctx.node));
        self
    }
    /// Its role in a reference render (default [`Reference::Keep`]).
    pub fn reference(mut self, role: Reference) -> Self {
        self.pass.reference = role;
        self
    }
    pub fn finish(mut self) {
        self.pass.name = format!("{}.{}", self.ctx.node, self.local_name);
        self.pass.node = self.ctx.node.to_string();
        if self.pass.random {
            let stream = stream_id(self.pass.continues.as_deref().unwrap_or(&self.pass.name));
            self.pass.params.insert("stream".into(), ParamValue::Int(i64::from(stream)));
        }
        self.ctx.expansion.passes.push(self.pass);
    }
}
