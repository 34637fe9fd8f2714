//! A lighting component rendered as plain Monte Carlo through the pipeline's `camera:` block, where
//! that block samples a lens (an aperture) or a shutter (open over an interval, on a moving scene)
//! and no factoring node filters them ([`wedge_graph::ExpandCtx::plain_camera`]).
//!
//! Why: Defocus and Motion are the *filters* of the lens and shutter dimensions, not the only way to
//! have them (docs/ARCHITECTURE.md "The camera"). A component node's own filter (Ch. 3's shadows,
//! Ch. 4's indirect light, Ch. 6's environment light) is derived for one pinhole ray per pixel: it
//! filters irradiance and multiplies the texture of that one ray back in, which through a lens
//! would put a sharp texture over lens-averaged light. So the node does not filter: its image is
//! the mean over `camera_paths` jittered paths per pixel, each through its own lens point and
//! shutter time, of the component's `L` (the shared sampler's per-part radiance, `paths.resolve`),
//! plus what the camera rays see directly where the node adds it — the image a path tracer with
//! that camera renders. Wiring the component through a Defocus or Motion node filters it.

use wedge_graph::factoring::CameraSettings;
use wedge_graph::{ExpandCtx, GraphError, ParamDecl, ParamValue, Part, SamplerPass, SamplerRequest};

/// The parameter every component node declares for it (one declaration: [`paths_param`]).
pub const PATHS: &str = "camera_paths";

/// `camera_paths`: paths per pixel through the camera block's lens or shutter where no factoring
/// node filters them.
pub const fn paths_param() -> ParamDecl {
    ParamDecl::int(
        PATHS,
        16,
        1,
        4096,
        "paths per pixel where the `camera:` block has an aperture or an open shutter and no Defocus/Motion node filters them: \
         the node renders the plain Monte Carlo image through that camera, unfiltered (its filter assumes a pinhole)",
    )
}

/// What a component node samples: the sampler's estimator and settings, the parts whose `L` it
/// sums, and whether its image adds what the camera rays see directly (emitters, the map where
/// they miss).
pub struct PlainComponent<'p> {
    pub estimator: &'static str,
    pub settings: Vec<(&'static str, ParamValue)>,
    pub parts: &'p [Part],
    pub emission: bool,
}

/// The passes: the sampler's paths through the camera, the sum of the parts' `L` (and emission),
/// bound to the node's `radiance` and `unfiltered`, with a zero `filter_width` and `camera_paths`
/// as `rays_per_pixel` (its heatmaps).
pub fn expand(ctx: &mut ExpandCtx<'_>, c: &PlainComponent<'_>) -> Result<(), GraphError> {
    let camera = ctx.own_camera();
    let paths = ctx.param(PATHS).clone();
    let mut request = SamplerRequest::new()
        .estimator(c.estimator)
        .setting("paths", paths.clone())
        .setting("jitter", ParamValue::Bool(true))
        .setting("sampling", ParamValue::Str("stratified".into()));
    for (n, v) in camera.lens.iter().chain(&c.settings) {
        request = request.setting(n, v.clone());
    }
    if camera.time {
        request = request.estimator(CameraSettings::TIME);
    }
    ctx.sampler(request)?;
    let mut terms = Vec::with_capacity(c.parts.len());
    for part in c.parts {
        terms.push(ctx.sampler_output(SamplerPass::Final, part.radiance)?);
    }
    let emission = if c.emission { Some(ctx.sampler_output(SamplerPass::Final, "emission")?) } else { None };
    let radiance = crate::factored::sum(ctx, "sum", &terms, emission);
    crate::factored::bind_unfiltered(ctx, radiance, paths);
    Ok(())
}
