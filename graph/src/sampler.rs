//! The shared sampler (thesis Ch. 5, Sec. 5.3–5.4; `docs/SAMPLER-STAGE.md` §4): one first pass of
//! paths and one adaptive pass serve every effect, instead of each effect sampling on its own.
//!
//! From [`crate::NodeKind::expand`] a node
//! - asks for the sampler with the estimators and settings it needs ([`ExpandCtx::sampler`] with a
//!   [`SamplerRequest`]): two nodes' values of one setting are negotiated by the rule the
//!   [`SamplerKind`] declares for it ([`SettingMerge`]: the larger count, jitter where any node
//!   jitters); only a setting the kind declares [`SettingMerge::Equal`] can conflict, and that is a
//!   graph error naming both nodes, the setting and why it cannot be shared;
//! - gets typed handles to the sampler's resolved buffers ([`ExpandCtx::sampler_output`]): the
//!   first-pass outputs (written in `Stage::Sample`) and the final ones after the adaptive pass
//!   (`Stage::Adaptive`), by the names the registered [`SamplerKind`] declares;
//! - submits per-pixel count requests ([`ExpandCtx::sampler_counts`], a [`CountRequest`]): `u32`
//!   buffers it writes in `Stage::Bandwidth` — primary paths per pixel and secondary samples per
//!   estimator or per *channel* of one ([`SamplerKind::channels`]): per primary path, a total over
//!   the adaptive pass ([`PerPrimary::Total`]), or a total over both passes spread over whatever
//!   paths the pixel gets ([`PerPrimary::Spread`], Ch. 3/4's counts at one primary hit).
//!
//! After every node has expanded, [`crate::expand()`] hands the merged [`SamplerPlan`] to the
//! [`SamplerKind`] registered in the [`crate::NodeRegistry`] (wedge's is `wedge_effects::sampler`),
//! which emits the passes once under the node name [`SAMPLER_NODE`]: first pass, resolve, the
//! `Stage::Counts` combination (per-pixel max of the requests, 3×3 max where asked, at least one
//! secondary per primary except for channels counted only by spreads), the adaptive pass continuing
//! the first pass's record, resolve. The graph knows no kernel of it. A pipeline whose nodes never ask for the sampler emits none of it.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::sync::Arc;

use crate::decl::{Format, ParamValue};
use crate::expand::{BufferId, ExpandCtx, Expansion};
use crate::GraphError;

/// The node name the sampler's passes and buffers carry (`sampler.first`, `sampler.adaptive`, …);
/// a pipeline node of this name cannot share a pipeline with the sampler.
pub const SAMPLER_NODE: &str = "sampler";

/// Which of the sampler's results a handle names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum SamplerPass {
    /// After the first pass (`Stage::Sample`): what bandwidths and rates are computed from.
    First,
    /// After the adaptive pass (`Stage::Adaptive`), continuing the first: what filters read.
    Final,
}

impl SamplerPass {
    pub fn name(self) -> &'static str {
        match self {
            SamplerPass::First => "first",
            SamplerPass::Final => "final",
        }
    }
}

/// What one node asks of the sampler: estimators (e.g. `light`, `hemisphere`) and settings (e.g.
/// `light` index, first-pass `paths`, `sampling`), as the registered [`SamplerKind`] names them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SamplerRequest {
    pub estimators: BTreeSet<String>,
    pub settings: BTreeMap<String, ParamValue>,
}

impl SamplerRequest {
    pub fn new() -> Self {
        Self::default()
    }
    pub fn estimator(mut self, name: &str) -> Self {
        self.estimators.insert(name.to_string());
        self
    }
    pub fn setting(mut self, name: &str, value: ParamValue) -> Self {
        self.settings.insert(name.to_string(), value);
        self
    }
}

/// How the sampler combines two nodes' values of one setting (issue 34 §4: settings are negotiated,
/// never a conflict the user resolves by an internal name).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SettingMerge {
    /// One value serves every node; a different one is refused with `why` (what the setting selects
    /// and what the user can do instead).
    Equal { why: &'static str },
    /// The larger number serves both (a count: more first-pass samples only refine each node's
    /// statistics, and every node reads the counts the merged plan gives).
    Max,
    /// On where any node asks (a switch whose `true` contains `false` as a special case, e.g.
    /// jittered primary paths: a ray through the pixel centre is one sample of the pixel).
    Any,
}

impl SettingMerge {
    /// The negotiated value, or `None` where the two cannot be shared.
    pub fn merge(self, a: &ParamValue, b: &ParamValue) -> Option<ParamValue> {
        if a == b {
            return Some(a.clone());
        }
        match (self, a, b) {
            (SettingMerge::Max, ParamValue::Int(x), ParamValue::Int(y)) => Some(ParamValue::Int(*x.max(y))),
            (SettingMerge::Max, ParamValue::Float(x), ParamValue::Float(y)) => Some(ParamValue::Float(x.max(*y))),
            (SettingMerge::Any, ParamValue::Bool(x), ParamValue::Bool(y)) => Some(ParamValue::Bool(*x || *y)),
            _ => None,
        }
    }
}

/// Secondary samples per primary path for one estimator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PerPrimary {
    /// The same everywhere.
    Constant(u32),
    /// A per-pixel `u32` buffer the node writes in `Stage::Bandwidth`.
    Buffer(BufferId),
    /// A per-pixel `u32` buffer of the estimator's secondary samples over all of the adaptive pass's
    /// paths (Ch. 5's `n_dir`, `n_ind`): the sampler spreads them as `s²` per path, the smallest
    /// square with `paths · s² ≥ total` (full stratification, Sec. 5.8 footnote 6), at least 1.
    Total(BufferId),
    /// A per-pixel `u32` buffer of the estimator's secondary samples over **both** passes, the first
    /// pass's included (Ch. 3's eq. 3.21, Ch. 4's eq. 4.21: samples at one primary hit). The sampler
    /// traces the rest on adaptive paths of about `unit` samples each (`ceil(rest / unit)` paths, or
    /// more where another request asks for more) and spreads it evenly over them, each path's count
    /// rounded up. Paths that need none of this estimator's samples trace none (no minimum of 1). Each
    /// sample weighs the same where the camera ray is fixed (a pinhole through the pixel centre): the
    /// record then weighs samples, not paths (`docs/SAMPLER-STAGE.md` "Samples, not paths").
    Spread { total: BufferId, unit: u32 },
}

impl PerPrimary {
    /// The per-pixel buffer it reads, if any.
    pub fn buffer(&self) -> Option<BufferId> {
        match *self {
            PerPrimary::Constant(_) => None,
            PerPrimary::Buffer(id) | PerPrimary::Total(id) | PerPrimary::Spread { total: id, .. } => Some(id),
        }
    }
}

/// One node's per-pixel counts for the adaptive pass.
#[derive(Clone, Debug, PartialEq)]
pub struct CountRequest {
    /// Per-pixel `u32` (written by the node in `Stage::Bandwidth`): the pixel's total primary paths
    /// over both passes, counted in units of `paths_unit` — the sampler takes `ceil(value /
    /// paths_unit)` paths, so a node whose rate is in secondary samples (eq. 3.21's shadow rays) at
    /// `paths_unit` samples per path states it directly. 1 when the buffer counts paths. `None`: the
    /// node asks for no paths of its own, only secondary samples on the paths others ask for (a
    /// Ch. 5 component: the Defocus node asks for `n_p`).
    pub paths: Option<BufferId>,
    pub paths_unit: u32,
    /// Secondary samples per primary path, per estimator the node asked for — or per *channel* of
    /// one ([`SamplerKind::channels`]: an estimator whose parts take their own counts, like the
    /// hemisphere estimator's diffuse and glossy samples); an estimator's name sets all its channels.
    pub per_primary: Vec<(String, PerPrimary)>,
    /// Spread the path count (and `PerPrimary::Total` counts) over the 3×3 neighbourhood (thesis
    /// Sec. 5.8 step 2) before combining.
    pub max3: bool,
    /// `paths` counts the adaptive pass alone (Ch. 5: the second pass traces `n_p` paths after the
    /// first pass's), not a total over both passes that includes the first pass's paths (Ch. 3's
    /// eq. 3.21 counts the initial samples).
    pub beyond_first: bool,
}

/// How a sampler is implemented: which estimators and settings it knows, which resolved outputs
/// nodes may read, and the passes it emits. Registered in the [`crate::NodeRegistry`].
pub trait SamplerKind: Send + Sync {
    /// Shown in errors, e.g. `paths`.
    fn name(&self) -> &'static str;
    /// Estimators a node may ask for.
    fn estimators(&self) -> Vec<&'static str>;
    /// Secondary-sample count channels as (channel, estimator): parts of an estimator whose per-primary
    /// counts a [`CountRequest`] may set apart. Default: one channel per estimator, named like it.
    fn channels(&self) -> Vec<(&'static str, &'static str)> {
        self.estimators().into_iter().map(|e| (e, e)).collect()
    }
    /// Setting names a node may give.
    fn settings(&self) -> Vec<&'static str>;
    /// How two nodes' values of `setting` combine. Default: they must be equal.
    fn merge(&self, _setting: &str) -> SettingMerge {
        SettingMerge::Equal { why: "the sampler takes one value of it per pipeline" }
    }
    /// Resolved outputs a handle may name, with their formats.
    fn outputs(&self) -> Vec<(&'static str, Format)>;
    /// Emit the sampler's passes (node [`SAMPLER_NODE`]) writing every handle in `plan`.
    fn emit(&self, ctx: &mut ExpandCtx<'_>, plan: &SamplerPlan) -> Result<(), GraphError>;
}

impl fmt::Debug for dyn SamplerKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "SamplerKind({})", self.name())
    }
}

/// Everything the nodes of a pipeline asked of the sampler, merged.
#[derive(Clone, Debug, Default)]
pub struct SamplerPlan {
    /// The nodes that asked, in expansion order.
    pub users: Vec<String>,
    pub estimators: BTreeSet<String>,
    /// Setting → (negotiated value, the node whose value it is).
    pub settings: BTreeMap<String, (ParamValue, String)>,
    /// Handles handed out: (pass, output name) → buffer. The sampler must write each one.
    pub handles: BTreeMap<(SamplerPass, String), BufferId>,
    /// Count requests, with the node that made each.
    pub requests: Vec<(String, CountRequest)>,
    /// Lighting components' first-pass factoring flags (u32, nonzero where the component's
    /// radiance factors into texture × irradiance, thesis eq. 5.30), each with the node that
    /// published it ([`crate::ExpandCtx::publish_factoring_flag`]), for the factoring node.
    pub factoring_flags: Vec<(String, BufferId)>,
    pub(crate) kind: Option<Arc<dyn SamplerKind>>,
}

impl SamplerPlan {
    pub(crate) fn new(kind: Option<Arc<dyn SamplerKind>>) -> Self {
        SamplerPlan { kind, ..Default::default() }
    }
    /// A setting's value, if some node gave it.
    pub fn setting(&self, name: &str) -> Option<&ParamValue> {
        self.settings.get(name).map(|(v, _)| v)
    }
    pub fn handle(&self, pass: SamplerPass, name: &str) -> Option<BufferId> {
        self.handles.get(&(pass, name.to_string())).copied()
    }
    pub fn is_used(&self) -> bool {
        !self.users.is_empty()
    }

    fn kind_for(&self, node: &str) -> Result<&Arc<dyn SamplerKind>, GraphError> {
        self.kind.as_ref().ok_or_else(|| GraphError::Expand {
            node: node.to_string(),
            message: "asks for the shared sampler, but no sampler kind is registered (register one with \
                      `NodeRegistry::register_sampler`, as `wedge_effects::register` does)"
                .into(),
        })
    }

    pub(crate) fn request(&mut self, node: &str, r: SamplerRequest) -> Result<(), GraphError> {
        let kind = self.kind_for(node)?.clone();
        let err = |message: String| GraphError::Expand { node: node.to_string(), message };
        let known = kind.estimators();
        for e in &r.estimators {
            if !known.contains(&e.as_str()) {
                return Err(err(format!(
                    "asks the `{}` sampler for estimator `{e}`, which it does not have (it has: {})",
                    kind.name(),
                    known.join(", ")
                )));
            }
        }
        let known = kind.settings();
        for (name, value) in &r.settings {
            if !known.contains(&name.as_str()) {
                return Err(err(format!(
                    "gives the `{}` sampler setting `{name}`, which it does not take (it takes: {})",
                    kind.name(),
                    known.join(", ")
                )));
            }
            if let Some((other, by)) = self.settings.get(name) {
                let rule = kind.merge(name);
                if rule.merge(other, value).is_none() {
                    let why = match rule {
                        SettingMerge::Equal { why } => why,
                        _ => "values of different kinds cannot be combined",
                    };
                    return Err(err(format!(
                        "needs the shared sampler's `{name}` = {value}, but node `{by}` needs {other}: {why}"
                    )));
                }
            }
        }
        for (name, value) in r.settings {
            match self.settings.get(&name) {
                None => {
                    self.settings.insert(name, (value, node.to_string()));
                }
                Some((other, _)) => {
                    let merged = kind.merge(&name).merge(other, &value).unwrap_or_else(|| other.clone());
                    if merged != *other {
                        self.settings.insert(name, (merged, node.to_string()));
                    }
                }
            }
        }
        self.estimators.extend(r.estimators);
        if !self.users.iter().any(|u| u == node) {
            self.users.push(node.to_string());
        }
        Ok(())
    }

    fn require_user(&self, node: &str, what: &str) -> Result<(), GraphError> {
        if self.users.iter().any(|u| u == node) {
            Ok(())
        } else {
            Err(GraphError::Expand {
                node: node.to_string(),
                message: format!("{what} before asking for the sampler (call `ctx.sampler(..)` first)"),
            })
        }
    }

    pub(crate) fn publish_flag(&mut self, node: &str, expansion: &Expansion, flag: BufferId) -> Result<(), GraphError> {
        self.require_user(node, "publishes a factoring flag")?;
        match expansion.buffers.get(flag.0).map(|b| b.format) {
            Some(Format::U32) => {
                self.factoring_flags.push((node.to_string(), flag));
                Ok(())
            }
            other => Err(GraphError::Expand {
                node: node.to_string(),
                message: format!(
                    "publishes a factoring flag that is {}; flags are u32 buffers",
                    other.map_or("no buffer".to_string(), |f| format!("a {f} buffer"))
                ),
            }),
        }
    }

    pub(crate) fn output(
        &mut self,
        node: &str,
        expansion: &mut Expansion,
        pass: SamplerPass,
        name: &str,
    ) -> Result<BufferId, GraphError> {
        self.require_user(node, &format!("reads sampler output `{name}`"))?;
        if let Some(id) = self.handle(pass, name) {
            return Ok(id);
        }
        let kind = self.kind_for(node)?;
        let outputs = kind.outputs();
        let Some((_, format)) = outputs.iter().find(|(n, _)| *n == name) else {
            return Err(GraphError::Expand {
                node: node.to_string(),
                message: format!(
                    "reads sampler output `{name}`, which the `{}` sampler does not have (it has: {})",
                    kind.name(),
                    outputs.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
                ),
            });
        };
        expansion
            .buffers
            .push(crate::expand::BufferInfo::new(format!("{SAMPLER_NODE}.{}_{name}", pass.name()), *format));
        let id = BufferId(expansion.buffers.len() - 1);
        self.handles.insert((pass, name.to_string()), id);
        Ok(id)
    }

    pub(crate) fn counts(&mut self, node: &str, expansion: &Expansion, r: CountRequest) -> Result<(), GraphError> {
        self.require_user(node, "submits sampler counts")?;
        let err = |message: String| GraphError::Expand { node: node.to_string(), message };
        let u32_buffer = |id: BufferId, what: &str| -> Result<(), GraphError> {
            match expansion.buffers.get(id.0).map(|b| b.format) {
                Some(Format::U32) => Ok(()),
                Some(f) => Err(err(format!("sampler count `{what}` is a {f} buffer; counts are u32"))),
                None => Err(err(format!("sampler count `{what}` names no buffer"))),
            }
        };
        if let Some(paths) = r.paths {
            u32_buffer(paths, "paths")?;
        }
        if r.paths_unit == 0 {
            return Err(err("sampler count `paths_unit` must be at least 1".into()));
        }
        let channels = self.kind_for(node)?.channels();
        for (name, per) in &r.per_primary {
            // An estimator's name, or one of its channels.
            let estimator = channels.iter().find(|(c, _)| c == name).map_or(name.as_str(), |(_, e)| *e);
            if !self.estimators.contains(estimator) {
                return Err(err(format!(
                    "submits secondary counts for estimator `{estimator}`, which no node asked the sampler for"
                )));
            }
            if let Some(id) = per.buffer() {
                u32_buffer(id, name)?;
            }
            if matches!(per, PerPrimary::Spread { unit: 0, .. }) {
                return Err(err(format!("sampler count `{name}`: a spread's `unit` must be at least 1")));
            }
        }
        self.requests.push((node.to_string(), r));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expand::BufferInfo;

    #[test]
    fn a_published_factoring_flag_is_a_u32_buffer_of_a_sampler_user() {
        let mut e = Expansion::default();
        for (name, format) in [("shadows.flag", Format::U32), ("shadows.e", Format::Vec3)] {
            e.buffers.push(BufferInfo { name: name.into(), format, layers: 1 });
        }
        let mut plan = SamplerPlan::new(None);
        let early = plan.publish_flag("shadows", &e, BufferId(0)).unwrap_err().to_string();
        assert!(early.contains("before asking for the sampler"), "{early}");
        plan.users.push("shadows".into());
        plan.publish_flag("shadows", &e, BufferId(0)).unwrap();
        let wrong = plan.publish_flag("shadows", &e, BufferId(1)).unwrap_err().to_string();
        assert!(wrong.contains("a vec3<f32> buffer; flags are u32"), "{wrong}");
        let missing = plan.publish_flag("shadows", &e, BufferId(7)).unwrap_err().to_string();
        assert!(missing.contains("no buffer"), "{missing}");
        assert_eq!(plan.factoring_flags, vec![("shadows".to_string(), BufferId(0))]);
    }
}
