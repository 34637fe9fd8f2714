//! `fill.constant`: every pixel of a `u32` buffer gets the same value. A reference render
//! (`wedge_graph::reference`) puts it where a pipeline computes per-pixel sample counts, so the
//! adaptive sampling passes draw the reference's count everywhere.

use wedge_graph::Format;

use crate::kernel::{Binding, Kernel, KernelClass, KernelCtx, Uniforms, WgslSource};
use crate::BackendError;

pub struct FillConstant;

/// The parameter as a `u32`; a count outside `0..=u32::MAX` is an error, never wrapped.
fn value(ctx: &KernelCtx<'_>) -> Result<u32, BackendError> {
    let v = ctx.int_param("value")?;
    u32::try_from(v).map_err(|_| BackendError::Kernel {
        pass: ctx.pass.into(),
        message: format!("`value` {v} is not a count (0..=4294967295)"),
    })
}

impl Kernel for FillConstant {
    fn name(&self) -> &'static str {
        wedge_graph::FILL_CONSTANT
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![Binding::write("out", Format::U32)]
    }
    /// WGSL mirror: `shaders/fill_constant.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/fill_constant.wgsl"), |ctx| {
                Ok(Uniforms::new().u32("value", value(ctx)?))
            })
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let v = value(ctx)?;
        ctx.put("out", vec![v; ctx.pixels()])
    }
}

/// `fill.constant_f32`: every pixel of an `f32` buffer gets parameter `value` (a finite number) —
/// e.g. a zero filter width where a node filters nothing. Same WGSL as `fill.constant`: the
/// generated bindings make `value` and `out` `f32`.
pub struct FillConstantF32;

fn value_f32(ctx: &KernelCtx<'_>) -> Result<f32, BackendError> {
    let v = ctx.f32_param("value")?;
    if !v.is_finite() {
        return Err(BackendError::Kernel { pass: ctx.pass.into(), message: format!("`value` {v} is not finite") });
    }
    Ok(v)
}

impl Kernel for FillConstantF32 {
    fn name(&self) -> &'static str {
        "fill.constant_f32"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![Binding::write("out", Format::F32)]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/fill_constant.wgsl"), |ctx| {
                Ok(Uniforms::new().f32("value", value_f32(ctx)?))
            })
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let v = value_f32(ctx)?;
        ctx.put("out", vec![v; ctx.pixels()])
    }
}

/// `fill.constant_vec4`: every component of every pixel of a `vec4` buffer gets parameter `value`
/// (a finite number) — e.g. a zero velocity where a Motion node sees no motion.
pub struct FillConstantVec4;

impl Kernel for FillConstantVec4 {
    fn name(&self) -> &'static str {
        "fill.constant_vec4"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![Binding::write("out", Format::Vec4)]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/fill_constant_vec4.wgsl"), |ctx| {
                Ok(Uniforms::new().f32("value", value_f32(ctx)?))
            })
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let v = value_f32(ctx)?;
        ctx.put("out", vec![[v; 4]; ctx.pixels()])
    }
}
