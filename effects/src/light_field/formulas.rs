//! Pure formulas of the light-field reconstruction: a sample's angular bandwidth `κ` (eq. 2,
//! Sec. 2.5), the ambient-occlusion test, and how eq. 3 shares a pixel's reconstruction rays among
//! its primary hits. WGSL mirrors: `shaders/light_field_common.wgsl` (`kappa`, `ao_occluded`) and
//! `shaders/light_field_reconstruct.wgsl` (the ray share).

use glam::Vec3;
use wedge_backends::kernels::hemisphere::Lobe;

use super::records::LightPrimary;

/// `κ` of a surface hit by an input ray (see the module doc): `4 √e_Blinn` where it has a glossy
/// lobe, else 0.
#[inline]
pub fn kappa(ks: Vec3, m: f32, lobe: Lobe) -> f32 {
    if m > 0.0 && ks.max_element() > 0.0 {
        let blinn = if lobe == Lobe::BlinnPhong { m } else { 4.0 * m };
        4.0 * blinn.sqrt()
    } else {
        0.0
    }
}

/// Whether an AO ray that reached a surface at `t` counts as occluded.
#[inline]
pub fn ao_occluded(t: f32, max_distance: f32) -> bool {
    max_distance <= 0.0 || t <= max_distance
}

/// An AO reconstruction ray's value: 1 where what it sees at distance `t` occludes, else 0.
pub fn occlusion(t: Option<f32>, max_distance: f32) -> Vec3 {
    Vec3::splat(t.is_some_and(|t| ao_occluded(t, max_distance)) as u32 as f32)
}

/// How a pixel's `rays` reconstruction rays are shared among its `P` primary hits (eq. 3 per hit,
/// the pixel the lens-weighted mean over hits): ray `r` goes to hit `r mod P` as its `r / P`-th, so
/// hit `j` takes `⌊N/P⌋ + [j < N mod P]` rays; a ray's value is weighted `w_j / n_j` and the pixel
/// divided by `Σ w_j` over the hits that have rays. Mirrored in `light_field_reconstruct.wgsl`.
pub struct RayShare<'a> {
    hits: &'a [LightPrimary],
    rays: u32,
}

impl<'a> RayShare<'a> {
    pub fn new(hits: &'a [LightPrimary], rays: u32) -> Self {
        RayShare { hits, rays }
    }
    fn count(&self) -> u32 {
        self.hits.len().max(1) as u32
    }
    /// Ray `r`'s hit and its index among that hit's rays.
    #[inline]
    pub fn ray(&self, r: u32) -> (u32, u32) {
        (r % self.count(), r / self.count())
    }
    /// Rays of hit `j`.
    #[inline]
    pub fn rays_of(&self, j: u32) -> u32 {
        self.rays / self.count() + u32::from(j < self.rays % self.count())
    }
    /// The weight of one of hit `j`'s rays, `w_j / n_j`.
    #[inline]
    pub fn scale(&self, j: u32) -> f32 {
        self.hits[j as usize].weight / self.rays_of(j).max(1) as f32
    }
    /// `Σ w_j` over the hits that have rays (1 where that is 0, so an empty pixel is 0).
    pub fn total_weight(&self) -> f32 {
        let w: f32 =
            (0..self.hits.len() as u32).filter(|&j| self.rays_of(j) > 0).map(|j| self.hits[j as usize].weight).sum();
        if w > 0.0 {
            w
        } else {
            1.0
        }
    }
}
