//! `light_field.splats`: the host kernel that builds the splats and their tree from the stored
//! samples ([`crate::light_field::splats`]).

use wedge_backends::kernels::direct::RAY_EPSILON;
use wedge_backends::{BackendError, Binding, Kernel, KernelClass, KernelCtx};
use wedge_graph::Format;

use crate::light_field::records::{LightSample, Splat, SplatNode, LIGHT_SAMPLE, SPLAT, SPLAT_NODE};
use crate::light_field::splats::{build, KnnSettings};
use crate::light_field::STACK_SIZE;

/// `light_field.splats` (see [`super`] and [`crate::light_field::splats`]).
pub struct LightFieldSplats;

fn knn_settings(ctx: &KernelCtx<'_>) -> Result<KnnSettings, BackendError> {
    let k = ctx.int_param("k")?;
    if !(1..=256).contains(&k) {
        return Err(ctx.err(format!("`k` = {k} must be between 1 and 256")));
    }
    let alpha = ctx.f32_param("alpha")?;
    if !(alpha >= 1.0 && alpha.is_finite()) {
        return Err(ctx.err(format!("`alpha` = {alpha} must be a finite number ≥ 1")));
    }
    let glossy_cap = ctx.f32_param("glossy_cap")?;
    if !(glossy_cap >= 1.0) {
        return Err(ctx
            .err(format!("`glossy_cap` = {glossy_cap} must be ≥ 1 (0 or less: no cap is written as a large number)")));
    }
    Ok(KnnSettings { k: k as u32, alpha, glossy_cap })
}

impl Kernel for LightFieldSplats {
    fn name(&self) -> &'static str {
        "light_field.splats"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn host(&self) -> bool {
        true
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("samples", Format::Struct(&LIGHT_SAMPLE)),
            Binding::write("splats", Format::Struct(&SPLAT)),
            Binding::write("nodes", Format::Struct(&SPLAT_NODE)),
            Binding::write_opt("splat_radius", Format::F32),
        ]
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let knn = knn_settings(ctx)?;
        let shrink = ctx.bool_param("shrink")?;
        let samples = ctx.read::<LightSample>("samples")?;
        let (spp, pixels) = (ctx.layers("samples") as usize, ctx.pixels());
        let (splat_slots, node_slots) = (pixels * ctx.layers("splats") as usize, pixels * ctx.layers("nodes") as usize);
        let built = build(samples, knn, shrink, RAY_EPSILON * ctx.scene.extent()).map_err(|depth| {
            ctx.err(format!("the splat tree is {depth} levels deep, more than the traversal stack's {STACK_SIZE}; use fewer samples (`spp`) or a smaller image"))
        })?;
        if built.splats.len() > splat_slots || built.nodes.len() > node_slots {
            return Err(ctx.err(format!(
                "{} splats and {} nodes do not fit the node's buffers ({splat_slots}, {node_slots}); `splats` needs ≥ spp and `nodes` ≥ 2·spp layers",
                built.splats.len(),
                built.nodes.len()
            )));
        }
        if ctx.is_bound("splat_radius") {
            let (mut sum, mut n) = (vec![0.0f32; pixels], vec![0u32; pixels]);
            for s in &built.splats {
                let p = s.sample as usize / spp.max(1);
                sum[p] += s.radius;
                n[p] += 1;
            }
            ctx.put(
                "splat_radius",
                sum.iter().zip(&n).map(|(s, &n)| if n > 0 { s / n as f32 } else { 0.0 }).collect::<Vec<_>>(),
            )?;
        }
        let mut splats = built.splats;
        splats.resize(splat_slots, Splat::default());
        let mut nodes = built.nodes;
        nodes.resize(node_slots, SplatNode::default());
        ctx.put("splats", splats)?;
        ctx.put("nodes", nodes)
    }
}
