//! `filter.gaussian`: one axis of the separable, spatially varying world-space Gaussian every
//! axis-aligned filter uses (thesis eqs. 3.10–3.12, Sec. 3.6; the same shape serves Ch. 4's indirect
//! filter with the full 3-D distance).
//!
//! For pixel `i` with bandwidth `β_i` (metres; `0` or non-finite = not filtered, the value passes
//! through), the
//! neighbours `j` along the axis within `ceil(3 β_i / d_i)` pixels (capped by `max_radius`) are
//! weighted by `exp(−‖x_i − x_j‖² / (2 β_i²))`, where the distance drops its component along
//! the normal of light `plane_light` when one is given (eq. 3.12: distance in the plane parallel to the light).
//! Neighbours on another object or the background (position `w`, see `primary.gbuffer`), whose normals differ by more than the normal test allows
//! (thesis: 10°), or whose values are not finite, are not used. `w` of the value passes through.

use glam::Vec3;

use crate::kernel::{Kernel, KernelCtx, Reach, WgslSource};
use crate::kernels::filter_window::WindowRadius;
use crate::kernels::v3;
use crate::params::{AnyLight, KernelParams};
use crate::BackendError;

pub struct GaussianFilter;

/// Largest slope (offset from the tangent plane over distance) a neighbour on the same smooth
/// surface may have; 0.2 allows a curvature radius down to about 2.5× the filter reach.
pub const TANGENT_SLOPE: f32 = 0.2;

crate::param_choice! {
    /// Whose width weighs a neighbour ([`FilterParams::mutual`]); WGSL `params.reach`, 1 = mutual.
    pub enum FilterReach { Own = "own", Mutual = "mutual" }
}

crate::kernel_params! {
    /// What a `filter.gaussian` pass carries (set by `effects::filtering::separable`): `axis` 0 = x,
    /// else y; `plane_light` the light of eq. 3.12's plane, -1 = full 3-D; `max_radius` clamped to
    /// `0..=MAX_RADIUS_LIMIT` as read.
    pub struct GaussianParams {
        axis: u32,
        plane_light: AnyLight,
        max_radius: WindowRadius<MAX_RADIUS_LIMIT>,
        normal_cos: f32,
        reach: FilterReach,
    }
}

crate::kernel_bindings! {
    /// What a `filter.gaussian` pass binds: the value filtered, the G-buffer, the bandwidth `β`
    /// per pixel (metres) and the filtered value.
    pub struct GaussianIo / GaussianData {
        read value: [f32; 4], read position: [f32; 4], read normal: [f32; 4], read bandwidth: f32,
        write out: [f32; 4],
    }
}

/// Largest `max_radius` a pass may ask for.
pub const MAX_RADIUS_LIMIT: u32 = 1024;

impl GaussianParams {
    /// The normal of eq. 3.12's plane: light `plane_light`'s (checked as read), or 0 (full 3-D
    /// distance) for -1.
    fn plane_normal(&self, ctx: &KernelCtx<'_>) -> Vec3 {
        self.plane_light.0.map_or(Vec3::ZERO, |l| ctx.scene.lights[l].normal())
    }
}

/// Parameters of one filter pass as [`filter_pixel`] uses them.
#[derive(Clone, Copy, Debug)]
pub struct FilterParams {
    pub axis: u32,
    pub plane_normal: Vec3,
    pub max_radius: i32,
    pub normal_cos: f32,
    /// Mutual reach: a neighbour with a narrower filter of its own weighs by that width
    /// (`exp(−‖x_i − x_j‖²/(2 min(β_i, β_j)²))`; a neighbour without one, β_j = 0, by β_i), so a
    /// wide filter does not gather a sharper shadow its own first pass never saw (the dark halo
    /// of `suite_near_light`, docs/DESIGN-NOTES.md "SoftShadows after the suite"). Consistent: as μ → ∞
    /// every β → 0 either way.
    pub mutual: bool,
}

/// Squared distance in the plane with unit normal `n` (eq. 3.12); `n = 0` gives the 3-D distance.
#[inline]
pub fn plane_distance2(a: Vec3, b: Vec3, n: Vec3) -> f32 {
    let d = a - b;
    let along = d.dot(n);
    (d.length_squared() - along * along).max(0.0)
}

/// Filter one pixel along one axis.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn filter_pixel(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    p: &FilterParams,
    value: &[[f32; 4]],
    position: &[[f32; 4]],
    normal: &[[f32; 4]],
    bandwidth: &[f32],
) -> [f32; 4] {
    let i = (y * width + x) as usize;
    let beta = bandwidth[i];
    let centre = value[i];
    if beta <= 0.0 || position[i][3] == 0.0 || !beta.is_finite() {
        return centre;
    }
    let d = normal[i][3].max(1e-12);
    let radius = ((3.0 * beta / d).ceil() as i64).clamp(0, p.max_radius as i64) as i32;
    let xi = v3(position[i]);
    let ni = v3(normal[i]);
    let inv = -0.5 / (beta * beta);
    let mut sum = [0.0f32; 3];
    let mut wsum = 0.0f32;
    for k in -radius..=radius {
        let (jx, jy) = if p.axis == 0 { (x + k, y) } else { (x, y + k) };
        if jx < 0 || jy < 0 || jx >= width || jy >= height {
            continue;
        }
        let j = (jy * width + jx) as usize;
        // Different object (or background): never mix. The plane distance of eq. 3.12 ignores
        // offsets along the light normal, so without this a lit bar and the shadowed surface right
        // below it would look like neighbours (thesis Sec. 3.6 footnote 7 offers the object-ID test).
        if position[j][3] != position[i][3] {
            continue;
        }
        if ni.dot(v3(normal[j])) < p.normal_cos {
            continue;
        }
        let v = value[j];
        if !(v[0].is_finite() && v[1].is_finite() && v[2].is_finite()) {
            continue;
        }
        let xj = v3(position[j]);
        let delta = xj - xi;
        // Tangent-plane test: a neighbour well off pixel i's tangent plane is another surface
        // (a bar above a floor, a step). Eq. 3.12 drops offsets along the light normal, so
        // surfaces stacked along it would otherwise blend with full weight.
        if delta.dot(ni).abs() > TANGENT_SLOPE * delta.length() + 0.25 * d {
            continue;
        }
        let bj = bandwidth[j];
        let inv_j = if p.mutual && bj > 0.0 && bj < beta { -0.5 / (bj * bj) } else { inv };
        let w = (plane_distance2(xi, xj, p.plane_normal) * inv_j).exp();
        for c in 0..3 {
            sum[c] += w * v[c];
        }
        wsum += w;
    }
    if wsum > 0.0 {
        [sum[0] / wsum, sum[1] / wsum, sum[2] / wsum, centre[3]]
    } else {
        centre
    }
}

impl Kernel for GaussianFilter {
    crate::kernel_signature!(name: "filter.gaussian", class: Filter, bindings: GaussianIo, params: [GaussianParams]);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/filter_gaussian.wgsl"), |ctx| {
                let p = GaussianParams::read(ctx)?;
                Ok(p.uniforms().vec3("plane_normal", p.plane_normal(ctx).to_array()))
            })
            .with_reach(|ctx| {
                // The x pass stays in its row; the y pass reads up to `max_radius` rows away.
                let p = GaussianParams::read(ctx)?;
                Ok(match p.axis {
                    0 => Reach::Cols(p.max_radius.get() as u32),
                    _ => Reach::Rows(p.max_radius.get() as u32),
                })
            }),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let io = GaussianIo::read(ctx)?;
        let g = GaussianParams::read(ctx)?;
        let p = FilterParams {
            axis: g.axis,
            plane_normal: g.plane_normal(ctx),
            max_radius: g.max_radius.get(),
            normal_cos: g.normal_cos,
            mutual: g.reach == FilterReach::Mutual,
        };
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let (value, position, normal, bandwidth) = (io.value, io.position, io.normal, io.bandwidth);
        let out = ctx
            .map_pixels(false, |x, y| filter_pixel(x as i32, y as i32, w, h, &p, value, position, normal, bandwidth));
        io.out.put(ctx, out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row of 21 pixels on one flat object, 1 cm apart: pixel 10 has a wide filter (β = 5 cm);
    /// pixels 14–20 hold a sharp shadow (value 0) with narrow filters of their own (β = 1 cm), the
    /// rest is lit (value 1) with no filter (β = 0).
    fn row(mutual: bool) -> [f32; 4] {
        let n = 21;
        let position: Vec<[f32; 4]> = (0..n).map(|i| [i as f32 * 0.01, 0.0, 0.0, 1.0]).collect();
        let normal = vec![[0.0, 1.0, 0.0, 0.01]; n];
        let value: Vec<[f32; 4]> =
            (0..n).map(|i| if i >= 14 { [0.0, 0.0, 0.0, 8.0] } else { [1.0, 1.0, 1.0, 8.0] }).collect();
        let bandwidth: Vec<f32> = (0..n)
            .map(|i| {
                if i == 10 {
                    0.05
                } else if i >= 14 {
                    0.01
                } else {
                    0.0
                }
            })
            .collect();
        let p = FilterParams { axis: 0, plane_normal: Vec3::ZERO, max_radius: 64, normal_cos: 0.98, mutual };
        filter_pixel(10, 0, n as i32, 1, &p, &value, &position, &normal, &bandwidth)
    }

    #[test]
    fn mutual_reach_keeps_a_wide_filter_out_of_a_sharp_shadow() {
        // Own reach (the thesis): pixel 10 gathers the shadow 4–10 cm away with its own 5 cm width.
        let own = row(false)[0];
        // Mutual: those neighbours weigh by their 1 cm width, exp(−(4 cm)²/(2 (1 cm)²)) ≈ 3e-4 at most.
        let mutual = row(true)[0];
        let w = |d: f32, b: f32| (-(d * d) / (2.0 * b * b)).exp();
        let lit: f32 = (-10..=3).map(|k| w(k as f32 * 0.01, 0.05)).sum();
        let dark_own: f32 = (4..=10).map(|k| w(k as f32 * 0.01, 0.05)).sum();
        let dark_mutual: f32 = (4..=10).map(|k| w(k as f32 * 0.01, 0.01)).sum();
        assert!((own - lit / (lit + dark_own)).abs() < 1e-6, "{own}");
        assert!((mutual - lit / (lit + dark_mutual)).abs() < 1e-6, "{mutual}");
        assert!(own < 0.8 && mutual > 0.9999, "own {own}, mutual {mutual}");
        // The value's w passes through.
        assert_eq!(row(true)[3], 8.0);
    }
}
