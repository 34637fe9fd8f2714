//! Thin-lens / pinhole camera.
//!
//! [`Camera::ray`] is the one camera model both backends trace (`shaders/camera.wgsl` mirrors it
//! operation for operation): a point on the image plane in pixels and a lens sample in [0,1)² give
//! a ray from a point on the aperture through the point of the focal plane (perpendicular to the
//! view direction at `focus_distance`) that the pinhole ray through the same image point meets. The
//! aperture is a disk of radius `aperture_radius` (world units); `aperture_radius = 0` is a pinhole.
//! [`LensShape`] chooses how the lens is weighted (see there), and [`Camera::coc_pixels`] gives the
//! circle of confusion of a depth in pixels (thesis eq. 5.2).

use glam::{Vec2, Vec3};

/// A look-at camera. `aperture_radius == 0` is a pinhole. `focus_distance` is measured along the view
/// direction (the focal plane is perpendicular to `look_at - position`); a value `<= 0` means
/// "focus on `look_at`".
///
/// `shutter_open` ≤ `shutter_close` is the exposure interval in the scene's time unit (seconds, or
/// the glTF animations' unit): glTF animations are sampled at these two times, which become the
/// shutter's `t = −1` and `t = +1` (see [`crate::motion`]). Default 0, 0: an instant, nothing in a
/// file's animations moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    pub vfov_deg: f32,
    pub aperture_radius: f32,
    pub focus_distance: f32,
    pub shutter_open: f32,
    pub shutter_close: f32,
}

/// [`Camera::ray`] for one image size with its per-ray constants computed once ([`Camera::rays`]):
/// the same operations on the same values, so the same rays bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct CameraRays {
    position: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    w: f32,
    h: f32,
    tan_half: f32,
    aperture_radius: f32,
    focus: f32,
}

impl CameraRays {
    /// See [`Camera::ray`].
    pub fn ray(&self, pixel: Vec2, lens_sample: Vec2, shape: LensShape) -> LensRay {
        let CameraRays { position, right, up, forward, w, h, tan_half, aperture_radius, focus } = *self;
        let sx = (2.0 * pixel.x / w - 1.0) * tan_half * (w / h);
        let sy = (1.0 - 2.0 * pixel.y / h) * tan_half;
        let dir = (forward + sx * right + sy * up).normalize();
        if aperture_radius <= 0.0 {
            return LensRay { origin: position, dir, weight: 1.0, lens: Vec2::ZERO };
        }
        // Thin lens: every ray through this pixel meets the pinhole ray on the focal plane.
        let focus = position + dir * (focus / dir.dot(forward));
        let u = concentric_disk(lens_sample);
        let d = u * aperture_radius;
        let origin = position + d.x * right + d.y * up;
        LensRay { origin, dir: (focus - origin).normalize(), weight: shape.weight(u), lens: u }
    }
}

impl Default for Camera {
    fn default() -> Self {
        Camera {
            position: Vec3::new(0.0, 1.0, 4.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 45.0,
            aperture_radius: 0.0,
            focus_distance: 0.0,
            shutter_open: 0.0,
            shutter_close: 0.0,
        }
    }
}

impl Camera {
    /// What [`Camera::validate`] requires, phrased as the fix for a message.
    pub const VALID_RULES: &'static str = "use finite numbers, 0 < vfov_deg < 180, look_at different from \
        position, an up vector that is not zero or parallel to look_at - position, aperture_radius >= 0 \
        and shutter_open <= shutter_close";

    /// Smallest sine of the angle between `up` and the view direction accepted by [`Camera::validate`]
    /// (about 0.06°); below it the image's roll is decided by rounding.
    pub const MIN_UP_VIEW_SINE: f32 = 1e-3;

    /// The one place that decides whether a camera can produce an image (scene files and the pipeline's
    /// camera use it): every field finite; 0 < `vfov_deg` < 180; `look_at - position` normalisable
    /// (not zero, not overflowing); `up` non-zero and at least [`Camera::MIN_UP_VIEW_SINE`] away from
    /// parallel to the view direction; `aperture_radius >= 0` (`focus_distance` <= 0 means "focus on
    /// look_at", so any finite value is fine); `shutter_open <= shutter_close`. Returns what is wrong,
    /// without the file name.
    pub fn validate(&self) -> Result<(), String> {
        let vectors = [("position", self.position), ("look_at", self.look_at), ("up", self.up)];
        for (name, v) in vectors {
            if !v.is_finite() {
                return Err(format!("{name} {v} is not finite"));
            }
        }
        let scalars = [
            ("vfov_deg", self.vfov_deg),
            ("aperture_radius", self.aperture_radius),
            ("focus_distance", self.focus_distance),
            ("shutter_open", self.shutter_open),
            ("shutter_close", self.shutter_close),
        ];
        for (name, x) in scalars {
            if !x.is_finite() {
                return Err(format!("{name} {x} is not finite"));
            }
        }
        if !(self.vfov_deg > 0.0 && self.vfov_deg < 180.0) {
            return Err(format!("vfov_deg {} is outside 0 < vfov_deg < 180", self.vfov_deg));
        }
        let Some(forward) = (self.look_at - self.position).try_normalize() else {
            return Err(format!(
                "look_at {} and position {} give no view direction (equal, or too far apart for f32)",
                self.look_at, self.position
            ));
        };
        let Some(up) = self.up.try_normalize() else {
            return Err(format!("up {} has no direction", self.up));
        };
        if forward.cross(up).length() < Self::MIN_UP_VIEW_SINE {
            return Err(format!("up {} is parallel to the view direction {forward}", self.up));
        }
        if self.aperture_radius < 0.0 {
            return Err(format!("aperture_radius {} is negative", self.aperture_radius));
        }
        if self.shutter_open > self.shutter_close {
            return Err(format!("shutter_open {} is after shutter_close {}", self.shutter_open, self.shutter_close));
        }
        Ok(())
    }

    /// Orthonormal camera frame (right, up, forward). Falls back to another up vector when `up` is
    /// parallel to the view direction so the frame is never NaN.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let forward = (self.look_at - self.position).try_normalize().unwrap_or(Vec3::NEG_Z);
        let mut right = forward.cross(self.up).try_normalize();
        if right.is_none() {
            let alt = if forward.y.abs() < 0.9 { Vec3::Y } else { Vec3::Z };
            right = forward.cross(alt).try_normalize();
        }
        let right = right.unwrap_or(Vec3::X);
        let up = right.cross(forward);
        (right, up, forward)
    }

    /// The distance to the focal plane actually used (see the struct doc).
    pub fn effective_focus_distance(&self) -> f32 {
        if self.focus_distance > 0.0 {
            self.focus_distance
        } else {
            (self.look_at - self.position).length().max(1e-4)
        }
    }

    /// Primary ray through image coordinates (px, py) in pixels, (0,0) the top-left corner, y down;
    /// the centre of pixel (x,y) is (x+0.5, y+0.5). `lens` in [0,1)^2 is mapped to the aperture disk with
    /// Shirley's concentric mapping (ignored for a pinhole). Returns (origin, unit direction).
    pub fn generate_ray(&self, px: f32, py: f32, width: u32, height: u32, lens: Vec2) -> (Vec3, Vec3) {
        let r = self.ray(Vec2::new(px, py), lens, width, height, LensShape::Disk);
        (r.origin, r.dir)
    }

    /// The thin-lens ray of image point `pixel` (pixels, as [`Camera::generate_ray`]) and lens sample
    /// `lens_sample` in [0,1)²: the sample goes to the unit disk by the concentric mapping (low
    /// distortion, so stratified lens samples stay stratified), scaled by `aperture_radius`; the ray
    /// aims at the focal-plane point of the pinhole ray. A pinhole (`aperture_radius <= 0`) ignores
    /// the lens sample. See [`LensShape`] for the weight.
    pub fn ray(&self, pixel: Vec2, lens_sample: Vec2, width: u32, height: u32, shape: LensShape) -> LensRay {
        self.rays(width, height).ray(pixel, lens_sample, shape)
    }

    /// The constants of [`Camera::ray`] for a `width`×`height` image (basis, field of view, focal
    /// distance), computed once for the many rays of a pass instead of per ray.
    pub fn rays(&self, width: u32, height: u32) -> CameraRays {
        let (right, up, forward) = self.basis();
        CameraRays {
            position: self.position,
            right,
            up,
            forward,
            w: width.max(1) as f32,
            h: height.max(1) as f32,
            tan_half: (self.vfov_deg.to_radians() * 0.5).tan(),
            aperture_radius: self.aperture_radius,
            focus: self.effective_focus_distance(),
        }
    }

    /// Circle of confusion, in pixels, of a point at `depth` along the optical axis (thesis eq. 5.2,
    /// `r = (aW/S)(f/z − 1)` with `a` the aperture radius, `f` the focus distance, `W` the half
    /// image in pixels and `S` the half focal plane in metres: `aW/S = a·h/(2 f tan(fov/2))` with
    /// the vertical field of view). Signed: positive in front of the focal plane, negative behind;
    /// 0 for a pinhole. Callers keep `|r|` for `r_min`/`r_max`.
    pub fn coc_pixels(&self, depth: f32, height: u32) -> f32 {
        if self.aperture_radius <= 0.0 {
            return 0.0;
        }
        let tan_half = (self.vfov_deg.to_radians() * 0.5).tan();
        let f = self.effective_focus_distance();
        let scale = self.aperture_radius * height.max(1) as f32 / (2.0 * f * tan_half);
        scale * (f / depth - 1.0)
    }

    /// A camera that frames an axis-aligned box from the front (+z) and slightly above.
    pub fn framing(min: Vec3, max: Vec3) -> Camera {
        let centre = (min + max) * 0.5;
        let radius = ((max - min).length() * 0.5).max(1e-3);
        let vfov_deg: f32 = 45.0;
        let dist = radius / (vfov_deg.to_radians() * 0.5).sin() * 1.05;
        let position = centre + Vec3::new(0.0, 0.35, 1.0).normalize() * dist;
        Camera {
            position,
            look_at: centre,
            up: Vec3::Y,
            vfov_deg,
            aperture_radius: 0.0,
            focus_distance: dist,
            shutter_open: 0.0,
            shutter_close: 0.0,
        }
    }
}

/// How the aperture weights its points. Both draw lens points uniformly on the disk (stratified
/// samples stay stratified through the concentric mapping); they differ in the weight the ray
/// carries, which estimators apply as an explicit weight (`Σ w·L / Σ w`), as the thesis does
/// ("we apply explicit Gaussian weights to lens and light samples", Sec. 5.8, instead of
/// importance sampling, which gives noisier rate estimates).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LensShape {
    /// Uniform disk, weight 1 (pbrt's and Mitsuba's thin lens; the default).
    #[default]
    Disk,
    /// The thesis's Gaussian aperture: weight `exp(−|u|²/2)` for `u` on the unit disk (σ = 1 in lens
    /// units, Sec. 5.3: "a Gaussian with a 2σ width over u ∈ [−1,1], so σ = 1"), truncated at the rim.
    Gaussian,
}

impl LensShape {
    /// `"disk"` or `"gaussian"`.
    pub fn parse(s: &str) -> Option<LensShape> {
        match s {
            "disk" => Some(LensShape::Disk),
            "gaussian" => Some(LensShape::Gaussian),
            _ => None,
        }
    }
    /// Weight of unit-disk lens point `u`.
    pub fn weight(self, u: Vec2) -> f32 {
        match self {
            LensShape::Disk => 1.0,
            LensShape::Gaussian => (-0.5 * u.length_squared()).exp(),
        }
    }
}

/// A camera ray with its lens weight and its point on the unit lens disk (`u`, before scaling by
/// the aperture radius; zero for a pinhole).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LensRay {
    pub origin: Vec3,
    pub dir: Vec3,
    pub weight: f32,
    pub lens: Vec2,
}

/// Shirley–Chiu concentric square-to-disk mapping (low distortion, so stratified lens samples stay stratified).
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y))
    };
    Vec2::new(theta.cos(), theta.sin()) * r
}
