//! `neighbourhood.fill`: give pixels with no statistic of their own the average of their
//! neighbours' within a radius (thesis Sec. 3.6: unoccluded pixels take the averages of `d1`, `d2`
//! within a 5-pixel radius). Only neighbours on the same object (position `w`) count, as in the
//! filter: otherwise a bar's edge takes the ground's occluder distances. Input `value.w > 0` marks a
//! pixel that has its own statistic; output `w` is 1 for own, 2 for filled from neighbours, 0 for
//! neither (such pixels are not filtered).

use crate::kernel::{Kernel, KernelCtx, Reach, WgslSource};
use crate::kernels::filter_window::ScreenRadius;
use crate::params::KernelParams;
use crate::BackendError;

pub struct FillInvalid;

crate::kernel_params! {
    /// The neighbourhood's radius in pixels, clamped to `0..=64` when read (the filters' cap).
    pub struct FillParams {
        radius: ScreenRadius,
    }
}

crate::kernel_bindings! {
    /// What a `neighbourhood.fill` pass binds: the first pass's statistics (`w` > 0 where valid),
    /// the G-buffer position (same object test) and the filled statistics.
    pub struct FillIo / FillData {
        read value: [f32; 4], read position: [f32; 4], write out: [f32; 4],
    }
}

impl Kernel for FillInvalid {
    crate::kernel_signature!(name: "neighbourhood.fill", class: Bandwidth, bindings: FillIo, params: [FillParams]);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/neighbourhood_fill.wgsl"), |ctx| {
                Ok(FillParams::read(ctx)?.uniforms())
            })
            .with_reach(|ctx| Ok(Reach::Rows(FillParams::read(ctx)?.radius.get() as u32))),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let FillData { value, position, out } = FillIo::read(ctx)?;
        let radius = FillParams::read(ctx)?.radius.get();
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let filled = ctx.map_pixels(false, |x, y| {
            let i = (y as i32 * w + x as i32) as usize;
            let v = value[i];
            if v[3] > 0.0 {
                return [v[0], v[1], v[2], 1.0];
            }
            if position[i][3] == 0.0 {
                return [0.0; 4];
            }
            let mut sum = [0.0f32; 3];
            let mut n = 0u32;
            for dy in -radius..=radius {
                for dx in -radius..=radius {
                    if dx * dx + dy * dy > radius * radius {
                        continue;
                    }
                    let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                    if nx < 0 || ny < 0 || nx >= w || ny >= h {
                        continue;
                    }
                    let j = (ny * w + nx) as usize;
                    let u = value[j];
                    // Same object only, as the filter (a bar must not take the ground's d1, d2).
                    if u[3] > 0.0 && position[j][3] == position[i][3] {
                        for c in 0..3 {
                            sum[c] += u[c];
                        }
                        n += 1;
                    }
                }
            }
            if n == 0 {
                [0.0; 4]
            } else {
                [sum[0] / n as f32, sum[1] / n as f32, sum[2] / n as f32, 2.0]
            }
        });
        out.put(ctx, filled)
    }
}
