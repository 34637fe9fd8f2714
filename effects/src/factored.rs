//! Passes every factoring node (thesis Ch. 5's Defocus, App. B's Motion) builds the same way: the
//! irradiance and screen-space filter chains, the compose of a component's factored parts (eq. 5.32:
//! `k̃ Ẽ` where a part factors, else `L`, summed over parts) with the component node's ports, and the
//! sum of components the factoring node blurs, with the emission its camera rays see where its image
//! declares it.

use wedge_backends::kernels::constant::{FillF32Io, FillU32Io};
use wedge_backends::kernels::filter_window::Axis;
use wedge_backends::kernels::irradiance_filter::IrradianceIo;
use wedge_backends::kernels::neighbourhood3::Neighbourhood3Io;
use wedge_graph::{
    BufferId, ExpandCtx, Format, GraphError, ParamValue, Part, PassBuilder, Reference, SamplerPass, Stage, TermKind,
    FILL_CONSTANT,
};

use crate::add::AddIo;
use crate::defocus::formulas::FACTORING_THRESHOLD;
use crate::defocus::kernels::{ComposeIo, FlagsIo};

/// SepDir / SepInd of `part` on the `pass` record (eq. 5.30: `‖L − k E‖` below a threshold, so `k E`
/// may stand for the pixel's `L`), with the 3×3 median where `median` (Ch. 5: its flags come from
/// noisy first-pass estimates), in a buffer `<name>`; all 0 without factoring (Ch. 5's ablation).
/// `role` is the last pass's part in a reference.
#[allow(clippy::too_many_arguments)]
pub fn factor_flags(
    ctx: &mut ExpandCtx<'_>,
    name: &str,
    part: &Part,
    (pass, stage): (SamplerPass, Stage),
    factor: bool,
    median: bool,
    role: Reference,
) -> Result<BufferId, GraphError> {
    let out = ctx.buffer(name, Format::U32);
    if !factor {
        FillU32Io { out }.bind(ctx.pass(name, FILL_CONSTANT, stage)).int("value", 0).reference(role).finish();
        return Ok(out);
    }
    let (l, k, e) = (
        ctx.sampler_output(pass, part.radiance)?,
        ctx.sampler_output(pass, part.texture)?,
        ctx.sampler_output(pass, part.irradiance)?,
    );
    let raw = if median { ctx.buffer(&format!("{name}_raw"), Format::U32) } else { out };
    let raw_name = if median { format!("{name}_raw") } else { name.to_string() };
    FlagsIo { radiance: l, texture: k, irradiance: e, flag: raw }
        .bind(ctx.pass(&raw_name, "defocus.flags", stage))
        .float("threshold", f64::from(FACTORING_THRESHOLD))
        .reference(if median { Reference::Keep } else { role })
        .finish();
    if median {
        let io = Neighbourhood3Io { value: raw, out };
        io.bind(ctx.pass(name, "neighbourhood.median3", stage)).reference(role).finish();
    }
    Ok(out)
}

/// A Ch. 5 filter (`filter.irradiance` or `filter.defocus`) on `value`: the x then the y pass
/// (`<name>_x`, `<name>_y`) when `separable`, else the 2-D reference (`<name>`); a reference
/// bypasses them. `bind(pass, value, out)` binds one pass's buffers (the kernel's `kernel_bindings!`
/// struct).
#[allow(clippy::too_many_arguments)]
pub fn filter_chain(
    ctx: &mut ExpandCtx<'_>,
    name: &str,
    kernel: &str,
    stage: Stage,
    value: BufferId,
    bind: impl for<'c, 'a> Fn(PassBuilder<'c, 'a>, BufferId, BufferId) -> PassBuilder<'c, 'a>,
    params: &[(&str, ParamValue)],
    separable: bool,
) -> BufferId {
    let axes: &[(Axis, &str)] = if separable { &[(Axis::X, "_x"), (Axis::Y, "_y")] } else { &[(Axis::Both, "")] };
    let mut value = value;
    for (axis, suffix) in axes {
        let local = format!("{name}{suffix}");
        let out = ctx.buffer(&local, Format::Vec3);
        let mut b = bind(ctx.pass(&local, kernel, stage), value, out);
        for (n, v) in params.iter().cloned().chain([axis.param()]) {
            b = b.param(n, v);
        }
        b.reference(Reference::Bypass { input: "value" }).finish();
        value = out;
    }
    value
}

/// `filter.irradiance` (eq. 5.31) as a component's parts run it: world-space distances between the
/// final pass's path-averaged positions, the 10° normal test, the width `omega` (pixel⁻¹) converted
/// to metres by `pixel_length`.
pub struct IrradianceFilter {
    pub position: BufferId,
    pub normal: BufferId,
    pub omega: BufferId,
    pub pixel_length: BufferId,
    pub max_radius: ParamValue,
    pub separable: bool,
}

impl IrradianceFilter {
    /// The filter on `e`, passes named `<name>` (`_x`, `_y` when separable).
    pub fn apply(&self, ctx: &mut ExpandCtx<'_>, name: &str, e: BufferId) -> BufferId {
        filter_chain(
            ctx,
            name,
            "filter.irradiance",
            Stage::Filter,
            e,
            |b, value, out| {
                let (position, normal, omega, pixel_length) =
                    (self.position, self.normal, self.omega, self.pixel_length);
                IrradianceIo { value, position, normal, omega, pixel_length, out }.bind(b)
            },
            &[("max_radius", self.max_radius.clone()), ("normal_cos", ParamValue::Float(10f64.to_radians().cos()))],
            self.separable,
        )
    }
}

/// One factored part's buffers for the compose: its `L`, its (filtered) `k` and `E`, and the flag
/// that says where it factors.
pub struct PartTerms {
    pub l: BufferId,
    pub k: BufferId,
    pub e: BufferId,
    pub flag: BufferId,
}

/// Eq. 5.32 for a component: `defocus.compose` per part (`<part>_compose`, each adding to the
/// previous part's sum) and Σ L (`<part>_unfiltered`), plus `extra` in both (e.g. emission) where
/// given, bound to the component node's ports `radiance` and `unfiltered`, with `filter_width` and
/// `rays_per_pixel`.
pub fn compose_component(
    ctx: &mut ExpandCtx<'_>,
    parts: &[(&Part, PartTerms)],
    extra: Option<BufferId>,
    filter_width: BufferId,
    rays: BufferId,
) {
    let (mut radiance, mut unfiltered): (Option<BufferId>, Option<BufferId>) = (extra, extra);
    for (part, t) in parts {
        let name = format!("{}_compose", part.name);
        let out = ctx.buffer(&name, Format::Vec3);
        let io = ComposeIo { radiance: t.l, texture: t.k, irradiance: t.e, flag: t.flag, previous: radiance, out };
        io.bind(ctx.pass(&name, "defocus.compose", Stage::Compose)).finish();
        radiance = Some(out);
        unfiltered = Some(match unfiltered {
            None => t.l,
            Some(prev) => {
                let name = format!("{}_unfiltered", part.name);
                let sum = ctx.buffer(&name, Format::Vec3);
                AddIo { a: prev, b: t.l, out: sum }.bind(ctx.pass(&name, "compose.add", Stage::Compose)).finish();
                sum
            }
        });
    }
    ctx.output("radiance", radiance.expect("a component has parts"));
    ctx.output("unfiltered", unfiltered.expect("a component has parts"));
    ctx.output("filter_width", filter_width);
    ctx.output("rays_per_pixel", rays);
}

/// `a + b + …` by a chain of `compose.add` passes named `<name>`, `<name>_1`, …; a single buffer is
/// returned as it is.
pub fn sum(ctx: &mut ExpandCtx<'_>, name: &str, terms: &[BufferId], extra: Option<BufferId>) -> BufferId {
    let all: Vec<BufferId> = terms.iter().copied().chain(extra).collect();
    let mut acc = all[0];
    for (k, b) in all[1..].iter().enumerate() {
        let local = if k + 2 == all.len() { name.to_string() } else { format!("{name}_{}", k + 1) };
        let out = ctx.buffer(&local, Format::Vec3);
        AddIo { a: acc, b: *b, out }.bind(ctx.pass(&local, "compose.add", Stage::Compose)).finish();
        acc = out;
    }
    acc
}

/// The component radiances wired into a factoring node's ports (`direct`, `indirect`,
/// `environment`), or the refusal of a factoring node with none.
pub fn components(ctx: &ExpandCtx<'_>) -> Result<Vec<BufferId>, GraphError> {
    let components: Vec<BufferId> =
        crate::light_terms::COMPONENT_PORTS.into_iter().filter_map(|p| ctx.input(p)).collect();
    if components.is_empty() {
        return Err(GraphError::Expand { node: ctx.node().into(), message: crate::light_terms::NO_COMPONENT.into() });
    }
    Ok(components)
}

/// A factoring node that does not factor (Defocus through a pinhole, Motion on a static scene):
/// the components rendered as without it, summed into its `radiance` and `unfiltered`, with a zero
/// `filter_width` and one ray per pixel for its heatmaps.
pub fn pass_through(ctx: &mut ExpandCtx<'_>, components: &[BufferId]) {
    let radiance = sum(ctx, "sum", components, None);
    bind_unfiltered(ctx, radiance, ParamValue::Int(1));
}

/// An image no filter touched, bound to the node's `radiance` and `unfiltered`, with a zero
/// `filter_width` and `rays` per pixel for its heatmaps.
pub fn bind_unfiltered(ctx: &mut ExpandCtx<'_>, radiance: BufferId, rays: ParamValue) {
    let width = ctx.buffer("filter_width", Format::F32);
    FillF32Io { out: width }
        .bind(ctx.pass("filter_width", "fill.constant_f32", Stage::Compose))
        .float("value", 0.0)
        .finish();
    let count = ctx.buffer("rays_per_pixel", Format::U32);
    FillU32Io { out: count }
        .bind(ctx.pass("rays_per_pixel", FILL_CONSTANT, Stage::Compose))
        .param("value", rays)
        .finish();
    for (port, id) in
        [("radiance", radiance), ("unfiltered", radiance), ("filter_width", width), ("rays_per_pixel", count)]
    {
        ctx.output(port, id);
    }
}

/// What the shared sampler's camera rays see directly (emitters; the map where they miss), summed
/// with a factoring node's components where its `radiance` declares that term
/// ([`crate::light_terms::factoring_sum`]): not where every component is ambient occlusion, which is
/// not light. The expansion follows the declaration, so `wedge graph`'s terms are what renders.
pub fn seen_directly(ctx: &mut ExpandCtx<'_>, pass: SamplerPass) -> Result<Option<BufferId>, GraphError> {
    if ctx.output_terms("radiance").is_some_and(|t| !t.holds(TermKind::Emission)) {
        return Ok(None);
    }
    ctx.sampler_output(pass, "emission").map(Some)
}
