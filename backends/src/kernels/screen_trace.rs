//! Screen-space ray tracing against the real layer (thesis Sec. 6.5, "screen-space rays to
//! intersect only real geometry"; `wedge_scene::RealLayer`): a ray is marched over the camera image's
//! pixels, and the real surface a pixel shows is hit where the ray passes behind it. WGSL mirror:
//! `shaders/screen_trace.wgsl`, term by term in the same order.
//!
//! **The rule** (the thesis adapts a hierarchical traversal it does not specify; wedge marches one
//! pixel at a time, which is exact to the pixel and simple to mirror):
//! - The ray `o + t d` is projected by the real layer's (pinhole) camera at both ends of the part in
//!   front of the near plane (`t_end`: where it reaches the near plane, else `FAR`), and that 2-D segment is clipped
//!   to the image. Depth along the optical axis is interpolated perspective-correctly (`1/z` is linear
//!   in screen space), so every step knows the ray's exact point.
//! - Steps of one pixel along the segment's longer axis, starting one step from the origin; at most
//!   `max_steps`.
//! - At each step the pixel's real surface (if the pixel is covered) is taken as its tangent plane
//!   (the pixel's position and normal), intersected with the line of sight of the step's exact screen
//!   point: the surface depth `z_s` there, free of the half-pixel depth error of a flat per-pixel depth.
//! - **Hit** where the ray is behind the surface, `z_ray ≥ z_s`, by at most the surface's assumed
//!   thickness: `max(thickness · z_s, |z_ray − z_prev|)` — a relative thickness (a fraction of the
//!   depth, default 0.05), and never less than the ray's own depth change over the step, so a ray that
//!   moves steeply in depth cannot step over a surface between two pixels.
//! - **Left the screen** where the clipped segment ends at the image border with no hit (counted: real
//!   geometry off screen is invisible to these rays, the method's stated limitation); **miss** where it
//!   ends inside the image (the near plane or `FAR`), or after `max_steps`.

use glam::{Vec2, Vec3};
use wedge_scene::{Camera, RealLayer};

/// Distance to the near plane along the optical axis (metres).
pub const NEAR: f32 = 1e-3;
/// Where a ray that moves away from the camera ends (metres).
pub const FAR: f32 = 1e5;

/// What a screen-space ray found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScreenHit {
    /// The real surface of pixel `(x, y)` at distance `t` along the ray.
    Hit { t: f32, x: u32, y: u32 },
    /// Ended inside the image (or after the step budget) without a hit.
    Miss,
    /// Left the image without a hit.
    Offscreen,
}

/// A pinhole view of the real layer and the march's settings.
#[derive(Clone, Copy, Debug)]
pub struct ScreenTracer<'a> {
    pub layer: &'a RealLayer,
    pub position: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    pub tan_half: f32,
    pub thickness: f32,
    pub max_steps: u32,
}

impl<'a> ScreenTracer<'a> {
    pub fn new(layer: &'a RealLayer, camera: &Camera, thickness: f32, max_steps: u32) -> ScreenTracer<'a> {
        let (right, up, forward) = camera.basis();
        let tan_half = (camera.vfov_deg.to_radians() * 0.5).tan();
        ScreenTracer { layer, position: camera.position, right, up, forward, tan_half, thickness, max_steps }
    }

    /// Continuous pixel coordinates of a point at view depth `z > 0` (the inverse of the pinhole ray).
    #[inline]
    fn project(&self, p: Vec3, z: f32) -> Vec2 {
        let (w, h) = (self.layer.width() as f32, self.layer.height() as f32);
        let d = p - self.position;
        let sx = d.dot(self.right) / z;
        let sy = d.dot(self.up) / z;
        Vec2::new((sx / (self.tan_half * (w / h)) + 1.0) * 0.5 * w, (1.0 - sy / self.tan_half) * 0.5 * h)
    }

    /// The (unnormalised) line-of-sight direction through continuous pixel point `s`.
    #[inline]
    fn sight(&self, s: Vec2) -> Vec3 {
        let (w, h) = (self.layer.width() as f32, self.layer.height() as f32);
        let sx = (2.0 * s.x / w - 1.0) * self.tan_half * (w / h);
        let sy = (1.0 - 2.0 * s.y / h) * self.tan_half;
        self.forward + sx * self.right + sy * self.up
    }

    /// The view depth of pixel `(x, y)`'s real surface (its tangent plane) along the sight line
    /// through `s`; `None` where the pixel shows no real surface.
    #[inline]
    fn surface_depth(&self, x: u32, y: u32, s: Vec2) -> Option<f32> {
        let p = self.layer.position(x, y)?;
        let n = self.layer.normal(x, y);
        let v = self.sight(s);
        let vn = v.dot(n);
        let zp = (p - self.position).dot(self.forward);
        // Grazing sight lines: the pixel's own depth (the plane gives no stable answer).
        if vn.abs() < 1e-4 {
            return Some(zp);
        }
        // The sight line `c + λ v` meets the plane at λ = ((p − c)·n)/(v·n); `v·forward` = 1, so λ is
        // the depth.
        let lambda = (p - self.position).dot(n) / vn;
        Some(if lambda > 0.0 { lambda } else { zp })
    }

    /// March the ray `o + t d` (`d` unit) over the real layer (module doc).
    pub fn trace(&self, o: Vec3, d: Vec3) -> ScreenHit {
        let (w, h) = (self.layer.width() as f32, self.layer.height() as f32);
        let z0 = (o - self.position).dot(self.forward);
        if !(z0 > NEAR) {
            // Behind the camera: the image never saw where it starts.
            return ScreenHit::Offscreen;
        }
        let dz = d.dot(self.forward);
        let t_end = if dz < 0.0 { ((z0 - NEAR) / -dz).min(FAR) } else { FAR };
        let e = o + d * t_end;
        let z1 = (z0 + dz * t_end).max(NEAR);
        let (s0, s1) = (self.project(o, z0), self.project(e, z1));
        let (k0, k1) = (1.0 / z0, 1.0 / z1);
        // Clip the segment s0 → s1 to the image (Liang–Barsky).
        let delta = s1 - s0;
        let (mut u_in, mut u_out) = (0.0f32, 1.0f32);
        for (p, q) in [(-delta.x, s0.x), (delta.x, w - s0.x), (-delta.y, s0.y), (delta.y, h - s0.y)] {
            if p == 0.0 {
                if q < 0.0 {
                    return ScreenHit::Offscreen;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    u_in = u_in.max(r);
                } else {
                    u_out = u_out.min(r);
                }
            }
        }
        if !(u_in < u_out) {
            return ScreenHit::Offscreen;
        }
        let clipped = u_out < 1.0;
        let length = delta.x.abs().max(delta.y.abs());
        if !(length > 0.0) {
            // Along the line of sight through the origin's own pixel: nothing to march over.
            return ScreenHit::Miss;
        }
        let du = 1.0 / length;
        let origin_pixel = (s0.x.floor() as i64, s0.y.floor() as i64);
        let mut z_prev = z0;
        let mut u = u_in.max(du);
        let mut steps = 0u32;
        while u < u_out && steps < self.max_steps {
            steps += 1;
            let s = s0 + delta * u;
            let (px, py) = (s.x.floor() as i64, s.y.floor() as i64);
            // Perspective-correct depth of the ray point that projects to `s`.
            let z_ray = 1.0 / (k0 + (k1 - k0) * u);
            if (px, py) != origin_pixel && px >= 0 && py >= 0 && (px as f32) < w && (py as f32) < h {
                let (x, y) = (px as u32, py as u32);
                if let Some(z_s) = self.surface_depth(x, y, s) {
                    let allowed = (self.thickness * z_s).max((z_ray - z_prev).abs());
                    if z_ray >= z_s && z_ray - z_s <= allowed {
                        // The ray's point: homogeneous interpolation of the end points.
                        let a = k0 * (1.0 - u);
                        let b = k1 * u;
                        let p = (o * a + e * b) / (a + b);
                        return ScreenHit::Hit { t: (p - o).length(), x, y };
                    }
                }
            }
            z_prev = z_ray;
            u += du;
        }
        if clipped && u >= u_out {
            ScreenHit::Offscreen
        } else {
            ScreenHit::Miss
        }
    }
}
