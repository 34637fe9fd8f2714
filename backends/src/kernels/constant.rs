//! `fill.constant`: every pixel of a `u32` buffer gets the same value. A reference render
//! (`wedge_graph::reference`) puts it where a pipeline computes per-pixel sample counts, so the
//! adaptive sampling passes draw the reference's count everywhere.

use crate::kernel::{Kernel, KernelCtx, WgslSource};
use crate::params::KernelParams;
use crate::BackendError;

pub struct FillConstant;

crate::kernel_bindings! {
    /// What a `fill.constant` pass binds.
    pub struct FillU32Io / FillU32Data { write out: u32 }
}
crate::kernel_bindings! {
    /// What a `fill.constant_f32` pass binds.
    pub struct FillF32Io / FillF32Data { write out: f32 }
}
crate::kernel_bindings! {
    /// What a `fill.constant_vec4` pass binds.
    pub struct FillVec4Io / FillVec4Data { write out: [f32; 4] }
}

crate::kernel_params! {
    /// `fill.constant`'s count (a count outside `0..=u32::MAX` is an error when read, never wrapped).
    pub struct CountParams {
        value: u32,
    }
}

crate::kernel_params! {
    /// `fill.constant_f32` / `fill.constant_vec4`'s value, finite ([`ValueParams::read_finite`]).
    pub struct ValueParams {
        value: f32,
    }
}

impl Kernel for FillConstant {
    crate::kernel_signature!(
        name: wedge_graph::FILL_CONSTANT, class: Bandwidth, bindings: FillU32Io, params: [CountParams]
    );
    /// WGSL mirror: `shaders/fill_constant.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/fill_constant.wgsl"), |ctx| {
                Ok(CountParams::read(ctx)?.uniforms())
            })
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let v = CountParams::read(ctx)?.value;
        FillU32Io::read(ctx)?.out.put(ctx, vec![v; ctx.pixels()])
    }
}

/// `fill.constant_f32`: every pixel of an `f32` buffer gets parameter `value` (a finite number) —
/// e.g. a zero filter width where a node filters nothing. Same WGSL as `fill.constant`: the
/// generated bindings make `value` and `out` `f32`.
pub struct FillConstantF32;

impl ValueParams {
    /// The pass's value; one that is not finite is an error.
    pub fn read_finite(ctx: &KernelCtx<'_>) -> Result<Self, BackendError> {
        let p = Self::read(ctx)?;
        if !p.value.is_finite() {
            return Err(ctx.err(format!("`value` {} is not finite", p.value)));
        }
        Ok(p)
    }
}

impl Kernel for FillConstantF32 {
    crate::kernel_signature!(name: "fill.constant_f32", class: Compose, bindings: FillF32Io, params: [ValueParams]);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/fill_constant.wgsl"), |ctx| {
                Ok(ValueParams::read_finite(ctx)?.uniforms())
            })
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let v = ValueParams::read_finite(ctx)?.value;
        FillF32Io::read(ctx)?.out.put(ctx, vec![v; ctx.pixels()])
    }
}

/// `fill.constant_vec4`: every component of every pixel of a `vec4` buffer gets parameter `value`
/// (a finite number) — e.g. a zero velocity where a Motion node sees no motion.
pub struct FillConstantVec4;

impl Kernel for FillConstantVec4 {
    crate::kernel_signature!(name: "fill.constant_vec4", class: Compose, bindings: FillVec4Io, params: [ValueParams]);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/fill_constant_vec4.wgsl"), |ctx| {
                Ok(ValueParams::read_finite(ctx)?.uniforms())
            })
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let v = ValueParams::read_finite(ctx)?.value;
        FillVec4Io::read(ctx)?.out.put(ctx, vec![[v; 4]; ctx.pixels()])
    }
}
