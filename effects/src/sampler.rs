//! The shared path sampler (thesis Ch. 5, Sec. 5.3–5.4 and 5.8 steps 1–3; `docs/SAMPLER-STAGE.md`
//! §4): the [`wedge_graph::SamplerKind`] wedge registers, emitting — once per pipeline, after every
//! node asked for it from `expand` ([`wedge_graph::sampler`]) — these passes of node `sampler`:
//!
//! 1. `first` (`Stage::Sample`, `paths.trace`): `paths` primary paths per pixel (setting; thesis
//!    Ch. 3/4: `n_p = 1` through the pixel centre), `shadow_per_primary` / `indirect_per_primary`
//!    secondary samples each, only the estimators some node asked for (`light`: shadow rays to area
//!    light `light`; `hemisphere`: one-bounce indirect). Reference role `Continued`.
//! 2. `resolve_first` (`paths.resolve`): the first-pass outputs nodes hold handles to.
//! 3. `Stage::Counts` (thesis Sec. 5.4): the adaptive pass's paths per pixel are the per-pixel max
//!    over the count requests of `ceil(request / paths_unit)` (each request first spread by
//!    `neighbourhood.max3` where it asks, Sec. 5.8 step 2), less the first pass's paths
//!    (`counts_paths`, role `Count`); secondary samples per primary are the per-pixel max over the
//!    requests, at least 1 (`counts_<estimator>`, role `CountPerPrimary`). The combining kernel is
//!    [`CombineCounts`] (`sampler.combine`), chained over the requests.
//! 4. `adaptive` (`Stage::Adaptive`, `paths.trace`): continues `first`'s record and its random
//!    sequences (same stream: the union of both passes is one progressive Sobol' set), role `Sample`.
//! 5. `resolve_final` (`paths.resolve`): the final outputs.
//!
//! So `wedge reference` of a sampler pipeline is `first` with no paths, the counts at N paths per
//! pixel with one secondary sample per estimator each: N jointly stratified paths per pixel.
//!
//! Every path of a pixel carries the same number of secondary samples in each pass (the record
//! averages per path), so an effect keeps equal weight per sample by asking for the first pass's
//! per-primary count and stating its rate in samples (`paths_unit`), as `SoftShadows` does.

use std::sync::Arc;

use wedge_backends::kernels::paths::{PATH_RECORD, RESOLVE_OUTPUTS};
use wedge_backends::{BackendError, Binding, Kernel, KernelClass, KernelCtx, KernelRegistry, Uniforms, WgslSource};
use wedge_graph::{
    BufferId, ExpandCtx, Format, GraphError, ParamValue, PerPrimary, Reference, SamplerKind, SamplerPass, SamplerPlan,
    Stage,
};

/// Estimator → (`paths.trace` switch, per-primary parameter and binding).
const ESTIMATORS: [(&str, &str, &str); 2] =
    [("light", "direct", "shadow_per_primary"), ("hemisphere", "indirect", "indirect_per_primary")];

/// Settings and their defaults (thesis Ch. 3/4: one primary path through the pixel centre).
fn defaults() -> Vec<(&'static str, ParamValue)> {
    vec![
        ("light", ParamValue::Int(0)),
        ("paths", ParamValue::Int(1)),
        ("shadow_per_primary", ParamValue::Int(1)),
        ("indirect_per_primary", ParamValue::Int(1)),
        ("jitter", ParamValue::Bool(false)),
        ("lens", ParamValue::Str("disk".into())),
        ("sampling", ParamValue::Str("stratified".into())),
        ("form_factor", ParamValue::Str("light_centre".into())),
        ("brdf", ParamValue::Str("phong".into())),
        ("bounces", ParamValue::Int(1)),
        // A pinhole unless a node asks for a lens (a Defocus node): a camera block's aperture alone
        // does not make the sampler's rays defocused while `Primary` and the Ch. 3/4 nodes' texture
        // and emission come from one pinhole ray per pixel (SoftShadows composed a sharp albedo with
        // lens-averaged irradiance that way: docs/DESIGN-NOTES.md "Independent thin-lens check").
        ("aperture_radius", ParamValue::Float(0.0)),
    ]
}

/// Settings without a default: passed to `paths.trace` only where a node sets them (a Defocus node's
/// focus distance).
const OPTIONAL_SETTINGS: [&str; 1] = ["focus_distance"];

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

    /// Write the resolved outputs of `record` that nodes hold handles to, in one pass.
    fn resolve(ctx: &mut ExpandCtx<'_>, plan: &SamplerPlan, pass: SamplerPass, record: BufferId, stage: Stage) {
        let wanted: Vec<(&str, BufferId)> =
            RESOLVE_OUTPUTS.iter().filter_map(|(n, _)| plan.handle(pass, n).map(|id| (*n, id))).collect();
        if wanted.is_empty() {
            return;
        }
        let mut b = ctx.pass(&format!("resolve_{}", pass.name()), "paths.resolve", stage).read("record", record);
        for (name, id) in wanted {
            b = b.write(name, id);
        }
        b.finish();
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
            ctx.pass(name, wedge_graph::FILL_CONSTANT, Stage::Counts)
                .write("out", out)
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
            ctx.pass(&local, "sampler.combine", Stage::Counts)
                .read("value", *value)
                .read_opt("other", running)
                .write("out", out)
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
        ESTIMATORS.iter().map(|(e, _, _)| *e).collect()
    }
    fn settings(&self) -> Vec<&'static str> {
        defaults().into_iter().map(|(n, _)| n).chain(OPTIONAL_SETTINGS).collect()
    }
    fn outputs(&self) -> Vec<(&'static str, Format)> {
        let mut o = vec![("record", Format::Struct(&PATH_RECORD))];
        o.extend(RESOLVE_OUTPUTS.iter().copied());
        o
    }
    fn emit(&self, ctx: &mut ExpandCtx<'_>, plan: &SamplerPlan) -> Result<(), GraphError> {
        let first_paths = Self::count_setting(plan, "paths")?;
        let mut trace_params: Vec<(&str, ParamValue)> = ["light", "jitter", "lens", "sampling", "form_factor", "brdf", "bounces", "aperture_radius"]
            .into_iter()
            .map(|n| (n, Self::setting(plan, n)))
            .collect();
        for n in OPTIONAL_SETTINGS {
            if let Some(v) = plan.setting(n) {
                trace_params.push((n, v.clone()));
            }
        }
        for (estimator, switch, per_primary) in ESTIMATORS {
            trace_params.push((switch, ParamValue::Bool(plan.estimators.contains(estimator))));
            trace_params.push((per_primary, ParamValue::Int(i64::from(Self::count_setting(plan, per_primary)?))));
        }

        // 1–2. First pass and its resolve.
        let first = plan.handle(SamplerPass::First, "record").unwrap_or_else(|| ctx.buffer("first_record", Format::Struct(&PATH_RECORD)));
        let mut b = ctx.pass("first", "paths.trace", Stage::Sample).write("record", first).int("count", i64::from(first_paths));
        for (n, v) in &trace_params {
            b = b.param(n, v.clone());
        }
        b.random().reference(Reference::Continued).finish();
        Self::resolve(ctx, plan, SamplerPass::First, first, Stage::Sample);

        // 3. Counts: paths per pixel, then secondary samples per primary per asked estimator.
        let spread = |ctx: &mut ExpandCtx<'_>, name: String, value: BufferId, max3: bool| {
            if !max3 {
                return value;
            }
            let out = ctx.buffer(&name, Format::U32);
            ctx.pass(&name, "neighbourhood.max3", Stage::Counts).read("value", value).write("out", out).finish();
            out
        };
        let mut path_sources: Vec<(BufferId, u32, u32)> = Vec::new();
        for (k, (_, r)) in plan.requests.iter().enumerate() {
            let Some(paths) = r.paths else { continue };
            let value = spread(ctx, format!("counts_max3_{k}"), paths, r.max3);
            // A total over both passes includes the first pass's paths; a request beyond it does not.
            path_sources.push((value, r.paths_unit, if r.beyond_first { 0 } else { first_paths }));
        }
        let paths = Self::combine(ctx, "counts_paths", &path_sources, 0, Reference::Count);
        let mut per_primary: Vec<(&str, BufferId)> = Vec::new();
        for (estimator, _, binding) in ESTIMATORS {
            if !plan.estimators.contains(estimator) {
                continue;
            }
            let mut at_least = 1u32;
            let mut sources: Vec<(BufferId, u32, u32)> = Vec::new();
            for (k, (_, r)) in plan.requests.iter().enumerate() {
                for (e, per) in &r.per_primary {
                    match (e.as_str() == estimator, per) {
                        (true, PerPrimary::Constant(c)) => at_least = at_least.max(*c),
                        (true, PerPrimary::Buffer(id)) => sources.push((*id, 1, 0)),
                        (true, PerPrimary::Total(id)) => {
                            // The total spread over the adaptive pass's paths as s² per path.
                            let total = spread(ctx, format!("counts_{estimator}_max3_{k}"), *id, r.max3);
                            let name = format!("counts_{estimator}_per_path_{k}");
                            let out = ctx.buffer(&name, Format::U32);
                            ctx.pass(&name, "sampler.per_primary", Stage::Counts)
                                .read("total", total)
                                .read("paths", paths)
                                .write("out", out)
                                .finish();
                            sources.push((out, 1, 0));
                        }
                        _ => {}
                    }
                }
            }
            let id = Self::combine(ctx, &format!("counts_{estimator}"), &sources, at_least, Reference::CountPerPrimary);
            per_primary.push((binding, id));
        }

        // 4–5. Adaptive pass continuing the first pass's record and sequences, and its resolve.
        let last = plan.handle(SamplerPass::Final, "record").unwrap_or_else(|| ctx.buffer("final_record", Format::Struct(&PATH_RECORD)));
        let mut b = ctx
            .pass("adaptive", "paths.trace", Stage::Adaptive)
            .read("previous", first)
            .read("counts", paths)
            .write("record", last)
            .int("count", 0);
        for (binding, id) in per_primary {
            b = b.read(binding, id);
        }
        for (n, v) in &trace_params {
            b = b.param(n, v.clone());
        }
        b.random_continuing("first").reference(Reference::Sample).finish();
        Self::resolve(ctx, plan, SamplerPass::Final, last, Stage::Adaptive);
        Ok(())
    }
}

/// `sampler.combine`: one step of the per-pixel max of count requests,
/// `out = max(ceil(value / unit) − minus (saturating), other, at_least)` (`other` optional: the
/// running max of the earlier requests). Integer-only, so both backends agree bit for bit.
pub struct CombineCounts;

fn combine_params(ctx: &KernelCtx<'_>) -> Result<(u32, u32, u32), BackendError> {
    let get = |name: &str, min: i64| -> Result<u32, BackendError> {
        let v = ctx.int_param(name)?;
        if v < min || v > i64::from(u32::MAX) {
            return Err(BackendError::Kernel { pass: ctx.pass.into(), message: format!("`{name}` = {v} is out of range") });
        }
        Ok(v as u32)
    };
    Ok((get("unit", 1)?, get("minus", 0)?, get("at_least", 0)?))
}

/// One pixel of [`CombineCounts`].
pub fn combine_pixel(value: u32, other: u32, unit: u32, minus: u32, at_least: u32) -> u32 {
    value.div_ceil(unit).saturating_sub(minus).max(other).max(at_least)
}

impl Kernel for CombineCounts {
    fn name(&self) -> &'static str {
        "sampler.combine"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![Binding::read("value", Format::U32), Binding::read_opt("other", Format::U32), Binding::write("out", Format::U32)]
    }
    /// WGSL mirror: `shaders/sampler_combine.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../shaders/sampler_combine.wgsl"), |ctx| {
                let (unit, minus, at_least) = combine_params(ctx)?;
                Ok(Uniforms::new().u32("unit", unit).u32("minus", minus).u32("at_least", at_least))
            })
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (unit, minus, at_least) = combine_params(ctx)?;
        let value = ctx.read::<u32>("value")?;
        let other = ctx.read_opt::<u32>("other")?;
        let out: Vec<u32> =
            (0..ctx.pixels()).map(|i| combine_pixel(value[i], other.map_or(0, |o| o[i]), unit, minus, at_least)).collect();
        ctx.put("out", out)
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

impl Kernel for PerPrimaryCounts {
    fn name(&self) -> &'static str {
        "sampler.per_primary"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![Binding::read("total", Format::U32), Binding::read("paths", Format::U32), Binding::write("out", Format::U32)]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(WgslSource::new(include_str!("../../shaders/sampler_per_primary.wgsl"), |_| Ok(Uniforms::new())).per_pixel())
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let total = ctx.read::<u32>("total")?;
        let paths = ctx.read::<u32>("paths")?;
        let out: Vec<u32> = (0..ctx.pixels()).map(|i| per_primary_pixel(paths[i], total[i])).collect();
        ctx.put("out", out)
    }
}

pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(CombineCounts));
    reg.register(Arc::new(PerPrimaryCounts));
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
}
