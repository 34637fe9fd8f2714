//! Camera moves of the viewer: orbit around the look-at point and dolly towards it, or fly (move in
//! the camera's own frame) and look around (turn on the spot). The moved camera replaces the
//! session's (`Session::scene.camera`) for the frames rendered after it.

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

/// The camera's frame: right, up and forward (towards the look-at point), orthonormal.
fn frame(cam: &Camera) -> (Vec3, Vec3, Vec3) {
    let up = cam.up.try_normalize().unwrap_or(Vec3::Y);
    let forward = (cam.look_at - cam.position).try_normalize().unwrap_or(Vec3::NEG_Z);
    let right = forward.cross(up).try_normalize().unwrap_or(Vec3::X);
    (right, right.cross(forward), forward)
}

/// `cam` moved by `d` in its own frame (`d.x` right, `d.y` up, `d.z` forward, in scene units); the
/// look-at point moves with it, so the view direction stays.
pub fn fly(cam: &Camera, d: Vec3) -> Camera {
    let (right, up, forward) = frame(cam);
    let step = right * d.x + up * d.y + forward * d.z;
    Camera { position: cam.position + step, look_at: cam.look_at + step, ..*cam }
}

/// `cam` turned on the spot by `yaw` around its up axis (> 0: to the left) and by `pitch` up: the
/// look-at point orbits the position (as [`orbit`] with the two swapped, whose pitch > 0 lowers the
/// orbiting point), the position stays.
pub fn look(cam: &Camera, yaw: f32, pitch: f32) -> Camera {
    let swapped = Camera { position: cam.look_at, look_at: cam.position, ..*cam };
    Camera { look_at: orbit(&swapped, yaw, -pitch).position, ..*cam }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fly_moves_in_the_camera_frame_and_keeps_the_view_direction() {
        let cam = Camera::default();
        let forward = (cam.look_at - cam.position).normalize();
        let f = fly(&cam, Vec3::new(0.0, 0.0, 2.0));
        assert!((f.position - (cam.position + forward * 2.0)).length() < 1e-4);
        assert!(((f.look_at - f.position) - (cam.look_at - cam.position)).length() < 1e-4);
        // Right is perpendicular to forward and up; up stays perpendicular to forward.
        let r = fly(&cam, Vec3::X);
        assert!((r.position - cam.position).dot(forward).abs() < 1e-5);
        assert!((r.position - cam.position).dot(cam.up).abs() < 1e-5);
        let u = fly(&cam, Vec3::Y);
        assert!((u.position - cam.position).dot(forward).abs() < 1e-5);
        assert!((u.position - cam.position).dot(cam.up) > 0.9);
        let back = fly(&fly(&cam, Vec3::new(0.3, -0.2, 0.5)), Vec3::new(-0.3, 0.2, -0.5));
        assert!(back.position.distance(cam.position) < 1e-4);
    }

    #[test]
    fn look_turns_on_the_spot_and_undoes() {
        let cam = Camera::default();
        let l = look(&cam, 0.4, 0.2);
        assert_eq!(l.position, cam.position);
        assert!(((l.look_at - l.position).length() - (cam.look_at - cam.position).length()).abs() < 1e-4);
        assert!(l.look_at.distance(cam.look_at) > 0.1);
        assert!((l.look_at - cam.look_at).dot(cam.up) > 0.0, "pitch > 0 looks up");
        let (right, _, _) = frame(&cam);
        assert!((look(&cam, 0.3, 0.0).look_at - cam.look_at).dot(right) < 0.0, "yaw > 0 turns left");
        let back = look(&look(&l, 0.0, -0.2), -0.4, 0.0);
        assert!(back.look_at.distance(cam.look_at) < 1e-3, "{:?} vs {:?}", back.look_at, cam.look_at);
    }

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
