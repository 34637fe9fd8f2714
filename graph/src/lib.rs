//! # wedge-graph
//!
//! The render graph of wedge, independent of scenes and GPUs:
//! - [`pipeline`]: the RON pipeline schema (unknown fields rejected) with source locations;
//! - [`camera_path`]: a pipeline's camera path, interpolated, and checked camera by camera;
//! - [`decl`]: what a node kind declares (ports with formats, typed parameters with ranges) and the
//!   [`NodeRegistry`] a user crate extends;
//! - [`validate()`]: checks a parsed pipeline against the declarations and reports *every* problem at
//!   once, each with file, line and column;
//! - [`expand()`]: turns validated nodes into passes (kernel + bindings + parameter block), each with
//!   its [`Stage`], whether it is random (the graph assigns its stream, [`stream_id`]) and its
//!   [`Reference`] role;
//! - [`terms`]: the light terms of radiance ports (a double count or a wrong component is a
//!   validation error);
//! - [`sampler`]: the shared sampler nodes ask for from `expand` (requests, handles, count requests;
//!   the registered [`SamplerKind`] emits its passes once after every node expanded);
//! - [`reference()`]: turns an expansion into the pipeline's own plain Monte Carlo reference (filters
//!   bypassed, counts constant, sampling passes at the reference's count and sampling);
//! - [`schedule()`]: checks stage order and stream uniqueness, culls passes that feed no sink, orders
//!   the rest by stage and then topologically (petgraph), computes
//!   buffer lifetimes and a pool plan that lets buffers with disjoint lifetimes share storage, and
//!   prints the schedule as a table or Graphviz.

pub mod camera_path;
pub mod decl;
pub mod expand;
mod explain;
pub mod factoring;
pub mod pipeline;
mod reference;
pub mod sampler;
mod schedule;
mod source_map;
pub mod stage;
pub mod terms;
mod validate;

pub use camera_path::{camera_path_at, camera_path_problems, PathProblem};
pub use decl::{
    Field, FieldType, Format, NodeKind, NodeRegistry, ParamDecl, ParamKind, ParamValue, PortDecl, SceneRequest,
    Special, StructLayout,
};
pub use expand::{BufferId, BufferInfo, ExpandCtx, Expansion, History, Pass, PassBuilder};
pub use factoring::{Component, Factoring, FactoringInputs, Part, SceneFacts, Statistic};
pub use pipeline::{CameraKey, CameraProblem, CameraSpec, Location, MotionSpec, NodeSpec, Pipeline, RawParam};
pub use reference::{reference, unfiltered, FILL_CONSTANT, REFERENCE_SAMPLING};
pub use sampler::{
    CountRequest, PerPrimary, SamplerKind, SamplerPass, SamplerPlan, SamplerRequest, SettingMerge, SAMPLER_NODE,
};
pub use schedule::{bytes_per_pixel, schedule, BufferBytes, Lifetime, Schedule};
pub use stage::{stream_id, Reference, Stage};
pub use terms::{AcceptView, Accepts, Term, TermKind, TermQuery, TermReport, Terms, View};
pub use validate::{
    check_camera_path, expand, load_pipeline, parse_pipeline, suggestion, validate, Diagnostic, DiagnosticKind,
    LoadedPipeline, ValidatedNode, ValidatedPipeline, MAX_DIAGNOSTICS, MAX_PIXELS, MAX_SIDE,
};

/// Everything that can go wrong between a pipeline file and a schedule.
#[derive(Debug, thiserror::Error)]
pub enum GraphError {
    /// The file could not be read.
    #[error("{path}: {message}")]
    Io { path: String, message: String },
    /// RON syntax or schema error (includes unknown fields), with ron's position.
    #[error("{location}: {message}\n  help: {help}")]
    Parse { location: Location, message: String, help: String },
    /// The file is beyond a size limit (bytes, nodes, entries or string length; see
    /// [`pipeline::MAX_PIPELINE_BYTES`] and its neighbours), refused before it is expanded.
    #[error("{location}: {message}\n  help: {help}")]
    TooLarge { location: Location, message: String, help: String },
    /// Every validation problem found, in file order.
    #[error("{}", format_diagnostics(.0))]
    Invalid(Vec<Diagnostic>),
    /// A node kind's `expand` refused its (validated) configuration.
    #[error("node `{node}`: {message}")]
    Expand { node: String, message: String },
    /// An error of a node's expansion at the node's place in the pipeline file (what the user edits).
    #[error("{location}: {error}")]
    At { location: Location, error: Box<GraphError> },
}

impl GraphError {
    /// The error without the place it was found at ([`GraphError::At`]).
    pub fn unlocated(&self) -> &GraphError {
        match self {
            GraphError::At { error, .. } => error.unlocated(),
            e => e,
        }
    }
}

fn format_diagnostics(d: &[Diagnostic]) -> String {
    let mut s = if d.len() >= validate::MAX_DIAGNOSTICS {
        format!(
            "{} problem(s) in the pipeline (the first {}; fix these and run again to see the rest):",
            d.len(),
            validate::MAX_DIAGNOSTICS
        )
    } else {
        format!("{} problem(s) in the pipeline:", d.len())
    };
    for x in d {
        s.push_str(&format!("\n{x}"));
    }
    s
}

/// Parse, validate, expand and schedule a pipeline file in one call.
pub fn compile(path: &std::path::Path, registry: &NodeRegistry) -> Result<(ValidatedPipeline, Schedule), GraphError> {
    let loaded = load_pipeline(path)?;
    let validated = validate(&loaded, registry)?;
    let expansion = expand(&validated)?;
    let sched = schedule(expansion)?;
    Ok((validated, sched))
}
