//! The light field's records (GPU buffers of `Format::Struct`, mirrored field for field in
//! `shaders/light_field_common.wgsl`): the stored input samples, the splats, the splat tree's nodes
//! and the primary hits the reconstruction reads.

use glam::Vec3;
use wedge_backends::record;

/// `flags` of a [`LightSample`]: no sample (the camera ray left the scene, or past `count`).
pub const SAMPLE_NONE: u32 = 0;
/// A secondary ray that hit a surface: a splat.
pub const SAMPLE_HIT: u32 = 1;
/// A secondary ray that left the scene: no splat, but shrinking retraces it to infinity.
pub const SAMPLE_ESCAPED: u32 = 2;

record! {
    /// One stored input sample (24 words; Sec. 2.1's tuple without the origin's motion vector, see
    /// the module doc): `origin` is where the ray started (the primary hit, offset along its
    /// normal), `distance` the ray parameter of `hit` (unit `direction`), `time` the path's shutter
    /// time in [−1, 1] (0 without motion), `velocity` the hit's world velocity per unit time, `lens`
    /// the camera ray's point on the unit lens disk (0 for a pinhole).
    pub struct LightSample / LIGHT_SAMPLE {
        origin: vec3,
        flags: u32,
        hit: vec3,
        distance: f32,
        normal: vec3,
        kappa: f32,
        direction: vec3,
        time: f32,
        radiance: vec3,
        velocity: vec3,
        lens: vec2,
    }
}

record! {
    /// One splat (20 words): a disk of `radius` at `centre` (a hit point, where it is at `time`) on
    /// the plane of `normal`, moving with `velocity` (world units per unit time), with its sample's
    /// `κ`, direction and radiance; `sample` = its input sample's index (`pixel·spp + s`), `flags` = 1
    /// for a splat, 0 for an unused slot.
    pub struct Splat / SPLAT {
        centre: vec3,
        radius: f32,
        normal: vec3,
        kappa: f32,
        direction: vec3,
        sample: u32,
        radiance: vec3,
        flags: u32,
        velocity: vec3,
        time: f32,
    }
}

impl Splat {
    /// Where the splat's centre is at time `t`: `h + v_h (t − t_i)` (exactly `h` for a still one).
    #[inline]
    pub fn centre_at(&self, t: f32) -> Vec3 {
        Vec3::from(self.centre) + Vec3::from(self.velocity) * (t - self.time)
    }
}

record! {
    /// One node of the splat BVH2 (8 words, obvhs's `Bvh2Node` layout): `count == 0` = inner node
    /// with children at `index` and `index + 1`; else a leaf of splats `index..index + count`. Node 0
    /// is the root. The boxes bound the splats over the whole shutter.
    pub struct SplatNode / SPLAT_NODE {
        min: vec3,
        count: u32,
        max: vec3,
        index: u32,
    }
}

record! {
    /// A primary hit as the reconstruction reads it (19 words; `valid` = 0: the camera ray left the
    /// scene): the point, its shading normal, `k_d`, `k_s`, Phong exponent `m`, the camera ray's
    /// origin `eye` (the lens point), its shutter `time` and lens `weight`.
    pub struct LightPrimary / LIGHT_PRIMARY {
        position: vec3,
        valid: u32,
        normal: vec3,
        m: f32,
        kd: vec3,
        time: f32,
        ks: vec3,
        weight: f32,
        eye: vec3,
    }
}
