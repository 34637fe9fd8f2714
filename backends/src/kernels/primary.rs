//! `primary.gbuffer`: one primary ray through each pixel centre and the per-pixel surface data every
//! effect reads (thesis Ch. 3–4 shade the point a pixel sees; lens and shutter sampling for Ch. 5 and
//! App. B belong to a multi-sample primary kernel, not this one).

use glam::Vec3;
use rayon::prelude::*;
use wedge_scene::{Hit, LensRay, LensShape};

use crate::bindings::PutWith;
use crate::kernel::{optional_rows, Counters, Kernel, KernelCtx, Uniforms, WgslSource};
use crate::BackendError;

crate::kernel_bindings! {
    /// What a `primary.gbuffer` pass binds: the per-pixel surface data.
    pub struct GBufferIo / GBufferData {
        /// xyz world position; w = 1 + object id where the pixel sees a surface, 0 for background
        /// (exact in f32 up to 2^24 objects). Filters use it to keep to one object (thesis
        /// Sec. 3.6, footnote 7).
        write position: [f32; 4],
        /// xyz unit shading normal facing the camera, w = projected pixel size d (metres).
        write normal: [f32; 4],
        write albedo: [f32; 3],
        write emission: [f32; 3],
        /// Optional: k_s rgb, w = Phong exponent m (0 = no glossy lobe). Read by `Indirect`.
        write_opt specular: [f32; 4],
    }
}

pub struct PrimaryGBuffer;

/// Pixels of a row traced per batch (see `run_cpu`): enough independent rays to overlap one
/// pixel's shading arithmetic with the next's, small enough for the stack.
const BATCH: usize = 32;

/// Per-pixel G-buffer entry.
#[derive(Clone, Copy, Default)]
struct Texel {
    position: [f32; 4],
    normal: [f32; 4],
    albedo: [f32; 3],
    emission: [f32; 3],
    specular: [f32; 4],
}

impl Kernel for PrimaryGBuffer {
    crate::kernel_signature!(name: "primary.gbuffer", class: Sampling, bindings: GBufferIo);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/primary_gbuffer.wgsl"), |ctx| {
                let cam = &ctx.scene.camera;
                let (right, up, forward) = cam.basis();
                let tan_half = (cam.vfov_deg.to_radians() * 0.5).tan();
                let pixel_angle = 2.0 * (cam.vfov_deg.to_radians() * 0.5).tan() / ctx.full_size().1 as f32;
                Ok(Uniforms::new()
                    .vec3("position", cam.position.to_array())
                    .f32("tan_half", tan_half)
                    .vec3("right", right.to_array())
                    .f32("pixel_angle", pixel_angle)
                    .vec3("up", up.to_array())
                    .f32("aperture", cam.aperture_radius)
                    .vec3("forward", forward.to_array())
                    .f32("focus_distance", cam.effective_focus_distance()))
            })
            .with_scene()
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let scene = ctx.scene;
        let cam = &scene.camera;
        // Rays of the full image's pixels (a tile's window is part of it).
        let ((w, h), window) = (ctx.full_size(), ctx.window);
        // Angle subtended by one pixel at the image centre.
        let pixel_angle = 2.0 * (cam.vfov_deg.to_radians() * 0.5).tan() / h as f32;
        // The camera basis once per pass, not per pixel (the same rays as `Camera::generate_ray`).
        let rays = cam.rays(w, h);
        // The camera ray through a pixel centre: (origin, direction).
        let ray = |x: u32, y: u32| {
            let (x, y) = window.global_xy(x, y);
            let pixel = glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let LensRay { origin, dir, .. } = rays.ray(pixel, glam::Vec2::splat(0.5), LensShape::Disk);
            (origin, dir)
        };
        let texel = |(o, d): (Vec3, Vec3), hit: Option<Hit>| {
            let Some(hit) = hit else {
                // A camera ray that leaves the scene sees the environment (black without a map).
                return Texel { emission: scene.background(d).to_array(), ..Texel::default() };
            };
            let sp = scene.surface(&hit, o, d);
            let n = sp.shading_normal;
            // Projected pixel size (thesis Sec. 3.4.1: world length per pixel, foreshortening
            // included): the footprint area is (t·θ)²/|cos θ|; d is its square root.
            let cos = n.dot(-d).abs().max(0.05);
            let footprint = hit.t * pixel_angle / cos.sqrt();
            let a = scene.albedo(&sp);
            let e = scene.emission(&sp);
            let mat = &scene.materials[sp.material as usize];
            Texel {
                position: [sp.position.x, sp.position.y, sp.position.z, 1.0 + sp.object as f32],
                normal: [n.x, n.y, n.z, footprint],
                albedo: a.to_array(),
                emission: e.to_array(),
                specular: [mat.specular.x, mat.specular.y, mat.specular.z, mat.phong_exponent],
            }
        };
        // Each output is written in place, row by row (recycled storage of a persistent pool; no
        // per-pixel intermediate to copy out), issue 38 §2.
        let out = GBufferIo::read(ctx)?;
        let mut position = out.position.storage(ctx)?;
        let mut normal = out.normal.storage(ctx)?;
        let mut albedo = out.albedo.storage(ctx)?;
        let mut emission = out.emission.storage(ctx)?;
        let mut specular = out.specular.storage(ctx)?;
        // (`max(1)`: chunks of an empty image's empty buffers.)
        let row = (ctx.width as usize).max(1);
        let rows = ctx.height as usize;
        let specular_rows = optional_rows(specular.as_mut(), row, rows);
        position
            .par_chunks_mut(row)
            .zip(normal.par_chunks_mut(row))
            .zip(albedo.par_chunks_mut(row))
            .zip(emission.par_chunks_mut(row))
            .zip(specular_rows)
            .enumerate()
            .for_each(|(y, ((((p, n), a), e), mut s))| {
                // A batch of pixels at a time, in three loops (rays, hits, texels) of independent
                // iterations the processor overlaps; per pixel the same numbers as one loop.
                let mut batch = [((Vec3::ZERO, Vec3::ZERO), None::<Hit>); BATCH];
                for x0 in (0..row).step_by(BATCH) {
                    let batch = &mut batch[..(row - x0).min(BATCH)];
                    for (x, (r, _)) in (x0..).zip(batch.iter_mut()) {
                        *r = ray(x as u32, y as u32);
                    }
                    for ((o, d), hit) in batch.iter_mut() {
                        *hit = scene.intersect(*o, *d, 0.0, f32::INFINITY);
                    }
                    for (x, &(r, hit)) in (x0..).zip(batch.iter()) {
                        let t = texel(r, hit);
                        (p[x], n[x], a[x], e[x]) = (t.position, t.normal, t.albedo, t.emission);
                        if let Some(s) = s.as_mut() {
                            s[x] = t.specular;
                        }
                    }
                }
            });
        Counters::add(&ctx.counters.primary_rays, ctx.pixels() as u64);
        out.position.put(ctx, position)?;
        out.normal.put(ctx, normal)?;
        out.albedo.put(ctx, albedo)?;
        out.emission.put(ctx, emission)?;
        out.specular.put_some(ctx, specular)
    }
}
