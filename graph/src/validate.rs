//! Parsing, validation and expansion of a pipeline.
//!
//! Validation checks a parsed [`Pipeline`] against the [`NodeRegistry`] and reports *every* problem in
//! one go, in file order, each pointing at the token that is wrong (the kind string, the input key,
//! the reference string, …) with a help line that says how to fix it. Reporting all problems at once
//! matters because a pipeline is edited by hand and re-running to discover the next mistake is slow.
//!
//! Only a pipeline without problems is ordered (topologically, ties in file order so the result is
//! stable under unrelated edits) and handed to [`expand`], which asks each node kind for its passes.

use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::camera_path::{camera_path_problems, PathProblem};
use crate::decl::{NodeKind, NodeRegistry, ParamDecl, ParamKind, ParamValue, PortDecl};
use crate::expand::{BufferId, ExpandCtx, Expansion};
use crate::explain::explain;
use crate::pipeline::{
    CameraSpec, Location, Pipeline, RawParam, MAX_NAME_CHARS, MAX_NODES, MAX_NODE_ENTRIES, MAX_PIPELINE_BYTES,
    MAX_SCENE_CHARS,
};
use crate::source_map::{NodeSource, Pos, SourceMap};
use crate::stage::Stage;
use crate::GraphError;

/// Largest admissible image side, and largest pixel count (2^26 = 64 Mpixel): buffers are
/// full-resolution, so this bounds memory per buffer (vec4 at 2^26 pixels is 1 GiB).
pub const MAX_SIDE: u32 = 16384;
pub const MAX_PIXELS: u64 = 1 << 26;

/// A parsed pipeline together with its source, so that validation can point into the file.
#[derive(Clone, Debug)]
pub struct LoadedPipeline {
    pub pipeline: Pipeline,
    pub path: PathBuf,
    pub source: String,
    /// Token positions of the parts of the file that validation may point at.
    pub(crate) map: SourceMap,
}

impl LoadedPipeline {
    /// Location of node `index`'s tuple (file order).
    pub fn node_location(&self, index: usize) -> Location {
        self.loc(self.map.nodes.get(index).map(|n| n.tuple))
    }

    /// Location of the `scene` value (the file's start where the field is left out).
    pub fn scene_location(&self) -> Location {
        self.loc(self.map.scene)
    }

    fn loc(&self, pos: Option<Pos>) -> Location {
        let pos = pos.unwrap_or(Pos { line: 1, col: 1 });
        Location { file: self.path.clone(), line: pos.line, col: pos.col }
    }

    fn node_src(&self, index: usize) -> NodeSource {
        self.map.nodes.get(index).cloned().unwrap_or_default()
    }
}

/// Parse pipeline text; `path` is only used for messages and relative paths.
///
/// A UTF-8 byte-order mark at the start (some Windows editors write one) is skipped. The size
/// limits ([`crate::pipeline::MAX_PIPELINE_BYTES`], [`MAX_NODES`], [`MAX_NODE_ENTRIES`],
/// [`MAX_NAME_CHARS`], [`MAX_SCENE_CHARS`]) are checked before parsing (text size) and right after
/// it (counts and lengths), so no later step sees an unbounded pipeline.
pub fn parse_pipeline(path: &Path, text: &str) -> Result<LoadedPipeline, GraphError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let at = |pos: Option<Pos>| {
        let pos = pos.unwrap_or(Pos { line: 1, col: 1 });
        Location { file: path.to_path_buf(), line: pos.line, col: pos.col }
    };
    if text.len() > MAX_PIPELINE_BYTES {
        return Err(file_too_large(path, text.len() as u64));
    }
    match ron::from_str::<Pipeline>(text) {
        Ok(pipeline) => {
            let map = SourceMap::build(text);
            check_limits(&pipeline, &map).map_err(|(pos, message, help)| GraphError::TooLarge {
                location: at(pos),
                message,
                help,
            })?;
            Ok(LoadedPipeline { pipeline, path: path.to_path_buf(), source: text.to_string(), map })
        }
        Err(e) => {
            let explained = explain(text, &e.code, Pos { line: e.span.start.line, col: e.span.start.col });
            Err(GraphError::Parse {
                location: at(Some(explained.pos)),
                message: explained.message,
                help: explained.help,
            })
        }
    }
}

fn file_too_large(path: &Path, bytes: u64) -> GraphError {
    GraphError::TooLarge {
        location: Location { file: path.to_path_buf(), line: 1, col: 1 },
        message: format!(
            "the pipeline file is {bytes} bytes, more than the limit of {MAX_PIPELINE_BYTES} bytes (1 MiB)"
        ),
        help: "a pipeline is a short text file of nodes (a few KiB); check that this is the right \
               file, and describe large scenes in a scene file instead"
            .into(),
    }
}

/// Counts and string lengths within the limits, else (where, what, fix).
fn check_limits(pl: &Pipeline, map: &SourceMap) -> Result<(), (Option<Pos>, String, String)> {
    if pl.nodes.len() > MAX_NODES {
        return Err((
            map.nodes_key,
            format!("the pipeline has {} nodes, more than the limit of {MAX_NODES}", pl.nodes.len()),
            format!("use at most {MAX_NODES} nodes (a render pipeline needs a handful)"),
        ));
    }
    let long = |what: &str, s: &str, limit: usize, pos: Option<Pos>| {
        let n = s.chars().count();
        if n > limit {
            Err((
                pos,
                format!("{what} is {n} characters long, more than the limit of {limit}"),
                format!("shorten {what} to at most {limit} characters"),
            ))
        } else {
            Ok(())
        }
    };
    long("`scene`", &pl.scene, MAX_SCENE_CHARS, None)?;
    for (i, n) in pl.nodes.iter().enumerate() {
        let src = map.nodes.get(i).cloned().unwrap_or_default();
        let tuple = (src.tuple.line > 0).then_some(src.tuple);
        let entries = n.params.len() + n.inputs.len();
        if entries > MAX_NODE_ENTRIES {
            return Err((
                tuple,
                format!(
                    "node {} has {entries} parameters and inputs, more than the limit of {MAX_NODE_ENTRIES}",
                    i + 1
                ),
                "give each parameter and input once; a node kind declares only a few".into(),
            ));
        }
        long("the node name", &n.name, MAX_NAME_CHARS, src.name.or(tuple))?;
        long("the node kind", &n.kind, MAX_NAME_CHARS, src.kind.or(tuple))?;
        for (j, (key, value)) in n.params.iter().enumerate() {
            let pos = src.params.get(j).copied().or(tuple);
            long("a parameter name", key, MAX_NAME_CHARS, pos)?;
            if let RawParam::Str(v) = value {
                long("a parameter value", v, MAX_NAME_CHARS, pos)?;
            }
        }
        for (j, (port, reference)) in n.inputs.iter().enumerate() {
            let pos = src.inputs.get(j).map(|&(k, _)| k).or(tuple);
            long("an input name", port, MAX_NAME_CHARS, pos)?;
            // A reference is `node.port`: two names and a dot.
            long("an input reference", reference, 2 * MAX_NAME_CHARS + 1, pos)?;
        }
    }
    Ok(())
}

/// Read and parse a pipeline file. Files larger than [`MAX_PIPELINE_BYTES`] are refused before
/// reading (and reading stops there even if the file grows or is a device such as `/dev/zero`).
pub fn load_pipeline(path: &Path) -> Result<LoadedPipeline, GraphError> {
    use std::io::Read;
    let io_err = |e: std::io::Error| GraphError::Io {
        path: path.display().to_string(),
        message: format!("cannot read pipeline file: {e}"),
    };
    let file = std::fs::File::open(path).map_err(io_err)?;
    if let Ok(meta) = file.metadata() {
        if meta.is_dir() {
            return Err(GraphError::Io {
                path: path.display().to_string(),
                message: "this is a directory, not a pipeline file; name a .ron file".into(),
            });
        }
        if meta.len() > MAX_PIPELINE_BYTES as u64 {
            return Err(file_too_large(path, meta.len()));
        }
    }
    let mut bytes = Vec::new();
    file.take(MAX_PIPELINE_BYTES as u64 + 1).read_to_end(&mut bytes).map_err(io_err)?;
    if bytes.len() > MAX_PIPELINE_BYTES {
        return Err(file_too_large(path, bytes.len() as u64));
    }
    let text = String::from_utf8(bytes).map_err(|e| GraphError::Io {
        path: path.display().to_string(),
        message: format!(
            "the pipeline file is not UTF-8 text (invalid byte at offset {}); save it as UTF-8",
            e.utf8_error().valid_up_to()
        ),
    })?;
    parse_pipeline(path, &text)
}

/// A node that passed validation.
#[derive(Clone)]
pub struct ValidatedNode {
    pub name: String,
    pub kind: Arc<dyn NodeKind>,
    /// Checked parameters with defaults filled in for everything the kind declares.
    pub params: BTreeMap<String, ParamValue>,
    /// Input port → (producer node, producer port).
    pub inputs: BTreeMap<String, (String, String)>,
    pub location: Location,
}

impl fmt::Debug for ValidatedNode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ValidatedNode")
            .field("name", &self.name)
            .field("kind", &self.kind.kind())
            .field("params", &self.params)
            .field("inputs", &self.inputs)
            .field("location", &self.location)
            .finish()
    }
}

/// A pipeline without problems, its nodes in topological order (ties in file order).
#[derive(Clone, Debug)]
pub struct ValidatedPipeline {
    pub pipeline: Pipeline,
    pub path: PathBuf,
    pub nodes: Vec<ValidatedNode>,
    /// The registry's shared sampler, emitted by [`expand()`] when some node asks for it.
    pub sampler: Option<Arc<dyn crate::sampler::SamplerKind>>,
    /// The pipeline's factoring node, if one factors ([`crate::factoring`]).
    pub factoring: Option<crate::Factoring>,
    /// The light terms of every radiance output and of each sink's image ([`crate::terms`]), for
    /// the factoring decision above.
    pub terms: crate::terms::TermReport,
    /// The scene facts of the last decision (`None`: decided without a scene).
    pub scene_facts: Option<crate::factoring::SceneFacts>,
}

impl ValidatedPipeline {
    /// Directory of the pipeline file, against which relative scene paths are resolved.
    pub fn base_dir(&self) -> PathBuf {
        match self.path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        }
    }
    pub fn node(&self, name: &str) -> Option<&ValidatedNode> {
        self.nodes.iter().find(|n| n.name == name)
    }
    /// Warnings for rendering frames `first..=last` as a sequence: each node that accumulates its
    /// frames pixel by pixel ([`NodeKind::accumulates_frames`]) while the camera path moves over
    /// those frames averages different views (smeared light), which nothing else would report.
    pub fn sequence_warnings(&self, first: u32, last: u32) -> Vec<String> {
        let keys = &self.pipeline.camera_path;
        let mut frames: Vec<u32> = keys.iter().map(|k| k.frame).filter(|f| (first..=last).contains(f)).collect();
        frames.extend([first, last]);
        let views: Vec<_> = frames.iter().filter_map(|&f| crate::camera_path_at(keys, f)).collect();
        if views.windows(2).all(|w| w[0] == w[1]) {
            return Vec::new();
        }
        let (from, to) = (keys[0].frame, keys[keys.len() - 1].frame);
        self.nodes
            .iter()
            .filter_map(|n| n.kind.accumulates_frames(&n.params).map(|what| (n, what)))
            .map(|(n, what)| {
                format!(
                    "{}: node `{}` ({}) averages {what} over frames {first}..{last} pixel by pixel, but the camera moves along the pipeline's `camera_path` (keys at frames {from}..{to}) over them: each pixel mixes different views (smeared light); render one view with `--frame N` or `--progressive N`, or a range where the path holds still",
                    n.location,
                    n.name,
                    n.kind.kind()
                )
            })
            .collect()
    }
    /// Decide the factoring node again from the nodes' current parameters (after parameter
    /// overrides such as `--set defocus.aperture_radius=0`) and, where a scene is loaded, its facts
    /// (`None`: no scene yet), with the validator's diagnostics.
    pub fn update_factoring(&mut self, scene: Option<crate::factoring::SceneFacts>) -> Result<(), GraphError> {
        let mut found: Option<crate::Factoring> = None;
        let mut problems = Vec::new();
        let inputs = crate::factoring::FactoringInputs { camera: self.pipeline.camera.as_ref(), scene };
        for n in &self.nodes {
            match n.kind.factoring(&n.params, &inputs) {
                Ok(None) => {}
                Ok(Some(settings)) => match &found {
                    None => found = Some(crate::Factoring { node: n.name.clone(), kind: n.kind.kind().into(), settings }),
                    Some(first) => problems.push(Diagnostic {
                        kind: DiagnosticKind::TwoFactoringNodes,
                        location: n.location.clone(),
                        message: format!(
                            "nodes `{}` ({}) and `{}` ({}) both factor and filter the pipeline's lighting components; \
                             the pipeline has one camera path, and one factoring node samples and filters it",
                            first.node, first.kind, n.name, n.kind.kind()
                        ),
                        help: "keep one: a Defocus node samples the camera's shutter too where the scene moves (lens and \
                               shutter together, docs/DEFOCUS-MOTION.md), so a film camera needs only it; or make one a \
                               no-op (a Defocus node with `aperture_radius: 0`; a Motion node on a static scene)"
                            .into(),
                    }),
                },
                Err(refusal) => problems.push(Diagnostic {
                    kind: DiagnosticKind::BadNodeConfig,
                    location: n.location.clone(),
                    message: format!("node `{}` of kind `{}`: {}", n.name, n.kind.kind(), refusal.message),
                    help: refusal.help,
                }),
            }
        }
        if !problems.is_empty() {
            return Err(GraphError::Invalid(problems));
        }
        self.factoring = found;
        self.scene_facts = scene;
        // Which light each output holds depends on who factors: checked again with every decision.
        let (terms, problems) = crate::terms::check(self);
        if !problems.is_empty() {
            return Err(GraphError::Invalid(problems));
        }
        self.terms = terms;
        Ok(())
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DiagnosticKind {
    UnknownNodeKind,
    DuplicateNode,
    UnknownInputPort,
    UnknownOutputPort,
    /// A reference not of the form `node.port`.
    BadReference,
    /// A reference to a node that does not exist.
    UnknownNode,
    /// A required input is not connected.
    MissingProducer,
    /// The same input port is given twice.
    TwoProducers,
    FormatConflict,
    Cycle,
    UnknownParam,
    DuplicateParam,
    ParamType,
    ParamOutOfRange,
    NoSink,
    /// width/height 0 or > 16384, or width*height > 2^26.
    BadSize,
    /// A camera that cannot render: see [`crate::CameraSpec::problems`] for the rules.
    BadCamera,
    /// A `motion` entry the scene's rigid motion cannot hold ([`crate::pipeline::MotionSpec::problems`]).
    BadMotion,
    /// A node name that references cannot name (empty, or with a dot, blank or control character).
    BadName,
    /// A node's parameters, each valid on its own, do not work together (its kind's refusal, e.g.
    /// a Defocus node with no lens anywhere).
    BadNodeConfig,
    /// Two nodes both factor the pipeline's components ([`crate::factoring`]).
    TwoFactoringNodes,
    /// A node takes an output that its producer finishes in a later stage than the node runs in
    /// (e.g. an `Add` after a Defocus node's image-space filter).
    StageOrder,
    /// A sum that counts one light term twice, or adds images of different cameras ([`crate::terms`]).
    TermOverlap,
    /// An input wired to radiance holding terms (or a camera) it does not take ([`crate::terms::Accepts`]).
    TermNotAccepted,
    /// A node renders an area light the loaded scene does not have.
    MissingLight,
}

impl DiagnosticKind {
    /// Short kebab-case code, as printed in `error[…]`.
    pub fn code(self) -> &'static str {
        match self {
            DiagnosticKind::UnknownNodeKind => "unknown-node-kind",
            DiagnosticKind::DuplicateNode => "duplicate-node",
            DiagnosticKind::UnknownInputPort => "unknown-input-port",
            DiagnosticKind::UnknownOutputPort => "unknown-output-port",
            DiagnosticKind::BadReference => "bad-reference",
            DiagnosticKind::UnknownNode => "unknown-node",
            DiagnosticKind::MissingProducer => "missing-producer",
            DiagnosticKind::TwoProducers => "two-producers",
            DiagnosticKind::FormatConflict => "format-conflict",
            DiagnosticKind::Cycle => "cycle",
            DiagnosticKind::UnknownParam => "unknown-param",
            DiagnosticKind::DuplicateParam => "duplicate-param",
            DiagnosticKind::ParamType => "param-type",
            DiagnosticKind::ParamOutOfRange => "param-out-of-range",
            DiagnosticKind::NoSink => "no-sink",
            DiagnosticKind::BadSize => "bad-size",
            DiagnosticKind::BadCamera => "bad-camera",
            DiagnosticKind::BadMotion => "bad-motion",
            DiagnosticKind::BadName => "bad-name",
            DiagnosticKind::BadNodeConfig => "bad-node-config",
            DiagnosticKind::TwoFactoringNodes => "two-factoring-nodes",
            DiagnosticKind::StageOrder => "stage-order",
            DiagnosticKind::TermOverlap => "term-overlap",
            DiagnosticKind::TermNotAccepted => "term-not-accepted",
            DiagnosticKind::MissingLight => "missing-light",
        }
    }
}

impl fmt::Display for DiagnosticKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.code())
    }
}

/// One validation problem, located at the offending token.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    pub kind: DiagnosticKind,
    pub location: Location,
    pub message: String,
    pub help: String,
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: error[{}]: {}\n  help: {}", self.location, self.kind, self.message, self.help)
    }
}

/// Levenshtein distance (case-insensitive), to suggest the closest spelling.
///
/// Only the first 64 characters of each word are compared: enough to rank misspellings, and it
/// keeps the cost bounded for long names (names are capped at [`MAX_NAME_CHARS`]).
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.to_lowercase().chars().take(64).collect();
    let b: Vec<char> = b.to_lowercase().chars().take(64).collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.iter().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// `candidates` ordered closest spelling first (stable for ties).
fn by_closeness<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Vec<&'a str> {
    let mut v: Vec<&str> = candidates.into_iter().collect();
    v.sort_by_cached_key(|c| edit_distance(word, c));
    v
}

/// "did you mean `x`? " when the closest candidate is a plausible misspelling (at most a third of
/// the word's letters wrong, at least one allowed), else nothing: suggesting `Blur` for `Fog` would
/// mislead more than help.
fn did_you_mean(word: &str, sorted: &[&str]) -> String {
    match sorted.first() {
        Some(c) if edit_distance(word, c) <= (word.chars().count() / 3).max(1) => {
            format!("did you mean `{c}`? ")
        }
        _ => String::new(),
    }
}

/// [`did_you_mean`] for callers outside the validator (`--set NODE.PARAM=…` in src/session.rs):
/// "did you mean `x`? " when one of `candidates` is a plausible misspelling of `word`, else "".
pub fn suggestion<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> String {
    did_you_mean(word, &by_closeness(word, candidates))
}

fn ports_list(ports: &[PortDecl]) -> String {
    if ports.is_empty() {
        return "(none)".into();
    }
    ports
        .iter()
        .map(|p| format!("{}: {}{}", p.name, p.format, if p.optional { " (optional)" } else { "" }))
        .collect::<Vec<_>>()
        .join(", ")
}

fn params_list(params: &[ParamDecl]) -> String {
    if params.is_empty() {
        return "(none)".into();
    }
    params
        .iter()
        .map(|p| match &p.kind {
            ParamKind::Float { min, max, min_exclusive, special, .. } => {
                let or = special.map_or(String::new(), |s| format!(" or {} ({})", s.value, s.meaning));
                format!("{}: number in {}{min}, {max}]{or}", p.name, if *min_exclusive { "(" } else { "[" })
            }
            ParamKind::Int { min, max, .. } => format!("{}: integer in [{min}, {max}]", p.name),
            ParamKind::Bool { .. } => format!("{}: bool", p.name),
            ParamKind::Choice { options, .. } => format!("{}: one of {options:?}", p.name),
            ParamKind::Path { .. } => format!("{}: file path", p.name),
            ParamKind::Vec3 { min, max, colour, .. } => {
                format!(
                    "{}: {} in [{min}, {max}]",
                    p.name,
                    if *colour { "colour (r, g, b)" } else { "three numbers (x, y, z)" }
                )
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Whether a written value has the declared type (range aside); integers count as numbers.
fn type_matches(kind: &ParamKind, v: &ParamValue) -> bool {
    matches!(
        (kind, v),
        (ParamKind::Float { .. }, ParamValue::Float(_) | ParamValue::Int(_))
            | (ParamKind::Int { .. }, ParamValue::Int(_))
            | (ParamKind::Bool { .. }, ParamValue::Bool(_))
            | (ParamKind::Choice { .. } | ParamKind::Path { .. }, ParamValue::Str(_))
            | (ParamKind::Vec3 { .. }, ParamValue::Vec3(_))
    )
}

/// Split `node.port` at its single dot; `None` if it is not of that form.
fn split_reference(r: &str) -> Option<(&str, &str)> {
    let (n, p) = r.split_once('.')?;
    let ok = |s: &str| !s.is_empty() && !s.contains('.') && !s.contains(char::is_whitespace);
    (ok(n) && ok(p)).then_some((n, p))
}

/// At most this many problems are reported (and looked for): with up to [`MAX_NODES`] nodes, each
/// problem's help may list many names, and a badly broken file would otherwise print megabytes.
pub const MAX_DIAGNOSTICS: usize = 100;

/// Collects the diagnostics of one validation, up to [`MAX_DIAGNOSTICS`].
struct Reporter<'a> {
    p: &'a LoadedPipeline,
    list: Vec<Diagnostic>,
}

impl Reporter<'_> {
    fn add(&mut self, kind: DiagnosticKind, pos: Option<Pos>, message: String, help: String) {
        if self.full() {
            return;
        }
        self.list.push(Diagnostic {
            kind,
            location: self.p.loc(pos),
            message: printable(message),
            help: printable(help),
        });
    }
    /// Whether the report is complete; validation stops looking (suggestions are not free).
    fn full(&self) -> bool {
        self.list.len() >= MAX_DIAGNOSTICS
    }
}

/// `s` with control characters (which a name copied from a broken file may hold) written as
/// escapes such as `\u{a}`, so that every diagnostic stays two readable lines.
fn printable(s: String) -> String {
    if !s.chars().any(char::is_control) {
        return s;
    }
    s.chars().map(|c| if c.is_control() { c.escape_unicode().to_string() } else { c.to_string() }).collect()
}

/// The first names of a list for a help line, and how many were left out.
fn list_some<S: AsRef<str>>(names: &[S]) -> String {
    const SHOWN: usize = 20;
    let mut s = names.iter().take(SHOWN).map(|n| n.as_ref()).collect::<Vec<_>>().join(", ");
    if names.len() > SHOWN {
        s.push_str(&format!(", … ({} more)", names.len() - SHOWN));
    }
    s
}

/// Check `p` against `reg`; all problems are collected before returning. Phases, in order: the
/// pipeline-level blocks (size, camera, motion, camera path), node names, then per node its kind,
/// parameters and inputs, then sinks and cycles over the resolved wiring; a pipeline without
/// problems is ordered (topologically, ties in file order) and its factoring decided.
pub fn validate(p: &LoadedPipeline, reg: &NodeRegistry) -> Result<ValidatedPipeline, GraphError> {
    let mut r = Reporter { p, list: Vec::new() };
    check_size(&mut r);
    check_camera_and_motion(&mut r);
    let index_of = check_node_names(&mut r);
    let mut wiring = Wiring { index_of, edges: Vec::new() };
    let mut validated_params: Vec<BTreeMap<String, ParamValue>> = Vec::new();
    for i in 0..p.pipeline.nodes.len() {
        if r.full() {
            break;
        }
        let kind = check_kind(&mut r, reg, i);
        validated_params.push(check_params(&mut r, i, kind));
        let connected = check_inputs(&mut r, reg, &mut wiring, i, kind);
        if let Some(k) = kind {
            check_required_inputs(&mut r, reg, i, k, &connected);
        }
    }
    check_sinks(&mut r, reg);
    let succ = successors(p.pipeline.nodes.len(), &wiring.edges);
    check_cycles(&mut r, &succ);
    if !r.list.is_empty() {
        let mut diags = r.list;
        // File order; the sort is stable, so problems at one token keep their discovery order.
        diags.sort_by_key(|d| (d.location.line, d.location.col));
        return Err(GraphError::Invalid(diags));
    }
    let order = topological_order(&succ);
    let mut validated = assemble(p, reg, order, wiring.edges, validated_params);
    // Which node factors follows from each node's whole, valid parameter block and the camera (the
    // scene is not loaded yet: a session decides again with its facts).
    validated.update_factoring(None)?;
    Ok(validated)
}

/// A wire `(consumer, input port, producer, output port)` between node indices.
type Edge = (usize, String, usize, String);

/// The wiring resolved so far: node names to indices (first definition wins) and the valid edges.
struct Wiring<'a> {
    index_of: HashMap<&'a str, usize>,
    edges: Vec<Edge>,
}

/// Image size: each side usable, the whole within [`MAX_PIXELS`].
fn check_size(r: &mut Reporter<'_>) {
    let (p, pl) = (r.p, &r.p.pipeline);
    // Image size.
    for (what, v, pos) in [("width", pl.width, p.map.width), ("height", pl.height, p.map.height)] {
        if v == 0 || v > MAX_SIDE {
            r.add(
                DiagnosticKind::BadSize,
                pos,
                format!("{what} = {v} is not a usable image size"),
                format!("set {what} to a value in 1..={MAX_SIDE}"),
            );
        }
    }
    let pixels = u64::from(pl.width) * u64::from(pl.height);
    if pl.width > 0 && pl.height > 0 && pl.width <= MAX_SIDE && pl.height <= MAX_SIDE && pixels > MAX_PIXELS {
        r.add(
            DiagnosticKind::BadSize,
            p.map.width,
            format!("{}x{} = {pixels} pixels is more than the limit of {MAX_PIXELS} (2^26)", pl.width, pl.height),
            "reduce width or height (render tiles separately if you need a larger image)".into(),
        );
    }
}

/// The camera block, the motion entries (numbers the scene's rigid motion can hold, each object
/// once) and the camera path (usable keys in increasing frame order, and the view between keys).
fn check_camera_and_motion(r: &mut Reporter<'_>) {
    let (p, pl) = (r.p, &r.p.pipeline);
    // Camera: a degenerate one renders black or NaN without any other error.
    if let Some(camera) = &pl.camera {
        for problem in camera.problems() {
            r.add(DiagnosticKind::BadCamera, p.map.camera_field(problem.field), problem.message, problem.help);
        }
    }

    // Motion entries: numbers the scene's rigid motion can hold, each object named once.
    let mut moved: HashMap<&str, usize> = HashMap::new();
    for (k, m) in pl.motion.iter().enumerate() {
        for (field, message, help) in m.problems() {
            r.add(DiagnosticKind::BadMotion, p.map.motion_field(k, field), message, help);
        }
        if let Some(first) = moved.insert(m.object.as_str(), k) {
            r.add(
                DiagnosticKind::BadMotion,
                p.map.motion_field(k, "object"),
                format!("object `{}` has two motion entries (entries {} and {})", m.object, first + 1, k + 1),
                "give each object one entry (its translation and rotation together)".into(),
            );
        }
    }

    // Camera path: usable keys in strictly increasing frame order.
    for (k, key) in pl.camera_path.iter().enumerate() {
        for (field, message, help) in key.problems() {
            r.add(DiagnosticKind::BadCamera, p.map.camera_path_field(k, field), message, help);
        }
        if k > 0 && key.frame <= pl.camera_path[k - 1].frame {
            r.add(
                DiagnosticKind::BadCamera,
                p.map.camera_path_field(k, "frame"),
                format!(
                    "camera key {} is at frame {}, not after the key before it (frame {})",
                    k + 1,
                    key.frame,
                    pl.camera_path[k - 1].frame
                ),
                "list the keys of `camera_path` in increasing frame order, each frame once".into(),
            );
        }
    }

    // Every camera along the path, once its keys are usable: the view it gets between keys. Without
    // a camera block the scene's camera decides `up`, so only the view direction is checked here
    // (a session checks `up` with the scene loaded, [`check_camera_path`]).
    let keys_ok = pl.camera_path.iter().all(|k| k.problems().is_empty())
        && pl.camera_path.windows(2).all(|w| w[0].frame < w[1].frame);
    if keys_ok {
        let (camera, check_up) = match &pl.camera {
            Some(c) => (c.clone(), true),
            None => (CameraSpec { up: (0.0, 1.0, 0.0), ..path_template() }, false),
        };
        for problem in camera_path_problems(&pl.camera_path, &camera, check_up) {
            let (pos, message, help) = path_diagnostic(p, &problem);
            r.add(DiagnosticKind::BadCamera, pos, message, help);
        }
    }
}

/// Node names usable in references and unique; returns the index of each name's first definition.
fn check_node_names<'a>(r: &mut Reporter<'a>) -> HashMap<&'a str, usize> {
    let (p, pl) = (r.p, &r.p.pipeline);
    // Node names: first definition wins for wiring; later ones are reported.
    let mut index_of: HashMap<&str, usize> = HashMap::new();
    for (i, n) in pl.nodes.iter().enumerate() {
        if r.full() {
            break;
        }
        let src = p.node_src(i);
        // A reference is `node.port`, so a name with a dot (or blanks, or control characters)
        // could never be referred to.
        if n.name.is_empty() || n.name.contains('.') || n.name.chars().any(|c| c.is_whitespace() || c.is_control()) {
            r.add(
                DiagnosticKind::BadName,
                src.name.or(src.tuple_pos()),
                format!("node name `{}` cannot be used in references", n.name),
                "name nodes with letters, digits, `_` or `-` (no dots, blanks or control characters), \
                 e.g. `name: \"shadows\"`"
                    .into(),
            );
        }
        if let Some(&first) = index_of.get(n.name.as_str()) {
            let f = p.loc(p.node_src(first).name);
            r.add(
                DiagnosticKind::DuplicateNode,
                src.name,
                format!("a node named `{}` is already defined at {}:{}", n.name, f.line, f.col),
                "give each node a unique name (and update the references to it)".into(),
            );
        } else {
            index_of.insert(&n.name, i);
        }
    }
    index_of
}

/// Node `i`'s kind, or an unknown-kind diagnostic with the closest registered names.
fn check_kind<'r>(r: &mut Reporter<'_>, reg: &'r NodeRegistry, i: usize) -> Option<&'r Arc<dyn NodeKind>> {
    let (p, n) = (r.p, &r.p.pipeline.nodes[i]);
    let src = p.node_src(i);
    let kind = reg.get(&n.kind);
    if kind.is_none() {
        let names = by_closeness(&n.kind, reg.names());
        let closest = did_you_mean(&n.kind, &names);
        r.add(
            DiagnosticKind::UnknownNodeKind,
            src.kind,
            format!("node `{}` has unknown kind `{}`", n.name, n.kind),
            format!(
                "{closest}registered kinds: {} (a new kind must be added with NodeRegistry::register)",
                list_some(&names)
            ),
        );
    }

    kind
}

/// Node `i`'s parameter block: declared defaults, overridden by each valid written value; every
/// duplicate, unknown, mistyped or out-of-range value reported at its position.
fn check_params(r: &mut Reporter<'_>, i: usize, kind: Option<&Arc<dyn NodeKind>>) -> BTreeMap<String, ParamValue> {
    let (p, n) = (r.p, &r.p.pipeline.nodes[i]);
    let src = p.node_src(i);
    let decls = kind.map(|k| k.params()).unwrap_or_default();
    let mut params: BTreeMap<String, ParamValue> =
        decls.iter().filter(|d| !d.optional).map(|d| (d.name.to_string(), d.default_value())).collect();
    let mut seen: HashSet<&str> = HashSet::new();
    for (j, (key, raw)) in n.params.iter().enumerate() {
        if r.full() {
            break;
        }
        let pos = src.params.get(j).copied().or(src.tuple_pos());
        if !seen.insert(key) {
            r.add(
                DiagnosticKind::DuplicateParam,
                pos,
                format!("parameter `{key}` of node `{}` is given twice", n.name),
                "remove one of the two entries".into(),
            );
            continue;
        }
        let Some(k) = kind else { continue };
        let Some(decl) = decls.iter().find(|d| d.name == key) else {
            let names = by_closeness(key, decls.iter().map(|d| d.name));
            let closest = did_you_mean(key, &names);
            r.add(
                DiagnosticKind::UnknownParam,
                pos,
                format!("node `{}` of kind `{}` has no parameter `{key}`", n.name, k.kind()),
                format!("{closest}parameters of {}: {}", k.kind(), params_list(&decls)),
            );
            continue;
        };
        let value = ParamValue::from(raw);
        match decl.check(&value) {
            Ok(v) => {
                params.insert(key.clone(), v);
            }
            Err(why) => {
                let kind = if type_matches(&decl.kind, &value) {
                    DiagnosticKind::ParamOutOfRange
                } else {
                    DiagnosticKind::ParamType
                };
                r.add(
                    kind,
                    pos,
                    format!("invalid parameter `{key}` of node `{}`", n.name),
                    format!("{why}{}", if decl.doc.is_empty() { String::new() } else { format!(" ({})", decl.doc) }),
                );
            }
        }
    }
    params
}

/// Node `i`'s written inputs: each connected once, to a port its kind has, by a well-formed
/// reference to an existing node's output of the same format; valid wires go to `wiring.edges`.
/// Returns the ports written (valid or not), for the required-input check.
fn check_inputs(
    r: &mut Reporter<'_>,
    reg: &NodeRegistry,
    wiring: &mut Wiring<'_>,
    i: usize,
    kind: Option<&Arc<dyn NodeKind>>,
) -> HashSet<String> {
    let (p, pl) = (r.p, &r.p.pipeline);
    let n = &pl.nodes[i];
    let src = p.node_src(i);
    let index_of = &wiring.index_of;
    let kind_of = |name: &str| index_of.get(name).and_then(|&i| reg.get(&pl.nodes[i].kind));
    let in_decls = kind.map(|k| k.inputs()).unwrap_or_default();
    let mut seen: HashMap<&str, usize> = HashMap::new();
    for (j, (port, reference)) in n.inputs.iter().enumerate() {
        if r.full() {
            break;
        }
        let (kpos, vpos) =
            src.inputs.get(j).map(|&(k, v)| (Some(k), Some(v))).unwrap_or((src.tuple_pos(), src.tuple_pos()));
        if let Some(&first) = seen.get(port.as_str()) {
            r.add(
                DiagnosticKind::TwoProducers,
                kpos,
                format!(
                    "input `{port}` of node `{}` is connected twice (to `{}` and `{reference}`)",
                    n.name, n.inputs[first].1
                ),
                "an input has exactly one producer: keep one of the two entries".into(),
            );
            continue;
        }
        seen.insert(port, j);
        let decl = match kind {
            Some(k) => match in_decls.iter().find(|d| d.name == port) {
                Some(d) => Some(d),
                None => {
                    let names = by_closeness(port, in_decls.iter().map(|d| d.name));
                    let closest = did_you_mean(port, &names);
                    r.add(
                        DiagnosticKind::UnknownInputPort,
                        kpos,
                        format!("node `{}` of kind `{}` has no input `{port}`", n.name, k.kind()),
                        format!("{closest}inputs of {}: {}", k.kind(), ports_list(&in_decls)),
                    );
                    None
                }
            },
            None => None,
        };
        let Some((pnode, pport)) = split_reference(reference) else {
            // If the text names a node, offer that node's outputs.
            let outputs = kind_of(reference)
                .map(|k| k.outputs().iter().map(|o| format!("\"{reference}.{}\"", o.name)).collect::<Vec<_>>())
                .filter(|o| !o.is_empty())
                .map(|o| format!(" (here: {})", o.join(", ")))
                .unwrap_or_default();
            r.add(
                DiagnosticKind::BadReference,
                vpos,
                format!("`{reference}` is not a reference to an output"),
                format!("write references as \"<node>.<output port>\", e.g. \"primary.normal\"{outputs}"),
            );
            continue;
        };
        let Some(&pi) = index_of.get(pnode) else {
            let names = by_closeness(pnode, pl.nodes.iter().map(|n| n.name.as_str()));
            let closest = did_you_mean(pnode, &names);
            r.add(
                DiagnosticKind::UnknownNode,
                vpos,
                format!("input `{port}` of node `{}` refers to node `{pnode}`, which does not exist", n.name),
                format!("{closest}nodes in this pipeline: {}", list_some(&names)),
            );
            continue;
        };
        let Some(pkind) = kind_of(pnode) else {
            // The producer's kind is unknown, which is reported at the producer.
            continue;
        };
        let outs = pkind.outputs();
        let Some(out) = outs.iter().find(|o| o.name == pport) else {
            let names = by_closeness(pport, outs.iter().map(|o| o.name));
            let closest = did_you_mean(pport, &names);
            r.add(
                DiagnosticKind::UnknownOutputPort,
                vpos,
                format!("node `{pnode}` of kind `{}` has no output `{pport}`", pkind.kind()),
                format!("{closest}outputs of {}: {}", pkind.kind(), ports_list(&outs)),
            );
            continue;
        };
        if let Some(d) = decl {
            if d.format != out.format {
                let same: Vec<String> =
                    outs.iter().filter(|o| o.format == d.format).map(|o| format!("{pnode}.{}", o.name)).collect();
                let alt = if same.is_empty() { String::new() } else { format!(" ({pnode} has: {})", same.join(", ")) };
                r.add(
                    DiagnosticKind::FormatConflict,
                    vpos,
                    format!(
                        "input `{port}` of node `{}` expects {} but `{reference}` is {}",
                        n.name, d.format, out.format
                    ),
                    format!("connect `{port}` to an output of format {}{alt}", d.format),
                );
                continue;
            }
            wiring.edges.push((i, port.clone(), pi, pport.to_string()));
        }
    }

    seen.into_keys().map(str::to_string).collect()
}

/// Required inputs of node `i` (kind `k`) left unconnected, each with the outputs that could feed it.
fn check_required_inputs(
    r: &mut Reporter<'_>,
    reg: &NodeRegistry,
    i: usize,
    k: &Arc<dyn NodeKind>,
    connected: &HashSet<String>,
) {
    let (p, pl) = (r.p, &r.p.pipeline);
    let n = &pl.nodes[i];
    let src = p.node_src(i);
    let in_decls = k.inputs();
    for d in in_decls.iter().filter(|d| !d.optional && !connected.contains(d.name)) {
        if r.full() {
            break;
        }
        let candidates: Vec<String> = pl
            .nodes
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .filter_map(|(_, m)| reg.get(&m.kind).map(|mk| (m, mk)))
            .flat_map(|(m, mk)| {
                mk.outputs()
                    .into_iter()
                    .filter(|o| o.format == d.format)
                    .map(move |o| format!("\"{}.{}\"", m.name, o.name))
                    .collect::<Vec<_>>()
            })
            .collect();
        let hint = if candidates.is_empty() {
            format!("add a node with a {} output", d.format)
        } else {
            format!("candidates: {}", list_some(&candidates))
        };
        r.add(
            DiagnosticKind::MissingProducer,
            src.name.or(src.tuple_pos()),
            format!("required input `{}` ({}) of node `{}` ({}) is not connected", d.name, d.format, n.name, k.kind()),
            format!("add `inputs: {{\"{}\": \"<node>.<port>\"}}`; {hint}", d.name),
        );
    }
}

/// At least one sink, or nothing would be computed.
fn check_sinks(r: &mut Reporter<'_>, reg: &NodeRegistry) {
    let (p, pl) = (r.p, &r.p.pipeline);
    if !pl.nodes.iter().any(|n| reg.get(&n.kind).is_some_and(|k| k.is_sink())) {
        let sinks: Vec<&str> = reg.names().into_iter().filter(|n| reg.get(n).is_some_and(|k| k.is_sink())).collect();
        r.add(
            DiagnosticKind::NoSink,
            p.map.nodes_key,
            "the pipeline has no sink, so nothing would be computed".into(),
            format!("add a sink node (kinds: {}) and connect what you want to see to it", sinks.join(", ")),
        );
    }
}

/// Per producer, its consumers: `(consumer, output port, input port)`.
fn successors(n: usize, edges: &[Edge]) -> Vec<Vec<(usize, String, String)>> {
    let mut succ: Vec<Vec<(usize, String, String)>> = vec![Vec::new(); n];
    for (c, cport, pidx, pport) in edges {
        succ[*pidx].push((*c, pport.clone(), cport.clone()));
    }
    succ
}

/// Every cycle among the resolved wiring, reported at its first node with the whole path.
fn check_cycles(r: &mut Reporter<'_>, succ: &[Vec<(usize, String, String)>]) {
    let (p, pl) = (r.p, &r.p.pipeline);
    for cycle in find_cycles(succ) {
        if r.full() {
            break;
        }
        let path: Vec<String> = cycle
            .iter()
            .map(|(from, out, to, inp)| format!("{}.{out} -> {}.{inp}", pl.nodes[*from].name, pl.nodes[*to].name))
            .collect();
        let first = cycle[0].0;
        r.add(
            DiagnosticKind::Cycle,
            p.node_src(first).name.or(p.node_src(first).tuple_pos()),
            format!("the wiring has a cycle: {}", path.join(", ")),
            "a node cannot depend on its own output; remove one of these connections".into(),
        );
    }
}

/// Topological order of an acyclic wiring, ties broken by file order (Kahn with an ordered ready set).
fn topological_order(succ: &[Vec<(usize, String, String)>]) -> Vec<usize> {
    let n = succ.len();
    let mut indeg = vec![0usize; n];
    for s in succ {
        for (c, _, _) in s {
            indeg[*c] += 1;
        }
    }
    let mut ready: BTreeSet<usize> = (0..n).filter(|&i| indeg[i] == 0).collect();
    let mut order = Vec::with_capacity(n);
    while let Some(i) = ready.pop_first() {
        order.push(i);
        for (c, _, _) in &succ[i] {
            indeg[*c] -= 1;
            if indeg[*c] == 0 {
                ready.insert(*c);
            }
        }
    }
    debug_assert_eq!(order.len(), n, "cycles were reported above");

    order
}

/// The validated pipeline: nodes in `order` with their kinds, checked parameters and resolved inputs.
fn assemble(
    p: &LoadedPipeline,
    reg: &NodeRegistry,
    order: Vec<usize>,
    edges: Vec<Edge>,
    validated_params: Vec<BTreeMap<String, ParamValue>>,
) -> ValidatedPipeline {
    let (pl, n) = (&p.pipeline, p.pipeline.nodes.len());
    let mut inputs: Vec<BTreeMap<String, (String, String)>> = vec![BTreeMap::new(); n];
    for (c, cport, pidx, pport) in edges {
        inputs[c].insert(cport, (pl.nodes[pidx].name.clone(), pport));
    }
    let mut validated_params: Vec<Option<BTreeMap<String, ParamValue>>> =
        validated_params.into_iter().map(Some).collect();
    let nodes = order
        .into_iter()
        .map(|i| {
            let spec = &pl.nodes[i];
            ValidatedNode {
                name: spec.name.clone(),
                kind: reg.get(&spec.kind).expect("kinds were checked").clone(),
                params: validated_params[i].take().unwrap_or_default(),
                inputs: std::mem::take(&mut inputs[i]),
                location: p.loc(p.node_src(i).name.or(p.node_src(i).tuple_pos())),
            }
        })
        .collect();
    ValidatedPipeline {
        pipeline: pl.clone(),
        path: p.path.clone(),
        nodes,
        sampler: reg.sampler().cloned(),
        factoring: None,
        terms: Default::default(),
        scene_facts: None,
    }
}

/// A camera for checking a path where the pipeline has no camera block: only its `up` matters.
pub(crate) fn path_template() -> CameraSpec {
    CameraSpec {
        position: (0.0, 0.0, 1.0),
        look_at: (0.0, 0.0, 0.0),
        up: (0.0, 1.0, 0.0),
        vfov_deg: 45.0,
        aperture_radius: 0.0,
        focus_distance: None,
        shutter: None,
    }
}

/// Check a pipeline's camera path against the `up` of the camera it renders with, once that is known
/// (the scene's, where the pipeline has no camera block): every camera along the path must pass the
/// camera rules. Errors point at the segment's keys, with the frame.
pub fn check_camera_path(p: &LoadedPipeline, up: (f32, f32, f32)) -> Result<(), GraphError> {
    let camera = CameraSpec { up, ..p.pipeline.camera.clone().unwrap_or_else(path_template) };
    let list: Vec<Diagnostic> = camera_path_problems(&p.pipeline.camera_path, &camera, true)
        .iter()
        .map(|problem| {
            let (pos, message, help) = path_diagnostic(p, problem);
            Diagnostic {
                kind: DiagnosticKind::BadCamera,
                location: p.loc(pos),
                message: printable(message),
                help: printable(help),
            }
        })
        .collect();
    if list.is_empty() {
        Ok(())
    } else {
        Err(GraphError::Invalid(list))
    }
}

/// Where, what and the fix for a camera along a path that breaks a camera rule: at the segment's
/// first key, naming both keys (with their lines) and the frame.
fn path_diagnostic(p: &LoadedPipeline, problem: &PathProblem) -> (Option<Pos>, String, String) {
    let keys = &p.pipeline.camera_path;
    let (k, a, b) = (problem.key, &keys[problem.key], &keys[problem.key + 1]);
    let line =
        |i: usize| p.map.camera_path_field(i, "frame").map_or(String::new(), |pos| format!(", line {}", pos.line));
    let when = if problem.frame.fract() == 0.0 {
        format!("at frame {}", problem.frame)
    } else {
        format!("at frame {} (between frames {} and {})", problem.frame, problem.frame.floor(), problem.frame.ceil())
    };
    let message = format!(
        "camera path between key {} (frame {}{}) and key {} (frame {}{}): the camera {when} breaks a camera rule: {}",
        k + 1,
        a.frame,
        line(k),
        k + 2,
        b.frame,
        line(k + 1),
        problem.problem.message
    );
    let help = match problem.problem.field {
        "look_at" => "position and look_at move through each other between these keys (e.g. the two keys swap them): change one key's `look_at` so the camera never reaches the point it looks at"
            .to_string(),
        "up" => "the view turns along `up` between these keys: add a key in between that keeps the view off `up`, or give the `camera` block an `up` the path never looks along"
            .to_string(),
        _ => problem.problem.help.clone(),
    };
    (p.map.camera_path_field(k, "frame").or(p.map.camera_path), message, help)
}

impl NodeSource {
    fn tuple_pos(&self) -> Option<Pos> {
        (self.tuple.line > 0).then_some(self.tuple)
    }
}

/// One cycle per strongly connected component that has one, as a list of edges
/// `(producer, out port, consumer, in port)` starting at the component's first node in file order.
fn find_cycles(succ: &[Vec<(usize, String, String)>]) -> Vec<Vec<(usize, String, usize, String)>> {
    use petgraph::graph::{DiGraph, NodeIndex};
    let mut g: DiGraph<(), ()> = DiGraph::new();
    let idx: Vec<NodeIndex> = (0..succ.len()).map(|_| g.add_node(())).collect();
    for (p, s) in succ.iter().enumerate() {
        for (c, _, _) in s {
            g.add_edge(idx[p], idx[*c], ());
        }
    }
    let mut cycles = Vec::new();
    for scc in petgraph::algo::tarjan_scc(&g) {
        let members: BTreeSet<usize> = scc.iter().map(|x| x.index()).collect();
        let start = *members.first().unwrap();
        let self_loop = succ[start].iter().any(|(c, _, _)| *c == start);
        if members.len() < 2 && !self_loop {
            continue;
        }
        // Breadth-first search inside the component for the shortest way back to `start`, which is a
        // simple cycle through it; edges tried in file order for a stable report.
        let mut prev: HashMap<usize, (usize, usize)> = HashMap::new(); // node → (from, edge index)
        let mut queue = std::collections::VecDeque::from([start]);
        let mut closing = None;
        'bfs: while let Some(u) = queue.pop_front() {
            for (e, (c, _, _)) in succ[u].iter().enumerate() {
                if !members.contains(c) {
                    continue;
                }
                if *c == start {
                    closing = Some((u, e));
                    break 'bfs;
                }
                if !prev.contains_key(c) {
                    prev.insert(*c, (u, e));
                    queue.push_back(*c);
                }
            }
        }
        let Some((mut u, e)) = closing else { continue };
        let mut rev = vec![(u, e)];
        while u != start {
            let (from, e) = prev[&u];
            rev.push((from, e));
            u = from;
        }
        rev.reverse();
        cycles.push(
            rev.into_iter()
                .map(|(from, e)| {
                    let (to, out, inp) = &succ[from][e];
                    (from, out.clone(), *to, inp.clone())
                })
                .collect(),
        );
    }
    cycles
}

/// Expand every node into passes, in topological order.
pub fn expand(v: &ValidatedPipeline) -> Result<Expansion, GraphError> {
    let mut expansion = Expansion::default();
    let mut written: HashMap<BufferId, String> = HashMap::new(); // buffer → name of the pass writing it
    let mut plan = crate::sampler::SamplerPlan::new(v.sampler.clone());
    for node in &v.nodes {
        let err = |message: String| GraphError::Expand { node: node.name.clone(), message };
        let mut inputs: BTreeMap<String, BufferId> = BTreeMap::new();
        for (port, (pnode, pport)) in &node.inputs {
            let id = expansion
                .outputs
                .get(&(pnode.clone(), pport.clone()))
                .copied()
                .ok_or_else(|| err(format!("input `{port}`: `{pnode}.{pport}` has no buffer")))?;
            inputs.insert(port.clone(), id);
        }
        let first_pass = expansion.passes.len();
        let first_buffer = expansion.buffers.len();
        let mut ctx = ExpandCtx::new(&node.name, &node.params, &inputs, &mut expansion)
            .with_sampler(&mut plan)
            .with_terms(&v.terms)
            .with_camera(v.pipeline.camera.as_ref(), v.scene_facts)
            .with_factoring(v.factoring.as_ref().and_then(|f| Some((f, v.node(&f.node)?.kind.as_ref()))));
        let expanded = node.kind.expand(&mut ctx);
        // The node's place in the file, so a refusal points where the user edits.
        let at = |error: GraphError| GraphError::At { location: node.location.clone(), error: Box::new(error) };
        // An undeclared parameter first: the errors after it may come from its placeholder value.
        ctx.check_params().map_err(at)?;
        expanded.map_err(at)?;
        let handles: HashSet<BufferId> = plan.handles.values().copied().collect();
        follow_data_stages(&mut expansion, first_pass);
        check_input_stages(v, node, &expansion, first_pass)?;

        // The node kind must keep its declared contract; a violation is a bug in the kind.
        let kind = node.kind.kind();
        for out in node.kind.outputs() {
            match expansion.outputs.get(&(node.name.clone(), out.name.to_string())) {
                None => return Err(err(format!("kind `{kind}` did not bind its declared output `{}`", out.name))),
                Some(id) => {
                    let f = expansion.buffers[id.0].format;
                    if f != out.format {
                        return Err(err(format!(
                            "kind `{kind}` bound output `{}` (declared {}) to a {f} buffer",
                            out.name, out.format
                        )));
                    }
                }
            }
        }
        for pass in &expansion.passes[first_pass..] {
            for (binding, id) in &pass.writes {
                if id.0 < first_buffer || handles.contains(id) {
                    return Err(err(format!(
                        "pass `{}` writes `{}` (binding `{binding}`), a buffer made by another node; \
                         a node may only write its own buffers",
                        pass.name, expansion.buffers[id.0].name
                    )));
                }
                if let Some(prev) = written.insert(*id, pass.name.clone()) {
                    return Err(err(format!(
                        "buffer `{}` is written by both `{prev}` and `{}`; each buffer has exactly one writer",
                        expansion.buffers[id.0].name, pass.name
                    )));
                }
            }
        }
        if node.kind.is_sink() {
            for d in node.kind.inputs() {
                if let Some(id) = inputs.get(d.name) {
                    expansion.sink_inputs.push((node.name.clone(), d.name.to_string(), *id));
                }
            }
        }
    }
    if plan.is_used() {
        emit_sampler(v, &mut expansion, &plan, &mut written)?;
    }
    Ok(expansion)
}

/// After composition the stage order follows the data (issue 34 §4): a pass of stage `Compose` or
/// later that reads an image finished in a later stage (an `Add` of a Defocus node's output) runs in
/// that stage, and so do the passes of the node that read it. Passes before `Compose` — sampling,
/// bandwidths, counts, factoring, world-space filters — keep their stage: the sampler's counts and
/// the reference transform rely on it, and reading a later stage there is the error below.
fn follow_data_stages(expansion: &mut Expansion, first_pass: usize) {
    for i in first_pass..expansion.passes.len() {
        let (earlier, rest) = expansion.passes.split_at_mut(i);
        let pass = &mut rest[0];
        if pass.stage < Stage::Compose {
            continue;
        }
        let writer_stage =
            |id: &BufferId| earlier.iter().rev().find(|p| p.writes.iter().any(|(_, b)| b == id)).map(|p| p.stage);
        if let Some(latest) = pass.reads.iter().filter_map(|(_, id)| writer_stage(id)).max() {
            pass.stage = pass.stage.max(latest);
        }
    }
}

/// A node's passes may only read what earlier stages finished (the scheduler orders by stage). An
/// input whose producer writes it in a later stage is the user's wiring, not a node kind's bug, so
/// it is reported at the node with the ports as the pipeline file names them, and what to wire
/// instead; the scheduler's own stage check stays for node kinds that break the rule inside.
fn check_input_stages(
    v: &ValidatedPipeline,
    node: &ValidatedNode,
    expansion: &Expansion,
    first_pass: usize,
) -> Result<(), GraphError> {
    let (earlier, own) = expansion.passes.split_at(first_pass);
    for (port, (pnode, pport)) in &node.inputs {
        let Some(id) = expansion.outputs.get(&(pnode.clone(), pport.clone())) else { continue };
        let Some(writer) = earlier.iter().find(|p| p.writes.iter().any(|(_, b)| b == id)) else { continue };
        let Some(reader) = own.iter().find(|p| p.stage < writer.stage && p.reads.iter().any(|(_, b)| b == id)) else {
            continue;
        };
        let producer = v.node(pnode);
        let kind = |n: Option<&ValidatedNode>| n.map_or_else(String::new, |n| format!(" ({})", n.kind.kind()));
        let upstream: Vec<String> =
            producer.map_or_else(Vec::new, |p| p.inputs.values().map(|(n, o)| format!("`{n}.{o}`")).collect());
        let own_out =
            node.kind.outputs().first().map_or_else(|| node.name.clone(), |o| format!("{}.{}", node.name, o.name));
        let combine = if upstream.is_empty() {
            String::new()
        } else {
            format!("combine before `{pnode}` instead: wire `{}` from what `{pnode}` reads ({}) and give `{own_out}` to `{pnode}`; or ", node.name, upstream.join(", "))
        };
        let message = format!(
            "node `{}`{} runs in stage {}, but its input `{port}` is `{pnode}.{pport}`, which `{pnode}`{} finishes only in the later stage {}: a node can only take outputs finished in its own or an earlier stage",
            node.name,
            kind(Some(node)),
            reader.stage,
            kind(producer),
            writer.stage
        );
        let help = format!("{combine}take `{pnode}.{pport}` straight to the Output");
        return Err(GraphError::Invalid(vec![Diagnostic {
            kind: DiagnosticKind::StageOrder,
            location: node.location.clone(),
            message: printable(message),
            help: printable(help),
        }]));
    }
    Ok(())
}

/// Emit the shared sampler's passes once, after every node expanded, and check that they write
/// every handle the nodes were given and nothing a node wrote.
fn emit_sampler(
    v: &ValidatedPipeline,
    expansion: &mut Expansion,
    plan: &crate::sampler::SamplerPlan,
    written: &mut HashMap<BufferId, String>,
) -> Result<(), GraphError> {
    use crate::sampler::SAMPLER_NODE;
    let err = |message: String| GraphError::Expand { node: SAMPLER_NODE.into(), message };
    if let Some(n) = v.nodes.iter().find(|n| n.name == SAMPLER_NODE) {
        return Err(GraphError::Expand {
            node: n.name.clone(),
            message: format!(
                "`{SAMPLER_NODE}` is the shared sampler's name, and node(s) {} ask for it; rename this node",
                plan.users.iter().map(|u| format!("`{u}`")).collect::<Vec<_>>().join(", ")
            ),
        });
    }
    let kind = v.sampler.clone().ok_or_else(|| err("no sampler kind is registered".into()))?;
    let first_pass = expansion.passes.len();
    let (params, inputs) = (BTreeMap::new(), BTreeMap::new());
    let mut ctx = ExpandCtx::new(SAMPLER_NODE, &params, &inputs, expansion);
    let emitted = kind.emit(&mut ctx, plan);
    ctx.check_params()?;
    emitted?;
    for pass in &expansion.passes[first_pass..] {
        for (binding, id) in &pass.writes {
            if let Some(prev) = written.insert(*id, pass.name.clone()) {
                return Err(err(format!(
                    "pass `{}` writes `{}` (binding `{binding}`), already written by `{prev}`",
                    pass.name, expansion.buffers[id.0].name
                )));
            }
        }
    }
    for ((pass, name), id) in &plan.handles {
        if !written.contains_key(id) {
            return Err(err(format!(
                "the `{}` sampler wrote no `{name}` after its {} pass, which a node reads",
                kind.name(),
                pass.name()
            )));
        }
    }
    Ok(())
}
