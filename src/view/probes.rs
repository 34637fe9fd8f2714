//! Any buffer of the schedule in the output picker (issue 38): the G-buffer (position, normal,
//! albedo), a node's terms, bandwidths, visibility — not only the sinks' images.
//!
//! A backend hands back the sinks' inputs and nothing else (the CPU backend's slots are reused by
//! later buffers, the wgpu backend's buffers stay on the device). So the viewer adds the buffers the
//! user picks as extra sink inputs ("probes") of the session's schedule, rebuilt from the same
//! expansion (`wedge_graph::expand` of the session's validated pipeline), and both backends hand them
//! back as they hand back `Output`'s image: no backend knows about the viewer. A probe keeps its
//! buffer alive to the end of the run (more memory, the same image: random streams are per pass,
//! `wedge_graph::stream_id`), and brings back a culled pass (a debug branch) whose output it is.
//!
//! Shown as `wedge render` would if it wrote them: scalars as heatmaps; vectors as colours, a
//! `normal` mapped from −1..1 to 0..1, a `position` normalised by the scene's bounds, anything
//! else tone-mapped like an image (the port's name says which: declarations carry no meaning).

use wedge_backends::{BufferData, RunResult};
use wedge_graph::{expand, Format};
use wedge_scene::Aabb;

use super::outputs::Picture;
use crate::heatmap::{render_heatmap, HeatmapSpec, Scale};
use crate::{Session, WedgeError};

/// The sink node the probes are handed back under ([`RunResult::outputs`]' node; a node name of a
/// pipeline cannot hold a space, so it clashes with none).
pub const PROBE_SINK: &str = "view probe";

/// The buffers that can be probed, in expansion order: per-pixel (one element per pixel), of a
/// number format, written by a pass (not a previous-frame buffer), not already a sink's input.
pub fn candidates(session: &Session) -> Result<Vec<String>, WedgeError> {
    let e = expand(&session.pipeline)?;
    let written = |id: usize| e.passes.iter().any(|p| p.writes.iter().any(|(_, w)| w.0 == id));
    let sink = |id: usize| e.sink_inputs.iter().any(|(_, _, s)| s.0 == id);
    Ok(e.buffers
        .iter()
        .enumerate()
        .filter(|(id, b)| b.layers == 1 && !matches!(b.format, Format::Struct(_)) && written(*id) && !sink(*id))
        .map(|(_, b)| b.name.clone())
        .collect())
}

/// Reschedule `session` so that a run also hands back the buffers named `probes`.
pub fn set_probes(session: &mut Session, probes: &[String]) -> Result<(), WedgeError> {
    let mut e = expand(&session.pipeline)?;
    for name in probes {
        let id = e.find_buffer(name).ok_or_else(|| {
            WedgeError::Usage(format!("{}: no buffer `{name}` to show", session.pipeline.path.display()))
        })?;
        e.sink_inputs.push((PROBE_SINK.to_string(), name.clone(), id));
    }
    let schedule = wedge_graph::schedule(e)?;
    session.kernels.check_schedule(&schedule)?;
    session.schedule = schedule;
    Ok(())
}

/// Probe `name` of `run` as a picture (`None`: not probed in this run).
pub fn picture(run: &RunResult, name: &str, width: u32, height: u32, bounds: &Aabb) -> Option<Picture> {
    let data = run.outputs.get(&(PROBE_SINK.to_string(), name.to_string()))?;
    let port = name.rsplit('.').next().unwrap_or(name);
    let colour = match data {
        BufferData::F32(_) | BufferData::U32(_) | BufferData::Words { .. } => None,
        _ if port.contains("normal") => Some(Colouring::Normal),
        _ if port.contains("position") => Some(Colouring::Position(*bounds)),
        _ => Some(Colouring::Linear),
    };
    let Some(colouring) = colour else {
        let spec = HeatmapSpec { title: name, unit: "", scale: Scale::Linear, range: None, arrows: None };
        let (width, height, rgb) = render_heatmap(width, height, &data.to_scalar(), None, &spec);
        return Some(Picture { width, height, rgb });
    };
    let pixels = width as usize * height as usize;
    let components = match data {
        BufferData::Vec2(_) => 2,
        _ => 3,
    };
    let rgb = (0..pixels.min(data.len()))
        .flat_map(|i| {
            let v = [0, 1, 2].map(|c| if c < components { data.component(i, c) } else { 0.0 });
            colouring.rgb8(v)
        })
        .collect();
    Some(Picture { width, height, rgb })
}

/// How a vector buffer's first three components become a colour.
#[derive(Clone, Copy, Debug)]
enum Colouring {
    /// −1..1 → 0..1 (a unit normal as the usual normal-map colours).
    Normal,
    /// The scene's bounds → 0..1 per axis.
    Position(Aabb),
    /// As an image's radiance, through the sRGB curve.
    Linear,
}

impl Colouring {
    fn rgb8(self, v: [f32; 3]) -> [u8; 3] {
        // NaN and infinities as the PNG writer shows them.
        if !v.iter().all(|c| c.is_finite()) {
            return crate::image::MAGENTA;
        }
        let unit = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
        match self {
            Colouring::Normal => v.map(|c| unit(c * 0.5 + 0.5)),
            Colouring::Position(b) => {
                let size = b.size().max(glam::Vec3::splat(f32::MIN_POSITIVE));
                [0, 1, 2].map(|a| unit((v[a] - b.min[a]) / size[a]))
            }
            Colouring::Linear => {
                let img = crate::image::Image { width: 1, height: 1, pixels: vec![v] };
                let px = crate::image::to_srgb8(&img, 1.0);
                [px[0], px[1], px[2]]
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_and_positions_map_into_colours() {
        assert_eq!(Colouring::Normal.rgb8([-1.0, 0.0, 1.0]), [0, 128, 255]);
        let b = Aabb { min: glam::Vec3::splat(-2.0), max: glam::Vec3::splat(2.0) };
        assert_eq!(Colouring::Position(b).rgb8([-2.0, 0.0, 2.0]), [0, 128, 255]);
        assert_eq!(Colouring::Position(b).rgb8([9.0, -9.0, f32::NAN]), crate::image::MAGENTA);
        assert_eq!(Colouring::Linear.rgb8([0.0, 1.0, 0.0]), [0, 255, 0]);
    }

    fn tiny() -> Session {
        let ov = crate::Overrides { width: Some(8), height: Some(6), ..Default::default() };
        Session::open(None, &ov).expect("the default pipeline opens")
    }

    #[test]
    fn no_probes_is_the_sessions_schedule_and_a_probe_is_a_sink_of_its_own() {
        let mut session = tiny();
        let passes = |s: &Session| s.schedule.passes.iter().map(|p| p.name.clone()).collect::<Vec<_>>();
        let before = (passes(&session), session.schedule.slots.clone());
        set_probes(&mut session, &[]).expect("reschedules");
        assert_eq!((passes(&session), session.schedule.slots.clone()), before);
        let names = candidates(&session).expect("candidates");
        assert!(names.iter().any(|n| n == "primary.normal"), "{names:?}");
        assert!(!names.iter().any(|n| n.contains("record")), "struct buffers are not shown: {names:?}");
        set_probes(&mut session, &["primary.normal".into()]).expect("probes");
        assert!(session.schedule.sink(PROBE_SINK, "primary.normal").is_some());
        let e = set_probes(&mut session, &["primary.nope".into()]).unwrap_err().to_string();
        assert!(e.contains("primary.nope"), "{e}");
    }
}
