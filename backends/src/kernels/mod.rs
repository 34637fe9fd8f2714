//! Shared kernels: the heavy machinery every effect node reuses. Effect-specific formulas
//! (bandwidths, rates) live with their effect in `wedge-effects`.

use std::sync::Arc;

use crate::kernel::KernelRegistry;

pub mod compose;
pub mod constant;
pub mod direct;
pub mod environment;
pub mod filter_lanes;
pub mod filter_window;
pub mod gaussian_filter;
pub mod hemisphere;
pub mod indirect;
pub mod irradiance_filter;
pub mod neighbourhood3;
pub mod neighbourhood_fill;
pub mod neighbourhood_others;
pub mod paths;
pub mod primary;
pub mod screen_trace;

pub fn register(reg: &mut KernelRegistry) {
    reg.register(Arc::new(primary::PrimaryGBuffer));
    reg.register(Arc::new(direct::DirectLight));
    reg.register(Arc::new(neighbourhood_fill::FillInvalid));
    reg.register(Arc::new(gaussian_filter::GaussianFilter));
    reg.register(Arc::new(compose::Modulate));
    reg.register(Arc::new(indirect::IndirectSample));
    reg.register(Arc::new(indirect::IndirectCompose));
    reg.register(Arc::new(neighbourhood3::Max3));
    reg.register(Arc::new(neighbourhood_others::Others));
    reg.register(Arc::new(neighbourhood3::Median3));
    reg.register(Arc::new(irradiance_filter::IrradianceFilter));
    reg.register(Arc::new(constant::FillConstant));
    reg.register(Arc::new(constant::FillConstantF32));
    reg.register(Arc::new(constant::FillConstantVec4));
    reg.register(Arc::new(paths::PathsTrace));
    reg.register(Arc::new(paths::PathsResolve));
    reg.register(Arc::new(paths::PathsResolveNear));
}

// Small helpers every kernel family uses, defined once here.

/// The `xyz` of a `vec4` buffer element.
pub fn v3(a: [f32; 4]) -> glam::Vec3 {
    glam::Vec3::new(a[0], a[1], a[2])
}

/// Widen a running range `(min, max)` of a pixel's samples by `v`; `first` (the pixel's first such
/// sample) starts it at `(v, v)`. The samplers keep the ranges of circles of confusion, occluder
/// and indirect-hit distances this way.
pub fn widen_range((min, max): (&mut f32, &mut f32), v: f32, first: bool) {
    if first {
        (*min, *max) = (v, v);
    } else {
        *min = min.min(v);
        *max = max.max(v);
    }
}

/// Whether all three components are finite.
pub fn is_finite3(v: [f32; 3]) -> bool {
    v[0].is_finite() && v[1].is_finite() && v[2].is_finite()
}

/// Add the pass's non-finite values to the run's `non_finite_samples` counter (they are counted
/// and left out of every sum, never averaged in).
pub fn count_non_finite(ctx: &crate::KernelCtx<'_>, value: &[[f32; 3]]) {
    let n = value.iter().filter(|v| !is_finite3(**v)).count() as u64;
    crate::Counters::add(&ctx.counters.non_finite_samples, n);
}

/// Whether every value is +0.0 (a part no surface of the image has, e.g. the glossy part of a
/// diffuse scene). A normalised filter of such an image gives +0.0 everywhere, its input bit for
/// bit, so the filters that check this skip their taps.
pub fn all_positive_zero(value: &[[f32; 3]]) -> bool {
    value.iter().all(|v| v.iter().all(|c| c.to_bits() == 0))
}

/// Rec. 709 luminance (`wedge_scene::environment::luminance`, in f32): the scalar whose variance
/// the pixel filter's blend works with (reading: the thesis blends RGB radiance with one `s` per
/// pixel and does not say which scalar its variances are of), and the environment's brightness.
#[inline]
pub fn luminance(c: glam::Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

#[cfg(test)]
mod tests {
    use super::all_positive_zero;

    #[test]
    fn only_positive_zeros_skip_a_filter() {
        assert!(all_positive_zero(&[[0.0; 3]; 4]));
        assert!(all_positive_zero(&[]));
        // −0.0 would come out of the taps as +0.0: not the input bit for bit, so no skip.
        assert!(!all_positive_zero(&[[0.0, -0.0, 0.0]]));
        assert!(!all_positive_zero(&[[0.0; 3], [0.0, 1e-30, 0.0]]));
        assert!(!all_positive_zero(&[[f32::NAN, 0.0, 0.0]]));
    }
}
