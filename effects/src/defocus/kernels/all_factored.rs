//! `defocus.all_factored`: the pixels whose whole radiance factors — every lighting component's
//! first-pass flag set (SepDir / SepInd, thesis eq. 5.30, median-filtered) and no emitter seen by
//! the camera paths — for `defocus.rates` to give eq. 5.33's screen filter the Defocus node's
//! `screen_scale_factored` there (docs/DESIGN-NOTES.md "The screen filter's scale, per pixel").
//!
//! The reasoning: such a pixel's radiance is a diffuse texture under the (smooth) irradiance its
//! component's filter averages, and defocus blurs a texture's edges into ramps, which a wider
//! Gaussian barely changes; a pixel whose radiance does not factor carries a glossy lobe or an
//! emitter, which defocus blurs into a disc with a sharp rim, which it does change. Measured, it
//! holds on the defocus suite and not on held-out scenes (factored pixels that take bias, bright
//! diffuse ones the absolute threshold leaves unfactored), so no shipped pipeline sets the option
//! (that section of docs/DESIGN-NOTES.md). One pass per component,
//! each ANDing its flag into the previous pass's result (`previous`; the first binds the emission).
//! Integer output from integer and sign tests, so both backends agree bit for bit. WGSL mirror:
//! `shaders/defocus_all_factored.wgsl`.

use wedge_backends::{BackendError, Kernel, KernelCtx, Uniforms, WgslSource};

wedge_backends::kernel_bindings! {
    /// What a `defocus.all_factored` pass binds: one component's flag, the result of the pass
    /// before it (absent for the first), the camera paths' emission (absent: none seen) and the
    /// result, 1 where every flag so far is set and no channel of the emission is above 0.
    pub struct AllFactoredIo / AllFactoredData {
        read flag: u32, read_opt previous: u32, read_opt emission: [f32; 3], write out: u32,
    }
}

/// Whether a pixel's radiance factors so far: its `flag` set, the `previous` passes' result set
/// (where bound) and no emission (where bound; a NaN channel counts as emission).
pub fn all_factored(flag: u32, previous: Option<u32>, emission: Option<[f32; 3]>) -> bool {
    let dark = |e: [f32; 3]| e.iter().all(|&c| c <= 0.0);
    flag != 0 && previous.is_none_or(|p| p != 0) && emission.is_none_or(dark)
}

/// `defocus.all_factored`: see the module doc.
pub struct AllFactored;

impl Kernel for AllFactored {
    wedge_backends::kernel_signature!(
        name: "defocus.all_factored", class: Bandwidth, bindings: AllFactoredIo
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/defocus_all_factored.wgsl"), |_| Ok(Uniforms::new()))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let AllFactoredData { flag, previous, emission, out } = AllFactoredIo::read(ctx)?;
        let result: Vec<u32> = ctx.map_pixels(false, |x, y| {
            let i = (y * ctx.width + x) as usize;
            all_factored(flag[i], previous.map(|p| p[i]), emission.map(|e| e[i])) as u32
        });
        out.put(ctx, result)
    }
}

#[cfg(test)]
mod tests {
    use super::all_factored;

    #[test]
    fn a_pixel_factors_only_where_every_flag_is_set_and_no_emitter_is_seen() {
        assert!(all_factored(1, None, None));
        assert!(all_factored(1, Some(1), Some([0.0, -0.0, 0.0])));
        assert!(!all_factored(0, None, None));
        assert!(!all_factored(1, Some(0), None));
        assert!(!all_factored(1, None, Some([0.0, 1e-6, 0.0])));
        assert!(!all_factored(1, None, Some([f32::NAN, 0.0, 0.0])));
    }
}
