//! Camera moves of the viewer: orbit around the look-at point and dolly towards it. The moved
//! camera replaces the session's (`Session::scene.camera`) for the frames rendered after it.

use glam::{Quat, Vec3};
use wedge_scene::Camera;

/// Closest the orbit gets to the up axis (radians), so the view never flips over the pole.
const POLE_MARGIN: f32 = 0.02;

/// `cam` turned by `yaw` around its up axis and by `pitch` towards it, at the same distance from
/// its look-at point.
pub fn orbit(cam: &Camera, yaw: f32, pitch: f32) -> Camera {
    let up = cam.up.try_normalize().unwrap_or(Vec3::Y);
    let offset = cam.position - cam.look_at;
    let yawed = Quat::from_axis_angle(up, yaw) * offset;
    // Pitch about the horizontal axis, clamped to stay off the poles.
    let angle_to_up = yawed.angle_between(up);
    let target = (angle_to_up - pitch).clamp(POLE_MARGIN, std::f32::consts::PI - POLE_MARGIN);
    let right = up.cross(yawed).try_normalize();
    let moved = match right {
        Some(axis) => Quat::from_axis_angle(axis, angle_to_up - target) * yawed,
        None => yawed,
    };
    Camera { position: cam.look_at + moved, ..*cam }
}

/// `cam` moved `fraction` of the way to its look-at point (negative: away); `fraction < 1`.
pub fn dolly(cam: &Camera, fraction: f32) -> Camera {
    let offset = (cam.position - cam.look_at) * (1.0 - fraction);
    Camera { position: cam.look_at + offset, ..*cam }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orbit_keeps_the_distance_and_dolly_scales_it() {
        let cam = Camera::default();
        let d = (cam.position - cam.look_at).length();
        let o = orbit(&cam, 0.7, 0.3);
        assert!(((o.position - o.look_at).length() - d).abs() < 1e-4);
        assert!(o.position.distance(cam.position) > 0.1);
        let back = orbit(&o, 0.0, -0.3);
        let back = orbit(&back, -0.7, 0.0);
        assert!(back.position.distance(cam.position) < 1e-3, "{:?} vs {:?}", back.position, cam.position);
        let near = dolly(&cam, 0.5);
        assert!(((near.position - near.look_at).length() - d / 2.0).abs() < 1e-4);
    }

    #[test]
    fn orbit_stops_short_of_the_pole() {
        let cam = Camera::default();
        let o = orbit(&cam, 0.0, 10.0);
        assert!((o.position - o.look_at).normalize().dot(cam.up) < 1.0 - 1e-5);
    }
}
