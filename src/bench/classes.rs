//! Where a render's error lives (issue 35 §2): the bench's bias² / variance split ([`super::stats`])
//! per pixel, summed over **pixel classes**, so a missed goal names its cause — e.g. "78% of the
//! squared error, out-of-focus pixels, variance".
//!
//! Classes come from the scene's pinhole G-buffer at the bench's size (the `primary.gbuffer` pass
//! `--aov` runs, [`crate::aov::Aovs`]): one ray through each pixel centre.
//!
//! - **focus** (only with a thin lens): *in focus* where the circle of confusion at the hit is at most
//!   [`IN_FOCUS_COC_PX`] pixels in radius, *out of focus* elsewhere (`Camera::coc_pixels`, the lens
//!   of the pipeline's factoring node);
//! - **motion** (only where the pipeline samples the shutter): *moving* where the surface seen
//!   blurs over at least [`MOVING_BLUR_PX`] pixels in the shutter (its object's velocity at the hit,
//!   at the shutter's centre, projected into the image: `2 |v|` for `v` in pixels per half shutter,
//!   t ∈ [−1, 1]), *static* elsewhere;
//! - **texture**: *texture edge* where the albedo's luminance steps by more than
//!   [`EDGE_STEP`] to a 4-neighbour (also a neighbour that misses), *flat* elsewhere;
//! - *background* (the centre ray misses) is its own class in every partition.
//!
//! Per pixel, from the two seeds `X₁`, `X₂` and the reference `R` (mean over channels):
//! `mse = (X₁ − R)²`, `variance = (X₁ − X₂)² / 2`. Per class, the means of both and
//! `bias² = max(0, mse − variance − σ_R²)` with the reference's own variance `σ_R²` (one number for
//! the image: the reference's halves are not kept per pixel), and the class's **share** of the
//! image's summed squared error. The same per-pixel maps, averaged over 4×4 blocks so a single
//! noisy pixel does not dominate, are the bench's `images/bias2.png` and `images/variance.png`.

use serde::Serialize;
use wedge_backends::kernels::paths::Projection;
use wedge_scene::{Camera, Scene, Vec3};

use crate::aov::Aovs;
use crate::image::Image;

/// A pixel whose circle of confusion is at most this radius (pixels) counts as in focus.
pub const IN_FOCUS_COC_PX: f32 = 1.0;
/// A luminance step of the albedo to a neighbour above this counts as a texture edge.
pub const EDGE_STEP: f32 = 0.1;
/// A pixel whose surface blurs over at least this many pixels in the shutter counts as moving.
pub const MOVING_BLUR_PX: f32 = 1.0;

/// One partition of the image's pixels: a class label per pixel.
#[derive(Clone, Debug)]
pub struct Partition {
    /// "focus" or "texture".
    pub name: &'static str,
    /// Class names, indexed by the labels.
    pub classes: Vec<&'static str>,
    pub label: Vec<u8>,
}

/// The error of one class of one partition.
#[derive(Clone, Debug, Serialize)]
pub struct ClassError {
    pub partition: &'static str,
    pub class: &'static str,
    /// Fraction of the image's pixels in the class.
    pub pixels: f64,
    /// Fraction of the image's summed squared error in the class.
    pub share: f64,
    pub mse: f64,
    pub variance: f64,
    pub bias2: f64,
}

impl ClassError {
    /// "bias" or "variance": what dominates the class's error.
    pub fn dominant(&self) -> &'static str {
        if self.bias2 > self.variance {
            "bias"
        } else {
            "variance"
        }
    }
}

/// The partitions of `aovs`' pixels: focus (when `lens` = `(aperture_radius, focus_distance)` has an
/// aperture), motion (when `shutter` gives the scene whose motion the pipeline's paths sample) and
/// texture.
pub fn partitions(aovs: &Aovs, camera: &Camera, lens: Option<(f32, f32)>, shutter: Option<&Scene>) -> Vec<Partition> {
    let mut out = Vec::new();
    if let Some((aperture_radius, focus_distance)) = lens.filter(|l| l.0 > 0.0) {
        let cam = Camera { aperture_radius, focus_distance, ..*camera };
        out.push(focus_partition(aovs, &cam));
    }
    if let Some(scene) = shutter.filter(|s| s.has_motion()) {
        out.push(motion_partition(aovs, camera, scene));
    }
    out.push(texture_partition(aovs));
    out
}

fn motion_partition(aovs: &Aovs, camera: &Camera, scene: &Scene) -> Partition {
    let (projection, at) = (Projection::new(camera, aovs.height), scene.at(0.0));
    let label = aovs
        .position
        .iter()
        .zip(&aovs.object)
        .map(|(p, object)| {
            let Some(object) = object else { return 0 };
            let x = Vec3::new(p[0], p[1], p[2]);
            if 2.0 * projection.image_velocity(x, at.object_velocity(*object, x)).length() >= MOVING_BLUR_PX {
                2
            } else {
                1
            }
        })
        .collect();
    Partition { name: "motion", classes: vec!["background", "static", "moving"], label }
}

fn focus_partition(aovs: &Aovs, cam: &Camera) -> Partition {
    let (_, _, forward) = cam.basis();
    let label = aovs
        .position
        .iter()
        .map(|p| {
            if p[3] <= 0.0 {
                return 0;
            }
            let depth = (glam::Vec3::new(p[0], p[1], p[2]) - cam.position).dot(forward);
            if cam.coc_pixels(depth, aovs.height).abs() <= IN_FOCUS_COC_PX {
                1
            } else {
                2
            }
        })
        .collect();
    Partition { name: "focus", classes: vec!["background", "in focus", "out of focus"], label }
}

fn texture_partition(aovs: &Aovs) -> Partition {
    let (w, h) = (aovs.width as usize, aovs.height as usize);
    let lum =
        |k: usize| (aovs.position[k][3] > 0.0).then(|| wedge_scene::environment::luminance(aovs.albedo[k]) as f32);
    let label = (0..w * h)
        .map(|k| {
            let Some(l) = lum(k) else { return 0 };
            let (x, y) = (k % w, k / w);
            let neighbours = [
                (x > 0).then(|| k - 1),
                (x + 1 < w).then(|| k + 1),
                (y > 0).then(|| k - w),
                (y + 1 < h).then(|| k + w),
            ];
            let edge = neighbours.into_iter().flatten().any(|n| lum(n).is_none_or(|m| (m - l).abs() > EDGE_STEP));
            if edge {
                2
            } else {
                1
            }
        })
        .collect();
    Partition { name: "texture", classes: vec!["background", "flat", "texture edge"], label }
}

/// Per-pixel `(mse, variance)` of `x1` (seed 1) against `reference`, with `x2` (seed 2): means over
/// channels; NaN where a value is not finite.
pub fn pixel_errors(x1: &Image, x2: &Image, reference: &Image) -> Vec<(f64, f64)> {
    x1.pixels
        .iter()
        .zip(&x2.pixels)
        .zip(&reference.pixels)
        .map(|((a, b), r)| {
            let (mut mse, mut var) = (0.0f64, 0.0f64);
            for c in 0..3 {
                let (a, b, r) = (f64::from(a[c]), f64::from(b[c]), f64::from(r[c]));
                mse += (a - r) * (a - r) / 3.0;
                var += (a - b) * (a - b) / 6.0;
            }
            if mse.is_finite() && var.is_finite() {
                (mse, var)
            } else {
                (f64::NAN, f64::NAN)
            }
        })
        .collect()
}

/// The error of every class of every partition (classes without pixels left out).
pub fn class_errors(partitions: &[Partition], errors: &[(f64, f64)], reference_variance: f64) -> Vec<ClassError> {
    let total: f64 = errors.iter().map(|e| e.0).filter(|v| v.is_finite()).sum();
    let n = errors.len().max(1) as f64;
    let mut out = Vec::new();
    for p in partitions {
        for (c, class) in p.classes.iter().enumerate() {
            let members: Vec<&(f64, f64)> = errors
                .iter()
                .zip(&p.label)
                .filter(|(e, l)| usize::from(**l) == c && e.0.is_finite())
                .map(|(e, _)| e)
                .collect();
            if members.is_empty() {
                continue;
            }
            let m = members.len() as f64;
            let mse = members.iter().map(|e| e.0).sum::<f64>() / m;
            let variance = members.iter().map(|e| e.1).sum::<f64>() / m;
            out.push(ClassError {
                partition: p.name,
                class,
                pixels: m / n,
                share: if total > 0.0 { mse * m / total } else { 0.0 },
                mse,
                variance,
                bias2: (mse - variance - reference_variance).max(0.0),
            });
        }
    }
    out
}

/// The class with the largest share of the error among the classes of partition `name` (the
/// background excluded unless it is the only one), or of any partition when `name` is `None`.
pub fn worst_class<'a>(errors: &'a [ClassError], name: Option<&str>) -> Option<&'a ClassError> {
    errors
        .iter()
        .filter(|e| name.is_none_or(|n| e.partition == n) && e.class != "background")
        .max_by(|a, b| a.share.total_cmp(&b.share))
}

/// One line naming where the error lives: per partition, its worst class, its share and what
/// dominates it (e.g. "out of focus 78% (variance); texture edge 40% (bias)").
pub fn summary(errors: &[ClassError]) -> String {
    let mut names: Vec<&str> = errors.iter().map(|e| e.partition).collect();
    names.dedup();
    names
        .into_iter()
        .filter_map(|n| worst_class(errors, Some(n)))
        .map(|e| format!("{} {:.0}% ({})", e.class, 100.0 * e.share, e.dominant()))
        .collect::<Vec<_>>()
        .join("; ")
}

/// Per-pixel map of `value(mse, variance)` averaged over `block`×`block` blocks (each pixel gets
/// its block's mean), for the heatmaps: one pixel's noise does not hide the structure.
pub fn block_map(
    errors: &[(f64, f64)],
    width: u32,
    height: u32,
    block: u32,
    value: impl Fn(f64, f64) -> f64,
) -> Vec<f32> {
    let (w, h, b) = (width as usize, height as usize, block.max(1) as usize);
    let mut out = vec![f32::NAN; w * h];
    for by in (0..h).step_by(b) {
        for bx in (0..w).step_by(b) {
            let cells: Vec<usize> =
                (by..(by + b).min(h)).flat_map(|y| (bx..(bx + b).min(w)).map(move |x| y * w + x)).collect();
            let vals: Vec<f64> =
                cells.iter().map(|&k| value(errors[k].0, errors[k].1)).filter(|v| v.is_finite()).collect();
            let mean = if vals.is_empty() { f64::NAN } else { vals.iter().sum::<f64>() / vals.len() as f64 };
            for k in cells {
                out[k] = mean as f32;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(v: &[f32]) -> Image {
        Image { width: v.len() as u32, height: 1, pixels: v.iter().map(|&x| [x; 3]).collect() }
    }

    #[test]
    fn shares_sum_to_one_and_bias_is_mse_minus_variance() {
        let x1 = image(&[1.0, 2.0, 0.5, 0.5]);
        let x2 = image(&[1.0, 1.0, 0.5, 0.5]);
        let r = image(&[0.5, 1.5, 0.5, 0.0]);
        let e = pixel_errors(&x1, &x2, &r);
        assert_eq!(e[0], (0.25, 0.0));
        assert_eq!(e[1], (0.25, 0.5));
        let p = Partition { name: "t", classes: vec!["background", "a", "b"], label: vec![1, 2, 2, 1] };
        let c = class_errors(&[p], &e, 0.0);
        assert_eq!(c.len(), 2);
        assert!((c.iter().map(|c| c.share).sum::<f64>() - 1.0).abs() < 1e-12);
        // Class a: pixels 0 and 3, mse 0.25 each, no variance: all bias, 2/3 of the summed error.
        assert_eq!((c[0].class, c[0].mse, c[0].bias2, c[0].dominant()), ("a", 0.25, 0.25, "bias"));
        // Class b: pixels 1 and 2, mse 0.125, variance 0.25: bias clamped to 0.
        assert_eq!((c[1].class, c[1].bias2, c[1].dominant()), ("b", 0.0, "variance"));
        assert_eq!(summary(&c), "a 67% (bias)");
    }

    #[test]
    fn moving_pixels_are_those_whose_surface_blurs_a_pixel_or_more() {
        let load = |name: &str| wedge_scene::load(&wedge_scene::SceneSource::Builtin(name.into())).unwrap();
        let (w, h) = (64, 48);
        let classes_of = |scene: &Scene, shutter: bool| {
            let aovs = Aovs::render(scene, w, h).unwrap();
            partitions(&aovs, &scene.camera, None, shutter.then_some(scene))
        };
        let moving = load("mo_fast_thin");
        let p = classes_of(&moving, true);
        assert_eq!(p.iter().map(|p| p.name).collect::<Vec<_>>(), ["motion", "texture"]);
        let count = |c: u8| p[0].label.iter().filter(|&&l| l == c).count();
        // Fast movers over a still backdrop: both classes, the movers the smaller one.
        assert!(count(2) > 0 && count(1) > count(2), "static {} moving {}", count(1), count(2));
        // No shutter sampled, or nothing that moves: no motion partition.
        assert_eq!(classes_of(&moving, false).len(), 1);
        assert_eq!(classes_of(&load("cornell"), true).len(), 1);
    }

    #[test]
    fn block_map_averages_blocks() {
        let e = vec![(1.0, 0.0), (3.0, 0.0), (5.0, 0.0), (7.0, 0.0)];
        assert_eq!(block_map(&e, 2, 2, 2, |m, _| m), vec![4.0; 4]);
        assert_eq!(block_map(&e, 2, 2, 1, |m, _| m), vec![1.0, 3.0, 5.0, 7.0]);
    }
}
