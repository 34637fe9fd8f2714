//! The separable world-space Gaussian as effects use it: one helper that declares the filter's
//! parameters and expands into the `filter_x` → `filter_y` pass pair (shared kernel
//! `filter.gaussian`, thesis Sec. 3.6 / 4.5), so every effect filters the same way.

use wedge_backends::kernels::gaussian_filter::{FilterReach, GaussianIo};
use wedge_graph::{BufferId, ExpandCtx, Format, ParamDecl, ParamValue, Reference, Stage};

/// The parameters every filtering node declares (window cap, normal test, and the reach rule:
/// `mutual`, the default, weighs a neighbour with a narrower filter by its own width
/// (`backends::kernels::gaussian_filter::FilterParams::mutual`); `own` is the thesis's, each pixel's β alone —
/// measured over the scene suite in docs/DESIGN-NOTES.md "SoftShadows after the suite").
pub fn params() -> [ParamDecl; 3] {
    [
        ParamDecl::int("max_radius", 64, 0, 1024, "cap on the filter half-width in pixels"),
        ParamDecl::float("normal_angle_deg", 10.0, 0.0, 180.0, "neighbours whose normals differ by more are not used"),
        ParamDecl::choice(
            "reach",
            "mutual",
            FilterReach::OPTIONS,
            "weigh neighbours by this pixel's filter width (thesis), or by the narrower of its and theirs",
        ),
    ]
}

/// What the filter reads besides the value: G-buffer, per-pixel bandwidth, and the light whose
/// plane distances are measured in (eq. 3.12), or `None` for the full 3-D distance (Ch. 4).
pub struct Separable {
    pub position: BufferId,
    pub normal: BufferId,
    pub bandwidth: BufferId,
    pub plane_light: Option<ParamValue>,
}

/// Filter `value` along x then y; passes are named `<prefix>filter_x`/`<prefix>filter_y`.
/// Returns the filtered buffer.
pub fn separable(ctx: &mut ExpandCtx<'_>, prefix: &str, value: BufferId, f: &Separable) -> BufferId {
    let max_radius = ctx.param("max_radius").clone();
    let normal_cos = match ctx.param("normal_angle_deg") {
        ParamValue::Float(a) => a.to_radians().cos(),
        _ => 10f64.to_radians().cos(),
    };
    let plane_light = f.plane_light.clone().unwrap_or(ParamValue::Int(-1));
    let reach = ctx.param("reach").clone();
    let mut v = value;
    for (axis, name) in [(0, "filter_x"), (1, "filter_y")] {
        let local = format!("{prefix}{name}");
        let out = ctx.buffer(&local, Format::Vec4);
        let io = GaussianIo { value: v, position: f.position, normal: f.normal, bandwidth: f.bandwidth, out };
        io.bind(ctx.pass(&local, "filter.gaussian", Stage::Filter))
            .int("axis", axis)
            .param("plane_light", plane_light.clone())
            .param("max_radius", max_radius.clone())
            .float("normal_cos", normal_cos)
            .param("reach", reach.clone())
            .reference(Reference::Bypass { input: "value" })
            .finish();
        v = out;
    }
    v
}
