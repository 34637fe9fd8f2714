//! The shared path sampler (thesis Ch. 5, Sec. 5.3–5.4 and 5.8 steps 1–3; `docs/SAMPLER-STAGE.md`
//! §4): the [`wedge_graph::SamplerKind`] wedge registers, emitting — once per pipeline, after every
//! node asked for it from `expand` ([`wedge_graph::sampler`]) — these passes of node `sampler`:
//!
//! 1. `first` (`Stage::Sample`, `paths.trace`): `paths` primary paths per pixel (setting; thesis
//!    Ch. 3/4: `n_p = 1` through the pixel centre), `shadow_per_primary` / `indirect_per_primary`
//!    secondary samples each, only the estimators some node asked for (`light`: shadow rays to area
//!    light `light`; `hemisphere`: one-bounce indirect; `environment`: look-ups into the environment
//!    map's table, `environment_per_primary` per path). Reference role `Continued`.
//! 2. `resolve_first` (`paths.resolve`): the first-pass outputs nodes hold handles to.
//! 3. `Stage::Counts` (thesis Sec. 5.4): the adaptive pass's paths per pixel are the per-pixel max
//!    over the count requests of `ceil(request / paths_unit)` (each request first spread by
//!    `neighbourhood.max3` where it asks, Sec. 5.8 step 2), less the first pass's paths, and of
//!    `ceil(rest / unit)` for each `PerPrimary::Spread` (`counts_paths`, role `Count`). Then per count
//!    *channel* (`light`; the hemisphere estimator's `diffuse` and `glossy`): its samples over the
//!    adaptive pass (`counts_<channel>`, [`PassTotal`], role `Count`) = `paths ×` the per-path max
//!    of its `Constant` / `Buffer` / `Total` (as s², [`PerPrimaryCounts`]) requests, at least 1 —
//!    or the spreads' rest beyond the first pass where larger (`rest` = total − first-pass samples;
//!    a channel counted only by spreads has no minimum). [`CombineCounts`] (`sampler.combine`) takes
//!    the per-pixel maxima, chained over the requests.
//! 4. `adaptive` (`Stage::Adaptive`, `paths.trace`): continues `first`'s record and its random
//!    sequences (same stream: the union of both passes is one progressive Sobol' set), role `Sample`.
//!    It splits each channel's total evenly over the pixel's paths, so two nodes' counts do not
//!    multiply: Ch. 3's shadow rays and Ch. 4's hemisphere samples each come out as asked.
//! 5. `resolve_final` (`paths.resolve`): the final outputs (and `resolve_near_final`,
//!    `paths.resolve_near`, where a node holds the near layer; the same after step 2).
//!
//! So `wedge reference` of a sampler pipeline is `first` with no paths and every count at N: N
//! jointly stratified paths per pixel with one secondary sample of each channel.
//!
//! Weights: under a lens (moving camera ray) the record averages per path, so an effect whose
//! samples should weigh the same asks for the same count per path (Ch. 5's `s²`); through a fixed
//! pinhole ray it weighs samples (`docs/SAMPLER-STAGE.md` "Samples, not paths"), so Ch. 3/4 nodes
//! state exact totals with `PerPrimary::Spread`.

use std::sync::Arc;

use wedge_backends::kernels::constant::FillU32Io;
use wedge_backends::kernels::neighbourhood3::Neighbourhood3Io;
use wedge_backends::kernels::paths::{TraceIo, NEAR_LAYER_OUTPUTS, PATH_RECORD, RESOLVE_OUTPUTS};
use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, KernelRegistry, Uniforms, WgslSource};
use wedge_graph::{
    BufferId, ExpandCtx, Format, GraphError, ParamValue, PassBuilder, PerPrimary, Reference, SamplerKind, SamplerPass,
    SamplerPlan, SamplerRequest, SettingMerge, Stage,
};

/// Thesis Ch. 3/4's first pass for `estimator`: one path per pixel through its centre (a fixed pinhole
/// ray, so the record weighs samples), with the count parameter `count` of `node` (an integer ≥ 1)
/// as the per-path samples of setting `per_path_setting`, stratified. Returns the request and that
/// count, the `unit` of the node's `PerPrimary::Spread`.
pub fn centre_path(
    node: &str,
    estimator: &str,
    per_path_setting: &str,
    count: &ParamValue,
) -> Result<(SamplerRequest, u32), GraphError> {
    let per_path = count.as_count().ok_or_else(|| GraphError::Expand {
        node: node.into(),
        message: format!("the count for sampler setting `{per_path_setting}` must be an integer, not {count}"),
    })?;
    let request = SamplerRequest::new()
        .estimator(estimator)
        .setting("paths", ParamValue::Int(1))
        .setting(per_path_setting, ParamValue::Int(i64::from(per_path)))
        .setting("jitter", ParamValue::Bool(false))
        .setting("sampling", ParamValue::Str("stratified".into()));
    Ok((request, per_path))
}

/// A resolve kernel's outputs: (name, format), in binding order.
type OutputList = [(&'static str, Format)];

/// The kernels that resolve a record, their passes' name prefix and their outputs: `paths.resolve`
/// (every mean and statistic) and `paths.resolve_near` (the near layer Defocus's `layers` reads; a
/// kernel apart so that neither exceeds the storage buffers a device binds per stage).
const RESOLVE_KERNELS: [(&str, &str, &OutputList); 2] =
    [("paths.resolve", "resolve", &RESOLVE_OUTPUTS), ("paths.resolve_near", "resolve_near", &NEAR_LAYER_OUTPUTS)];

/// Estimator → `paths.trace` switch. `time` is not a secondary estimator: it gives each path its own
/// shutter time (thesis App. B), so the scene's motion blurs every estimate of the path.
/// `environment`: look-ups into the scene's environment map (thesis Ch. 6).
const ESTIMATORS: [(&str, &str); 4] =
    [("light", "direct"), ("hemisphere", "indirect"), ("time", "time"), ("environment", "environment")];

/// Count channels: (channel, estimator, the [`TraceIo`] binding of its samples over the adaptive
/// pass, the setting giving its first-pass count per path). An estimator's first channel is always bound
/// in the adaptive pass; a later one only where a count request names it — unbound, `paths.trace`
/// gives it the first channel's counts (the glossy part follows the diffuse one unless Ch. 4 counts
/// it apart).
const CHANNELS: [(&str, &str, TotalBinding, &str); 4] = [
    ("light", "light", |io| &mut io.shadow_total, "shadow_per_primary"),
    ("diffuse", "hemisphere", |io| &mut io.diffuse_total, "indirect_per_primary"),
    ("glossy", "hemisphere", |io| &mut io.glossy_total, "indirect_per_primary"),
    ("environment", "environment", |io| &mut io.environment_total, "environment_per_primary"),
];

/// A channel's binding in an adaptive `paths.trace` pass.
type TotalBinding = fn(&mut TraceIo) -> &mut Option<BufferId>;

/// Settings and their defaults (thesis Ch. 3/4: one primary path through the pixel centre).
fn defaults() -> Vec<(&'static str, ParamValue)> {
    vec![
        ("light", ParamValue::Int(0)),
        ("paths", ParamValue::Int(1)),
        ("shadow_per_primary", ParamValue::Int(1)),
        ("indirect_per_primary", ParamValue::Int(1)),
        ("environment_per_primary", ParamValue::Int(1)),
        // Relative luminance below which an occluded environment look-up does not set the occluder
        // term (thesis Sec. 6.7's 0.1, read against the map's mean radiance).
        ("occluder_threshold", ParamValue::Float(0.1)),
        // The environment's light at glossy receivers: the map's table alone (the thesis) or MIS with
        // the lobe (`kernels::environment::GlossySampling`).
        ("environment_glossy", ParamValue::Str("table".into())),
        ("jitter", ParamValue::Bool(false)),
        ("lens", ParamValue::Str("disk".into())),
        ("sampling", ParamValue::Str("stratified".into())),
        ("form_factor", ParamValue::Str("light_centre".into())),
        ("brdf", ParamValue::Str("phong".into())),
        ("bounces", ParamValue::Int(1)),
        // Ambient occlusion instead of radiance for the hemisphere estimator (Ch. 4 Sec. 4.6).
        ("ao", ParamValue::Bool(false)),
        // The hemisphere estimator's glossy part (off: a node that composes no glossy light).
        ("glossy", ParamValue::Bool(true)),
        ("max_distance", ParamValue::Float(0.0)),
        // A pinhole unless a node asks for a lens: a factoring node (its components filtered), or a
        // component node rendering plain Monte Carlo through the camera block (`plain_camera.rs`).
        // The Ch. 3/4 nodes' own filters take texture and emission from one pinhole ray per pixel,
        // so they never run under a lens (SoftShadows composed a sharp albedo with lens-averaged
        // irradiance that way once: docs/DESIGN-NOTES.md "Independent thin-lens check").
        ("aperture_radius", ParamValue::Float(0.0)),
    ]
}

/// Settings without a default: passed to `paths.trace` only where a node sets them (a Defocus node's
/// focus distance).
const OPTIONAL_SETTINGS: [&str; 1] = ["focus_distance"];

/// How two nodes' values of a setting are negotiated (issue 34 §4). Counts take the larger: each
/// node's statistics only gain from more first-pass samples, and the count stage reads the merged
/// plan, so every `PerPrimary::Spread` subtracts the first-pass samples actually traced. Jitter is
/// on where any node asks: a centre ray is one sample of the pixel, and with jittered paths the
/// record weighs paths (`paths.rs` "Weights"), which is unbiased for a pinhole node too. What a
/// setting selects — a light, a lobe, a camera — is one per pipeline.
fn merge_rule(setting: &str) -> SettingMerge {
    let why = match setting {
        "paths" | "shadow_per_primary" | "indirect_per_primary" | "environment_per_primary" => {
            return SettingMerge::Max
        }
        "jitter" => return SettingMerge::Any,
        "light" => {
            "the shared sampler traces shadow rays to one area light per pipeline: filter one light's shadows with \
             SoftShadows and add each other light with a MonteCarlo node (`light`: its index, no `emission` input)"
        }
        "lens" | "aperture_radius" | "focus_distance" => "a pipeline has one camera, and the sampler traces through it",
        "form_factor" => "the shadow estimator weighs every node's light samples one way",
        "brdf" | "bounces" | "ao" | "glossy" | "max_distance" => {
            "the hemisphere estimator traces one kind of indirect light per pipeline (give the nodes the same \
             `brdf`, `bounces`, `mode` and `max_distance`)"
        }
        "sampling" => "stratified or independent applies to every sequence of the record",
        "environment_glossy" => "the environment estimator samples every glossy receiver one way",
        _ => "the sampler takes one value of it per pipeline",
    };
    SettingMerge::Equal { why }
}

/// The `paths.trace` sampler.
pub struct PathSampler;

impl PathSampler {
    fn setting(plan: &SamplerPlan, name: &str) -> ParamValue {
        plan.setting(name).cloned().unwrap_or_else(|| {
            defaults().into_iter().find(|(n, _)| *n == name).map(|(_, v)| v).expect("every setting has a default")
        })
    }

    fn count_setting(plan: &SamplerPlan, name: &str) -> Result<u32, GraphError> {
        match Self::setting(plan, name) {
            ParamValue::Int(v) if (0..=i64::from(u32::MAX)).contains(&v) => Ok(v as u32),
            other => Err(GraphError::Expand {
                node: wedge_graph::SAMPLER_NODE.into(),
                message: format!("sampler setting `{name}` = {other} is not a count (0..=4294967295)"),
            }),
        }
    }

    /// Write the resolved outputs of `record` that nodes hold handles to: one pass per resolve
    /// kernel with a wanted output ([`RESOLVE_KERNELS`]). Bound by name from the kernels' output
    /// lists, the one declaration of the sampler's outputs nodes ask for by name (why it is not a
    /// typed block: `wedge_backends::kernels::paths`, "Bindings").
    fn resolve(ctx: &mut ExpandCtx<'_>, plan: &SamplerPlan, pass: SamplerPass, record: BufferId, stage: Stage) {
        for (kernel, prefix, outputs) in RESOLVE_KERNELS {
            let wanted: Vec<(&str, BufferId)> =
                outputs.iter().filter_map(|(n, _)| plan.handle(pass, n).map(|id| (*n, id))).collect();
            if wanted.is_empty() {
                continue;
            }
            let mut b = ctx.pass(&format!("{prefix}_{}", pass.name()), kernel, stage).read("record", record);
            for (name, id) in wanted {
                b = b.write(name, id);
            }
            b.finish();
        }
    }

    /// The per-pixel max of `sources` (buffers of unit 1): none, the one buffer itself, or a
    /// `sampler.combine` chain named `name`.
    fn max_of(ctx: &mut ExpandCtx<'_>, name: &str, sources: &[(BufferId, u32, u32)]) -> Option<BufferId> {
        match sources {
            [] => None,
            [(one, 1, 0)] => Some(*one),
            _ => Some(Self::combine(ctx, name, sources, 0, Reference::Keep)),
        }
    }

    /// Chain `sampler.combine` over `sources` (buffer, unit, minus), the last pass written with
    /// `role`; with no source, `fill.constant` of `at_least`.
    fn combine(
        ctx: &mut ExpandCtx<'_>,
        name: &str,
        sources: &[(BufferId, u32, u32)],
        at_least: u32,
        role: Reference,
    ) -> BufferId {
        if sources.is_empty() {
            let out = ctx.buffer(name, Format::U32);
            FillU32Io { out }
                .bind(ctx.pass(name, wedge_graph::FILL_CONSTANT, Stage::Counts))
                .int("value", i64::from(at_least))
                .reference(role)
                .finish();
            return out;
        }
        let mut running: Option<BufferId> = None;
        for (k, (value, unit, minus)) in sources.iter().enumerate() {
            let last = k + 1 == sources.len();
            let local = if last { name.to_string() } else { format!("{name}_{k}") };
            let out = ctx.buffer(&local, Format::U32);
            CombineIo { value: *value, other: running, out }
                .bind(ctx.pass(&local, "sampler.combine", Stage::Counts))
                .int("unit", i64::from(*unit))
                .int("minus", i64::from(*minus))
                .int("at_least", i64::from(at_least))
                .reference(if last { role } else { Reference::Keep })
                .finish();
            running = Some(out);
        }
        running.expect("at least one source")
    }
}

impl SamplerKind for PathSampler {
    fn name(&self) -> &'static str {
        "paths"
    }
    fn estimators(&self) -> Vec<&'static str> {
        ESTIMATORS.iter().map(|(e, _)| *e).collect()
    }
    fn channels(&self) -> Vec<(&'static str, &'static str)> {
        CHANNELS.iter().map(|(c, e, _, _)| (*c, *e)).collect()
    }
    fn settings(&self) -> Vec<&'static str> {
        defaults().into_iter().map(|(n, _)| n).chain(OPTIONAL_SETTINGS).collect()
    }
    fn merge(&self, setting: &str) -> SettingMerge {
        merge_rule(setting)
    }
    fn outputs(&self) -> Vec<(&'static str, Format)> {
        let mut o = vec![("record", Format::Struct(&PATH_RECORD))];
        o.extend(RESOLVE_KERNELS.iter().flat_map(|(_, _, outputs)| outputs.iter().copied()));
        o
    }
    fn emit(&self, ctx: &mut ExpandCtx<'_>, plan: &SamplerPlan) -> Result<(), GraphError> {
        let first_paths = Self::count_setting(plan, "paths")?;
        let trace_params = Self::trace_params(plan)?;
        let first = Self::emit_first(ctx, plan, first_paths, &trace_params);
        let counts = Self::emit_counts(ctx, plan, first_paths)?;
        Self::emit_adaptive(ctx, plan, first, counts, &trace_params);
        Ok(())
    }
}

/// A count channel as [`CHANNELS`] lists it.
type Channel = (&'static str, &'static str, TotalBinding, &'static str);

/// What the count stage hands the adaptive pass: its paths per pixel and each bound channel's samples.
struct PassCounts {
    paths: BufferId,
    totals: Vec<(TotalBinding, BufferId)>,
}

/// Whether a count request's key sets `channel`: by its own name or its estimator's.
fn sets(key: &str, channel: &str, estimator: &str) -> bool {
    key == channel || key == estimator
}

/// `value` spread by `neighbourhood.max3` into a buffer `name` where the request asks (`max3`), else
/// `value` itself (thesis Sec. 5.8 step 2).
fn spread(ctx: &mut ExpandCtx<'_>, name: String, value: BufferId, max3: bool) -> BufferId {
    if !max3 {
        return value;
    }
    let out = ctx.buffer(&name, Format::U32);
    Neighbourhood3Io { value, out }.bind(ctx.pass(&name, "neighbourhood.max3", Stage::Counts)).finish();
    out
}

/// Set `params` on a `paths.trace` pass: both passes trace with the same settings, so the adaptive
/// one continues the first one's sequences.
fn with_params<'c, 'a>(mut b: PassBuilder<'c, 'a>, params: &[(&str, ParamValue)]) -> PassBuilder<'c, 'a> {
    for (n, v) in params {
        b = b.param(n, v.clone());
    }
    b
}

impl PathSampler {
    /// The settings both `paths.trace` passes get: the merged plan's (or their defaults), the optional
    /// ones a node set, each estimator's switch and the first pass's samples per path.
    fn trace_params(plan: &SamplerPlan) -> Result<Vec<(&'static str, ParamValue)>, GraphError> {
        let mut trace_params: Vec<(&str, ParamValue)> = [
            "light",
            "jitter",
            "lens",
            "sampling",
            "form_factor",
            "brdf",
            "bounces",
            "ao",
            "max_distance",
            "glossy",
            "aperture_radius",
            "occluder_threshold",
            "environment_glossy",
        ]
        .into_iter()
        .map(|n| (n, Self::setting(plan, n)))
        .collect();
        for n in OPTIONAL_SETTINGS {
            if let Some(v) = plan.setting(n) {
                trace_params.push((n, v.clone()));
            }
        }
        for (estimator, switch) in ESTIMATORS {
            trace_params.push((switch, ParamValue::Bool(plan.estimators.contains(estimator))));
        }
        for per_primary in ["shadow_per_primary", "indirect_per_primary", "environment_per_primary"] {
            trace_params.push((per_primary, ParamValue::Int(i64::from(Self::count_setting(plan, per_primary)?))));
        }
        Ok(trace_params)
    }

    /// Steps 1–2: the first pass (`first_paths` paths per pixel) and its resolve; returns its record.
    fn emit_first(
        ctx: &mut ExpandCtx<'_>,
        plan: &SamplerPlan,
        first_paths: u32,
        trace_params: &[(&str, ParamValue)],
    ) -> BufferId {
        let first = plan
            .handle(SamplerPass::First, "record")
            .unwrap_or_else(|| ctx.buffer("first_record", Format::Struct(&PATH_RECORD)));
        let b = TraceIo::new(first)
            .bind(ctx.pass("first", "paths.trace", Stage::Sample))
            .int("count", i64::from(first_paths));
        with_params(b, trace_params).random().reference(Reference::Continued).finish();
        Self::resolve(ctx, plan, SamplerPass::First, first, Stage::Sample);
        first
    }

    /// Step 3: paths per pixel, then each bound channel's samples over the adaptive pass.
    fn emit_counts(ctx: &mut ExpandCtx<'_>, plan: &SamplerPlan, first_paths: u32) -> Result<PassCounts, GraphError> {
        let mut path_sources = Self::request_paths(ctx, plan, first_paths);
        let channels = Self::bound_channels(plan);
        let rests = Self::spread_rests(ctx, plan, first_paths, &channels, &mut path_sources)?;
        let paths = Self::combine(ctx, "counts_paths", &path_sources, 0, Reference::Count);
        let totals = channels
            .iter()
            .map(|&(channel, estimator, binding, _)| {
                (binding, Self::channel_total(ctx, plan, channel, estimator, paths, &rests))
            })
            .collect();
        Ok(PassCounts { paths, totals })
    }

    /// The count requests' paths per pixel, as `sampler.combine` sources (buffer, unit, minus).
    fn request_paths(ctx: &mut ExpandCtx<'_>, plan: &SamplerPlan, first_paths: u32) -> Vec<(BufferId, u32, u32)> {
        let mut path_sources: Vec<(BufferId, u32, u32)> = Vec::new();
        for (k, (_, r)) in plan.requests.iter().enumerate() {
            let Some(paths) = r.paths else { continue };
            let value = spread(ctx, format!("counts_max3_{k}"), paths, r.max3);
            // A total over both passes includes the first pass's paths; a request beyond it does not.
            path_sources.push((value, r.paths_unit, if r.beyond_first { 0 } else { first_paths }));
        }
        path_sources
    }

    /// The channels bound in the adaptive pass: the first of each estimator in use, and a later one
    /// where a request names it.
    fn bound_channels(plan: &SamplerPlan) -> Vec<Channel> {
        CHANNELS
            .into_iter()
            .enumerate()
            .filter(|(index, (channel, estimator, _, _))| {
                let named = plan.requests.iter().any(|(_, r)| r.per_primary.iter().any(|(key, _)| key == channel));
                let first_of_estimator = CHANNELS[..*index].iter().all(|(_, e, _, _)| e != estimator);
                plan.estimators.contains(*estimator) && (first_of_estimator || named)
            })
            .map(|(_, c)| c)
            .collect()
    }

    /// `PerPrimary::Spread`: the samples left after the first pass's, per channel and request, each
    /// added to `path_sources` as paths of about `unit` samples. Returns (request, channel, rest).
    fn spread_rests(
        ctx: &mut ExpandCtx<'_>,
        plan: &SamplerPlan,
        first_paths: u32,
        channels: &[Channel],
        path_sources: &mut Vec<(BufferId, u32, u32)>,
    ) -> Result<Vec<(usize, &'static str, BufferId)>, GraphError> {
        let mut rests: Vec<(usize, &str, BufferId)> = Vec::new();
        for &(channel, estimator, _, first_setting) in channels {
            let first = first_paths.saturating_mul(Self::count_setting(plan, first_setting)?);
            for (k, (_, r)) in plan.requests.iter().enumerate() {
                for (key, per) in &r.per_primary {
                    let PerPrimary::Spread { total, unit } = *per else { continue };
                    if !sets(key, channel, estimator) {
                        continue;
                    }
                    let total = spread(ctx, format!("counts_{channel}_max3_{k}"), total, r.max3);
                    let rest = Self::combine(
                        ctx,
                        &format!("counts_{channel}_rest_{k}"),
                        &[(total, 1, first)],
                        0,
                        Reference::Keep,
                    );
                    // Paths of about `unit` samples each.
                    path_sources.push((rest, unit, 0));
                    rests.push((k, channel, rest));
                }
            }
        }
        Ok(rests)
    }

    /// One channel's samples over the adaptive pass (`counts_<channel>`, role `Count`).
    fn channel_total(
        ctx: &mut ExpandCtx<'_>,
        plan: &SamplerPlan,
        channel: &str,
        estimator: &str,
        paths: BufferId,
        rests: &[(usize, &str, BufferId)],
    ) -> BufferId {
        let (per_path, at_least) = Self::per_path(ctx, plan, channel, estimator, paths);
        let channel_rests: Vec<(BufferId, u32, u32)> =
            rests.iter().filter(|(_, c, _)| *c == channel).map(|(_, _, id)| (*id, 1, 0)).collect();
        let rest = Self::max_of(ctx, &format!("counts_{channel}_rest"), &channel_rests);
        // The channel's samples over the adaptive pass: `paths × per path`, or the spreads' rest
        // where larger; `paths.trace` splits it evenly over the paths. A reference's count (N
        // paths) makes it N: one sample per path.
        let name = format!("counts_{channel}");
        let total = ctx.buffer(&name, Format::U32);
        PassTotalIo { paths, per_path, rest, out: total }
            .bind(ctx.pass(&name, "sampler.pass_total", Stage::Counts))
            .int("at_least", i64::from(at_least))
            .reference(Reference::Count)
            .finish();
        total
    }

    /// A channel's samples per path: the per-pixel max of its `Buffer` and `Total` requests (`None`
    /// without any), and the minimum per path (`at_least`: the largest `Constant`, at least 1).
    fn per_path(
        ctx: &mut ExpandCtx<'_>,
        plan: &SamplerPlan,
        channel: &str,
        estimator: &str,
        paths: BufferId,
    ) -> (Option<BufferId>, u32) {
        // Per path: at least one secondary sample (Ch. 5), except for a channel counted only by
        // spreads, whose paths may carry none of it.
        let mut at_least = 1u32;
        let mut spread_only = None;
        let mut per_path: Vec<(BufferId, u32, u32)> = Vec::new();
        for (k, (_, r)) in plan.requests.iter().enumerate() {
            for (key, per) in &r.per_primary {
                if !sets(key, channel, estimator) {
                    continue;
                }
                spread_only = Some(spread_only.unwrap_or(true) && matches!(per, PerPrimary::Spread { .. }));
                match per {
                    PerPrimary::Constant(c) => at_least = at_least.max(*c),
                    PerPrimary::Buffer(id) => per_path.push((*id, 1, 0)),
                    PerPrimary::Total(id) => {
                        // The total over the adaptive pass as s² per path.
                        let total = spread(ctx, format!("counts_{channel}_max3_{k}"), *id, r.max3);
                        let name = format!("counts_{channel}_per_path_{k}");
                        let out = ctx.buffer(&name, Format::U32);
                        PerPrimaryIo { total, paths, out }
                            .bind(ctx.pass(&name, "sampler.per_primary", Stage::Counts))
                            .finish();
                        per_path.push((out, 1, 0));
                    }
                    PerPrimary::Spread { .. } => {}
                }
            }
        }
        if spread_only == Some(true) {
            at_least = 0;
        }
        (Self::max_of(ctx, &format!("counts_{channel}_per_path"), &per_path), at_least)
    }

    /// Steps 4–5: the adaptive pass continuing the first pass's record and sequences, and its resolve.
    fn emit_adaptive(
        ctx: &mut ExpandCtx<'_>,
        plan: &SamplerPlan,
        first: BufferId,
        counts: PassCounts,
        trace_params: &[(&str, ParamValue)],
    ) {
        let last = plan
            .handle(SamplerPass::Final, "record")
            .unwrap_or_else(|| ctx.buffer("final_record", Format::Struct(&PATH_RECORD)));
        let mut io = TraceIo { previous: Some(first), counts: Some(counts.paths), ..TraceIo::new(last) };
        for (binding, id) in counts.totals {
            *binding(&mut io) = Some(id);
        }
        let b = io.bind(ctx.pass("adaptive", "paths.trace", Stage::Adaptive)).int("count", 0);
        with_params(b, trace_params).random_continuing("first").reference(Reference::Sample).finish();
        Self::resolve(ctx, plan, SamplerPass::Final, last, Stage::Adaptive);
    }
}

/// `sampler.combine`: one step of the per-pixel max of count requests,
/// `out = max(ceil(value / unit) − minus (saturating), other, at_least)` (`other` optional: the
/// running max of the earlier requests). Integer-only, so both backends agree bit for bit.
pub struct CombineCounts;

wedge_backends::kernel_params! {
    /// `sampler.combine`'s parameters, set by the sampler (WGSL: `params.NAME`).
    pub struct CombineParams {
        /// Divisor of `value`, at least 1.
        unit: u32,
        minus: u32,
        at_least: u32,
    }
}

fn combine_params(ctx: &KernelCtx<'_>) -> Result<CombineParams, BackendError> {
    let p = CombineParams::read(ctx)?;
    if p.unit == 0 {
        return Err(ctx.err("`unit` = 0 is out of range".into()));
    }
    Ok(p)
}

/// One pixel of [`CombineCounts`].
pub fn combine_pixel(value: u32, other: u32, unit: u32, minus: u32, at_least: u32) -> u32 {
    value.div_ceil(unit).saturating_sub(minus).max(other).max(at_least)
}

wedge_backends::kernel_bindings! {
    /// What a `sampler.combine` pass binds.
    pub struct CombineIo / CombineData {
        read value: u32,
        read_opt other: u32,
        write out: u32,
    }
}

impl Kernel for CombineCounts {
    wedge_backends::kernel_signature!(
        name: "sampler.combine", class: Bandwidth, bindings: CombineIo, params: [CombineParams]
    );
    /// WGSL mirror: `shaders/sampler_combine.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../shaders/sampler_combine.wgsl"), |ctx| {
                Ok(combine_params(ctx)?.uniforms())
            })
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let CombineParams { unit, minus, at_least } = combine_params(ctx)?;
        let CombineData { value, other, out } = CombineIo::read(ctx)?;
        let counts =
            (0..ctx.pixels()).map(|i| combine_pixel(value[i], other.map_or(0, |o| o[i]), unit, minus, at_least));
        out.put(ctx, counts.collect())
    }
}

/// `sampler.per_primary`: secondary samples per path from an estimator's total over the adaptive
/// pass (`PerPrimary::Total`): the smallest square `s²` with `paths · s² ≥ total`, `s` in `[1, 64]`
/// (so at most 4096 per path, the Ch. 5 rates' cap). Integer-only; WGSL mirror
/// `shaders/sampler_per_primary.wgsl`.
pub struct PerPrimaryCounts;

/// Largest strata per secondary axis `sampler.per_primary` gives (64² = 4096 samples per path).
pub const MAX_PER_PRIMARY_STRATA: u32 = 64;

/// One pixel of [`PerPrimaryCounts`].
pub fn per_primary_pixel(paths: u32, total: u32) -> u32 {
    let p = paths.max(1);
    let q = total.div_ceil(p);
    let mut s = ((q as f32).sqrt() as u32).min(MAX_PER_PRIMARY_STRATA);
    while s > 1 && s * s > q {
        s -= 1;
    }
    while s < MAX_PER_PRIMARY_STRATA && s * s < q {
        s += 1;
    }
    let s = s.max(1);
    s * s
}

/// `sampler.pass_total`: a channel's secondary samples over the adaptive pass,
/// `out = max(paths × max(per_path, at_least), rest)` (saturating; `per_path`, `rest` optional, 0
/// when unbound), which `paths.trace` splits evenly over the pixel's paths. Integer-only; WGSL
/// mirror `shaders/sampler_pass_total.wgsl`.
pub struct PassTotal;

/// One pixel of [`PassTotal`].
pub fn pass_total_pixel(paths: u32, per_path: u32, rest: u32, at_least: u32) -> u32 {
    paths.saturating_mul(per_path.max(at_least)).max(rest)
}

wedge_backends::kernel_params! {
    /// `sampler.pass_total`'s one parameter, set by the sampler (WGSL: `params.at_least`).
    pub struct PassTotalParams {
        at_least: u32,
    }
}

wedge_backends::kernel_bindings! {
    /// What a `sampler.pass_total` pass binds.
    pub struct PassTotalIo / PassTotalData {
        read paths: u32,
        read_opt per_path: u32,
        read_opt rest: u32,
        write out: u32,
    }
}

impl Kernel for PassTotal {
    wedge_backends::kernel_signature!(
        name: "sampler.pass_total", class: Bandwidth, bindings: PassTotalIo, params: [PassTotalParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../shaders/sampler_pass_total.wgsl"), |ctx| {
                Ok(PassTotalParams::read(ctx)?.uniforms())
            })
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let PassTotalParams { at_least } = PassTotalParams::read(ctx)?;
        let PassTotalData { paths, per_path, rest, out } = PassTotalIo::read(ctx)?;
        let at = |b: Option<&[u32]>, i: usize| b.map_or(0, |b| b[i]);
        let totals = (0..ctx.pixels()).map(|i| pass_total_pixel(paths[i], at(per_path, i), at(rest, i), at_least));
        out.put(ctx, totals.collect())
    }
}

wedge_backends::kernel_bindings! {
    /// What a `sampler.per_primary` pass binds.
    pub struct PerPrimaryIo / PerPrimaryData {
        read total: u32,
        read paths: u32,
        write out: u32,
    }
}

impl Kernel for PerPrimaryCounts {
    wedge_backends::kernel_signature!(name: "sampler.per_primary", class: Bandwidth, bindings: PerPrimaryIo);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../shaders/sampler_per_primary.wgsl"), |_| Ok(Uniforms::new()))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let PerPrimaryData { total, paths, out } = PerPrimaryIo::read(ctx)?;
        out.put(ctx, (0..ctx.pixels()).map(|i| per_primary_pixel(paths[i], total[i])).collect())
    }
}

pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(CombineCounts));
    reg.register(Arc::new(PerPrimaryCounts));
    reg.register(Arc::new(PassTotal));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn combine_is_the_max_of_rounded_up_requests_less_the_first_pass() {
        // 143 shadow rays at 9 per path: 16 paths, 1 of them in the first pass.
        assert_eq!(combine_pixel(143, 0, 9, 1, 0), 15);
        // A request at or below the first pass adds nothing; another request's max wins.
        assert_eq!(combine_pixel(9, 0, 9, 1, 0), 0);
        assert_eq!(combine_pixel(9, 7, 9, 1, 0), 7);
        // Per-primary counts: at least one, or the largest constant asked.
        assert_eq!(combine_pixel(0, 0, 1, 0, 1), 1);
        assert_eq!(combine_pixel(4, 2, 1, 0, 9), 9);
        assert_eq!(combine_pixel(u32::MAX, 0, 1, 0, 0), u32::MAX);
    }

    #[test]
    fn per_primary_is_the_smallest_square_covering_the_total() {
        assert_eq!(per_primary_pixel(4, 36), 9);
        assert_eq!(per_primary_pixel(4, 37), 16);
        assert_eq!(per_primary_pixel(9, 1), 1);
        assert_eq!(per_primary_pixel(0, 5), 9);
        assert_eq!(per_primary_pixel(1, 0), 1);
        assert_eq!(per_primary_pixel(1, u32::MAX), 4096);
        // Matches the Ch. 5 formula the rates use.
        for (p, n) in [(1, 400), (16, 143), (25, 2500), (3, 10)] {
            assert_eq!(per_primary_pixel(p, n), crate::defocus::formulas::secondary_per_primary(p, n));
        }
    }

    #[test]
    fn a_pass_total_is_paths_times_per_path_or_the_spread_rest() {
        // Ch. 5: 4 paths of 9 (s²); at least one per path.
        assert_eq!(pass_total_pixel(4, 9, 0, 1), 36);
        assert_eq!(pass_total_pixel(4, 0, 0, 1), 4);
        // A spread's rest alone: exactly it, also on paths another channel asked for.
        assert_eq!(pass_total_pixel(12, 0, 30, 0), 30);
        assert_eq!(pass_total_pixel(12, 0, 0, 0), 0);
        assert_eq!(pass_total_pixel(3, 2, 5, 1), 6);
        assert_eq!(pass_total_pixel(u32::MAX, 2, 0, 1), u32::MAX);
    }
}
