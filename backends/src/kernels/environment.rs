//! Environment lighting as the path sampler and the indirect paths see it (thesis Ch. 6, Sec. 6.5.2;
//! the map itself is `wedge_scene::EnvironmentMap`): look-ups into the map's table of 4096
//! precomputed samples, and next-event estimation of the environment at an indirect path's vertex.
//! WGSL mirror: `shaders/environment_light.wgsl`.
//!
//! **Which entries a pixel looks up.** The table is stored in Sobol' order, so every aligned run of
//! `2^k` consecutive entries is itself a stratified `(0,k,2)`-net over the map's distribution
//! (`wedge_scene::environment` module doc). Stratified sampling gives a pixel's `q`-th look-up the
//! entry `shift XOR q` (mod 4096), `shift` a per-pixel uniform random entry: for every power-of-2
//! count the pixel's look-ups are one aligned run with its order permuted — a stratified set of
//! directions — and each look-up on its own is a uniform random entry, so `L f cos / pdf` of it is an
//! unbiased estimate of the table's quadrature. (Stratifying the index instead would not stratify
//! directions: each of 16 index strata is a run of 256 entries spread over the whole sphere.)
//! Independent sampling draws each entry uniformly. Beyond 4096 look-ups a pixel repeats the table:
//! the estimate converges to the table's quadrature, whose error against the exact integral
//! `scene/tests/environment.rs` measures.

use glam::Vec3;
use wedge_scene::environment::TABLE_SIZE;
use wedge_scene::{EnvSample, SceneAt};

use crate::kernels::indirect::{PathParams, Vertex};
use crate::rng::{dim, PixelRng};

crate::param_choice! {
    /// How the path sampler estimates the environment's light at a glossy receiver: the map's table
    /// alone (`table`, thesis Sec. 6.5.2: directions importance-sampled by the map's luminance), or
    /// each look-up paired with a direction drawn from the receiver's glossy lobe and the two
    /// combined by multiple importance sampling with the balance heuristic (`mis`). WGSL:
    /// `params.environment_mis`, 1 = `mis`.
    pub enum GlossySampling { Table = "table", Mis = "mis" }
}

/// Entry `(shift XOR q) mod 4096`: a pixel's `q`-th stratified look-up (module doc).
#[inline]
pub fn stratified_entry(shift: u32, q: u32) -> u32 {
    (shift ^ q) & (TABLE_SIZE as u32 - 1)
}

/// The entry a uniform number `u ∈ [0, 1)` picks: `floor(u · 4096)` (exact in f32: a power of two).
#[inline]
pub fn uniform_entry(u: f32) -> u32 {
    ((u * TABLE_SIZE as f32) as u32).min(TABLE_SIZE as u32 - 1)
}

/// Next-event estimation of the environment at path vertex `v`: one table look-up drawn with
/// dimension `dim::ENVIRONMENT` of the bounce, a shadow ray to infinity, `L f cos / pdf`. Zero
/// without a map. `shadow_rays` counts the ray.
#[inline]
pub fn environment_event(
    scene: &SceneAt<'_>,
    p: &PathParams,
    v: &Vertex,
    rng: &PixelRng,
    sample: u32,
    bounce: u32,
    shadow_rays: &mut u64,
) -> Vec3 {
    let Some(env) = scene.scene().environment.as_ref() else {
        return Vec3::ZERO;
    };
    let e: EnvSample =
        env.table(uniform_entry(rng.uniform(sample, dim::ENVIRONMENT + bounce * dim::BOUNCE_STRIDE)) as usize);
    let cos = v.n.dot(e.dir);
    if !(cos > 0.0 && e.pdf > 0.0) {
        return Vec3::ZERO;
    }
    *shadow_rays += 1;
    if scene.occluded(v.x + v.n * p.eps, e.dir, 0.0, f32::INFINITY) {
        return Vec3::ZERO;
    }
    e.radiance * v.brdf(p.lobe, e.dir) * (cos / e.pdf)
}
