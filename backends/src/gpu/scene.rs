//! Scene upload: the same flat arrays the CPU traverses, in the layouts `shaders/scene.wgsl` declares,
//! packed one after another into ONE storage buffer of 16-byte elements ([`pack`]) so a kernel
//! that reads the scene spends one storage binding on it (WebGPU's default allows 8 per stage);
//! where each array starts goes in a small uniform (`SceneLayout` in scene.wgsl).
//! `WideNode`, `TrianglePack` and `TriangleRecord` are uploaded byte for byte; shading, materials, textures and lights
//! are repacked into 16-byte-aligned structs. Light quantities the kernels need (normal, area,
//! centre, σ) are computed here by the same Rust code the CPU uses, so both backends see identical
//! values.

use bytemuck::{Pod, Zeroable};
use wedge_scene::{LightShape, Scene};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct GpuShading {
    n0: [f32; 3],
    material: u32,
    n1: [f32; 3],
    object: u32,
    n2: [f32; 3],
    _pad: u32,
    uv0: [f32; 2],
    uv1: [f32; 2],
    uv2: [f32; 2],
    _pad2: [f32; 2],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct GpuMaterial {
    base_color: [f32; 3],
    texture: u32,
    emission: [f32; 3],
    _pad: u32,
    specular: [f32; 3],
    phong_exponent: f32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct GpuTextureInfo {
    offset: u32,
    width: u32,
    height: u32,
    _pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct GpuLight {
    p0: [f32; 4],
    p1: [f32; 4],
    p2: [f32; 4],
    radiance: [f32; 4],
    normal_area: [f32; 4],
    centre_sigma: [f32; 4],
    kind: u32,
    two_sided: u32,
    _pad: [u32; 2],
}

/// Names of the scene arrays, in the order they are packed (and of `SceneLayout`'s fields).
pub const SCENE_ARRAYS: [&str; 8] =
    ["bvh_nodes", "triangle_packs", "triangles", "shading", "materials", "tex_info", "texels", "lights"];

/// The bytes of each scene array (never empty: an empty array gets one zeroed element, since
/// WGSL storage buffers cannot be zero-sized).
pub fn scene_bytes(scene: &Scene) -> [Vec<u8>; 8] {
    let shading: Vec<GpuShading> = scene
        .shading
        .iter()
        .map(|s| GpuShading {
            n0: s.n[0].to_array(),
            material: s.material,
            n1: s.n[1].to_array(),
            object: s.object,
            n2: s.n[2].to_array(),
            _pad: 0,
            uv0: s.uv[0].to_array(),
            uv1: s.uv[1].to_array(),
            uv2: s.uv[2].to_array(),
            _pad2: [0.0; 2],
        })
        .collect();
    let materials: Vec<GpuMaterial> = scene
        .materials
        .iter()
        .map(|m| GpuMaterial {
            base_color: m.base_color.to_array(),
            texture: m.base_color_texture.unwrap_or(u32::MAX),
            emission: m.emission.to_array(),
            _pad: 0,
            specular: m.specular.to_array(),
            phong_exponent: m.phong_exponent,
        })
        .collect();
    let mut texels: Vec<f32> = Vec::new();
    let tex_info: Vec<GpuTextureInfo> = scene
        .textures
        .iter()
        .map(|t| {
            let offset = (texels.len() / 4) as u32;
            let ok = !t.texels.is_empty() && t.texels.len() >= (t.width as usize * t.height as usize);
            if ok {
                // One 16-byte element per texel (rgb, 0) so a texel is one load.
                texels.extend(t.texels.iter().flat_map(|c| [c[0], c[1], c[2], 0.0]));
            }
            GpuTextureInfo {
                offset,
                width: if ok { t.width } else { 0 },
                height: if ok { t.height } else { 0 },
                _pad: 0,
            }
        })
        .collect();
    let lights: Vec<GpuLight> = scene
        .lights
        .iter()
        .map(|l| {
            let (kind, p) = match l.shape {
                LightShape::Rect { corner, edge_u, edge_v } => (0u32, [corner, edge_u, edge_v]),
                LightShape::Triangle { v0, v1, v2 } => (1u32, [v0, v1, v2]),
            };
            let v4 = |v: wedge_scene::Vec3, w: f32| [v.x, v.y, v.z, w];
            GpuLight {
                p0: v4(p[0], 0.0),
                p1: v4(p[1], 0.0),
                p2: v4(p[2], 0.0),
                radiance: v4(l.radiance, 0.0),
                normal_area: v4(l.normal(), l.area()),
                centre_sigma: v4(l.centre(), l.sigma()),
                kind,
                two_sided: l.two_sided as u32,
                _pad: [0; 2],
            }
        })
        .collect();
    fn bytes<T: Pod + Zeroable>(v: &[T]) -> Vec<u8> {
        if v.is_empty() {
            vec![0u8; std::mem::size_of::<T>().max(16)]
        } else {
            bytemuck::cast_slice(v).to_vec()
        }
    }
    [
        bytes(&scene.bvh.nodes),
        bytes(&scene.bvh.packs),
        bytes(&scene.triangles),
        bytes(&shading),
        bytes(&materials),
        bytes(&tex_info),
        bytes(&texels),
        bytes(&lights),
    ]
}

/// All scene arrays in one buffer (each starting on a 16-byte element) and the element index where
/// each starts, in [`SCENE_ARRAYS`] order (8 words: the uniform `SceneLayout`).
pub fn pack(arrays: &[Vec<u8>; 8]) -> (Vec<u8>, [u32; 8]) {
    let mut data = Vec::with_capacity(arrays.iter().map(|a| a.len() + 16).sum());
    let mut offsets = [0u32; 8];
    for (k, a) in arrays.iter().enumerate() {
        offsets[k] = (data.len() / 16) as u32;
        data.extend_from_slice(a);
        data.resize(data.len().div_ceil(16) * 16, 0);
    }
    (data, offsets)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_arrays_start_on_16_byte_elements_in_order() {
        let arrays = [vec![1u8; 32], vec![2; 48], vec![3; 80], vec![4; 48], vec![5; 16], vec![6; 20], vec![7; 112], vec![8; 4]];
        let (data, offsets) = pack(&arrays);
        assert_eq!(offsets, [0, 2, 5, 10, 13, 14, 16, 23]);
        assert_eq!(data.len(), 24 * 16);
        for (k, a) in arrays.iter().enumerate() {
            let at = offsets[k] as usize * 16;
            assert_eq!(&data[at..at + a.len()], &a[..], "array {k}");
        }
    }
}
