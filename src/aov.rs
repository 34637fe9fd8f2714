//! Arbitrary output variables: per-pixel surface data of the scene a pipeline renders, written beside
//! the image by `wedge render --aov position,normal,albedo`.
//!
//! They are exactly the maps a mixed-reality real layer is read from
//! ([`wedge_scene::RealLayer::open`], issue 15), so a wedge render of any scene can stand in for a
//! captured real world: its `render.exr` is `L_cam`, and
//!
//! - `aov_position.exr` (RGBA): the world-space point a camera ray through the pixel centre hits, A = 1
//!   where it hits geometry and 0 where it misses (xyz 0 there);
//! - `aov_normal.exr` (RGB): the unit shading normal there, facing the camera, as the `Primary` node's
//!   G-buffer has it (0 on misses);
//! - `aov_albedo.exr` (RGB): the diffuse albedo `k_d` there, textures included (0 on misses).
//!
//! They come from the very `primary.gbuffer` kernel every pipeline starts with, run alone on the CPU
//! ([`wedge_backends::lone::LonePass`]): one ray through each pixel centre, through the lens centre,
//! at the shutter's centre (t = 0), so they match the pipeline's G-buffer bit for bit. Its position's w
//! (1 + object id) becomes the coverage and its normal's w (the pixel footprint) is dropped.

use std::collections::BTreeMap;
use std::sync::Arc;

use wedge_backends::kernels::primary::PrimaryGBuffer;
use wedge_backends::lone::LonePass;
use wedge_backends::BufferData;
use wedge_scene::Scene;

use crate::session::WedgeError;

/// The AOVs `--aov` accepts, in the order they are written.
pub const AOV_NAMES: [&str; 3] = ["position", "normal", "albedo"];

/// The three maps at one image size (row-major, top row first).
#[derive(Clone, Debug, PartialEq)]
pub struct Aovs {
    pub width: u32,
    pub height: u32,
    /// World xyz, w = 1 where the pixel-centre ray hits geometry, 0 where it misses (xyz 0 there).
    pub position: Vec<[f32; 4]>,
    /// Unit shading normal facing the camera; 0 on misses.
    pub normal: Vec<[f32; 3]>,
    /// Diffuse albedo k_d at the hit (textures included); 0 on misses.
    pub albedo: Vec<[f32; 3]>,
    /// The id of the object hit (`None` on misses): the bench's moving / static pixel classes read
    /// its motion. Not written by `--aov`.
    pub object: Vec<Option<u32>>,
}

impl Aovs {
    /// Run `primary.gbuffer` for `scene` (its camera) at `width × height` on the CPU and convert its
    /// outputs to the real layer's conventions (module doc).
    pub fn render(scene: &Scene, width: u32, height: u32) -> Result<Aovs, WedgeError> {
        let inputs: BTreeMap<String, BufferData> = BTreeMap::new();
        let pass = LonePass::new(Arc::new(PrimaryGBuffer), BTreeMap::new(), &inputs)?;
        // The G-buffer draws no random numbers; the seed is irrelevant.
        let (out, _) = pass.run_cpu(scene, width, height, 0)?;
        let get = |name: &str| {
            out.get(name).ok_or_else(|| WedgeError::Usage(format!("primary.gbuffer wrote no `{name}` buffer (a bug)")))
        };
        let (BufferData::Vec4(pos), BufferData::Vec4(nor), BufferData::Vec3(alb)) =
            (get("position")?, get("normal")?, get("albedo")?)
        else {
            return Err(WedgeError::Usage("primary.gbuffer's outputs have unexpected formats (a bug)".into()));
        };
        let n = pos.len();
        let (mut position, mut normal, mut albedo, mut object) =
            (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
        for k in 0..n {
            // position.w = 1 + object id on a hit, 0 on a miss (primary.rs).
            if pos[k][3] > 0.0 {
                position.push([pos[k][0], pos[k][1], pos[k][2], 1.0]);
                normal.push([nor[k][0], nor[k][1], nor[k][2]]);
                albedo.push(alb[k]);
                object.push(Some(pos[k][3] as u32 - 1));
            } else {
                position.push([0.0; 4]);
                normal.push([0.0; 3]);
                albedo.push([0.0; 3]);
                object.push(None);
            }
        }
        Ok(Aovs { width, height, position, normal, albedo, object })
    }

    /// The maps named in `names` (a subset of [`AOV_NAMES`], in any order) as `(file stem, RGBA
    /// pixels, whether A is data)` in [`AOV_NAMES`] order: `aov_position` keeps its A, the others are RGB.
    pub fn images(&self, names: &[String]) -> Vec<crate::outputs::ExtraExr> {
        let wants = |n: &str| names.iter().any(|s| s == n);
        let rgb = |v: &[[f32; 3]]| v.iter().map(|c| [c[0], c[1], c[2], 1.0]).collect::<Vec<_>>();
        let mut out = Vec::new();
        for name in AOV_NAMES {
            if !wants(name) {
                continue;
            }
            let (pixels, alpha) = match name {
                "position" => (self.position.clone(), true),
                "normal" => (rgb(&self.normal), false),
                _ => (rgb(&self.albedo), false),
            };
            out.push(crate::outputs::ExtraExr {
                stem: format!("aov_{name}"),
                width: self.width,
                height: self.height,
                pixels,
                alpha,
            });
        }
        out
    }
}
