//! `light_field.splats`: the host kernel that builds the splats and their tree from the stored
//! samples ([`crate::light_field::splats`]).

use wedge_backends::kernels::direct::RAY_EPSILON;
use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, PutWith};

use crate::light_field::node::{DEFAULT_ALPHA, DEFAULT_GLOSSY_CAP, DEFAULT_K};
use crate::light_field::records::{LightSample, Splat, SplatNode};
use crate::light_field::splats::{build, KnnSettings};
use crate::light_field::STACK_SIZE;

/// `light_field.splats` (see [`super`] and [`crate::light_field::splats`]).
pub struct LightFieldSplats;

wedge_backends::kernel_params! {
    /// `light_field.splats`'s parameters (Secs. 2.2, 2.3.1), declared by the node and forwarded.
    pub struct SplatParams {
        k: u32 = int(DEFAULT_K, 1, 256, "the k of the splat-radius k-NN search (Sec. 2.2)"),
        alpha: f32 = float(DEFAULT_ALPHA, 1.0, 1e3, "k-NN metric: offsets along the normal count alpha times (Sec. 2.2)"),
        glossy_cap: f32 = float(DEFAULT_GLOSSY_CAP, 1.0, f64::from(f32::MAX), "a glossy splat's radius is at most this many times its spatial-only k-NN radius (a large number: the paper's unbounded search)"),
        shrink: bool = boolean(true, "shrink splats that block input rays (Sec. 2.3.1)"),
    }
}

/// The k-NN settings of `p`, checked (a pass need not come from the node's declarations).
fn knn_settings(ctx: &KernelCtx<'_>, p: &SplatParams) -> Result<KnnSettings, BackendError> {
    let SplatParams { k, alpha, glossy_cap, .. } = *p;
    if !(1..=256).contains(&k) {
        return Err(ctx.err(format!("`k` = {k} must be between 1 and 256")));
    }
    if !(alpha >= 1.0 && alpha.is_finite()) {
        return Err(ctx.err(format!("`alpha` = {alpha} must be a finite number ≥ 1")));
    }
    if !(glossy_cap >= 1.0) {
        return Err(ctx
            .err(format!("`glossy_cap` = {glossy_cap} must be ≥ 1 (0 or less: no cap is written as a large number)")));
    }
    Ok(KnnSettings { k, alpha, glossy_cap })
}

wedge_backends::kernel_bindings! {
    /// What a `light_field.splats` pass binds: the samples, the splats and their tree, and the mean
    /// splat radius per pixel (optional, a heatmap).
    pub struct SplatsIo / SplatsData {
        read samples: LightSample, write splats: Splat, write nodes: SplatNode, write_opt splat_radius: f32,
    }
}

impl Kernel for LightFieldSplats {
    wedge_backends::kernel_signature!(
        name: "light_field.splats", class: Bandwidth, bindings: SplatsIo, params: [SplatParams]
    );
    fn host(&self) -> bool {
        true
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let p = SplatParams::read(ctx)?;
        let (knn, shrink) = (knn_settings(ctx, &p)?, p.shrink);
        let io = SplatsIo::read(ctx)?;
        let samples = io.samples;
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
        io.splat_radius.put_with(ctx, || {
            let (mut sum, mut n) = (vec![0.0f32; pixels], vec![0u32; pixels]);
            for s in &built.splats {
                let p = s.sample as usize / spp.max(1);
                sum[p] += s.radius;
                n[p] += 1;
            }
            sum.iter().zip(&n).map(|(s, &n)| if n > 0 { s / n as f32 } else { 0.0 }).collect()
        })?;
        let mut splats = built.splats;
        splats.resize(splat_slots, Splat::default());
        let mut nodes = built.nodes;
        nodes.resize(node_slots, SplatNode::default());
        io.splats.put(ctx, splats)?;
        io.nodes.put(ctx, nodes)
    }
}
