//! Scene upload: the same flat arrays the CPU traverses, in the layouts `shaders/scene.wgsl` declares,
//! packed one after another into ONE storage buffer of 16-byte elements ([`pack`]) so a kernel
//! that reads the scene spends one storage binding on it (WebGPU's default allows 8 per stage);
//! where each array starts goes in a small uniform (`SceneLayout` in scene.wgsl).
//! `WideNode`, `TrianglePack` and `TriangleRecord` are uploaded byte for byte; shading, materials, textures and lights
//! are repacked into 16-byte-aligned structs. Light quantities the kernels need (normal, area,
//! centre, σ) are computed here by the same Rust code the CPU uses, so both backends see identical
//! values. Moving instances (`Scene::instances`) go up with their `PreparedMotion` (θ, 1/sin θ, the
//! short-arc quaternions, ω as the CPU computed them), plus one u32 per object naming its instance
//! and one per light in `GpuLight::instance` (`shaders/motion.wgsl`, `scene.wgsl`).
//!
//! The environment map (`Scene::environment`, `shaders/environment.wgsl`) goes up as four arrays:
//! its texels (one element each: radiance × scale as the CPU computes it, and the texel's sampling pdf
//! per solid angle, `EnvironmentMap::texel_pdf`), the row-boundary values `cot²θ_k` (four per element),
//! the column boundaries sorted by world pseudo-angle as (quadrant, fraction) pairs (two per
//! element), and the 4096-entry sample table (two elements per entry: direction and pdf, radiance and
//! texel). The GPU does not invert CDFs: renderers sample through the table (thesis Sec. 6.5.2), so
//! the CDFs stay on the CPU. Without a map each array is one zeroed element and `env_width` is 0.
//!
//! The mixed-reality real layer (`Scene::real`, `shaders/real_layer.wgsl`) goes up as one array of
//! four elements per camera pixel, row-major, interleaved so one pixel is four consecutive loads:
//! camera rgb + coverage, position xyzw, normal xyz 0, albedo rgb 0 (the CPU's values bit for bit),
//! followed in the same array by the layer's depth pyramid for the scene's camera (the CPU's
//! `screen_trace::DepthPyramid`, bit for bit: a header of 16 elements, then four values per element);
//! `real_width`/`real_height` in the layout, 0 without a layer (then the array is one zeroed element).

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
    /// The instance the light moves with, or [`NO_INSTANCE`].
    instance: u32,
    _pad: u32,
}

/// `GpuLight::instance` / an object's entry of an object at rest (`NO_INSTANCE` in motion.wgsl).
pub const NO_INSTANCE: u32 = u32::MAX;

/// A moving instance (`Instance` in motion.wgsl, 128 bytes): its tree's root, swept box and motion.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct GpuInstance {
    swept_min: [f32; 3],
    root: u32,
    swept_max: [f32; 3],
    _pad0: u32,
    pivot: [f32; 3],
    theta: f32,
    t0: [f32; 3],
    inv_sin_theta: f32,
    t1: [f32; 3],
    _pad1: u32,
    q0: [f32; 4],
    q1: [f32; 4],
    omega: [f32; 3],
    _pad2: u32,
}

/// How many arrays the scene buffer holds.
pub const ARRAY_COUNT: usize = 15;

/// Names of the scene arrays, in the order they are packed (and of `SceneLayout`'s first fields).
pub const SCENE_ARRAYS: [&str; ARRAY_COUNT] = [
    "bvh_nodes",
    "triangle_packs",
    "triangles",
    "shading",
    "materials",
    "tex_info",
    "texels",
    "lights",
    "instances",
    "object_instances",
    "env_texels",
    "env_rows",
    "env_columns",
    "env_table",
    "real_maps",
];

/// Words of the uniform `SceneLayout`: each array's first element, the instance count, the root of
/// the top-level tree over the instances (`Scene::instance_root`), the environment's width, height
/// and first column, the real layer's width and height, padding to 16 bytes (a uniform struct's size
/// is a multiple of 16).
pub const LAYOUT_WORDS: usize = 24;

/// The words of `SceneLayout` after the arrays' offsets, in order (`_pad` words included), as
/// `shaders/scene.wgsl` names them.
pub const LAYOUT_TAIL: [&str; LAYOUT_WORDS - ARRAY_COUNT] = [
    "instance_count",
    "instance_root",
    "env_width",
    "env_height",
    "env_first",
    "real_width",
    "real_height",
    "_pad0",
    "_pad1",
];

/// The bytes of each scene array (never empty: an empty array gets one zeroed element, since
/// WGSL storage buffers cannot be zero-sized).
pub fn scene_bytes(scene: &Scene) -> [Vec<u8>; ARRAY_COUNT] {
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
        .enumerate()
        .map(|(i, l)| {
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
                instance: light_instance(scene, i),
                _pad: 0,
            }
        })
        .collect();
    let instances: Vec<GpuInstance> = scene
        .instances
        .iter()
        .map(|inst| {
            let m = &inst.prepared;
            GpuInstance {
                swept_min: inst.swept_bounds.min.to_array(),
                root: inst.root,
                swept_max: inst.swept_bounds.max.to_array(),
                _pad0: 0,
                pivot: m.pivot.to_array(),
                theta: m.theta,
                t0: m.t[0].to_array(),
                inv_sin_theta: m.inv_sin_theta,
                t1: m.t[1].to_array(),
                _pad1: 0,
                q0: m.q[0].to_array(),
                q1: m.q[1].to_array(),
                omega: m.omega.to_array(),
                _pad2: 0,
            }
        })
        .collect();
    let object_instances: Vec<u32> = scene.objects.iter().map(|o| o.instance.unwrap_or(NO_INSTANCE)).collect();
    let env = environment_arrays(scene);
    let real = real_array(scene);
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
        bytes(&instances),
        bytes(&object_instances),
        bytes(&env.texels),
        bytes(&env.rows),
        bytes(&env.columns),
        bytes(&env.table),
        bytes(&real),
    ]
}

/// The environment map's GPU arrays (empty without a map).
#[derive(Default)]
struct EnvArrays {
    texels: Vec<[f32; 4]>,
    rows: Vec<f32>,
    columns: Vec<[u32; 2]>,
    table: Vec<[u32; 8]>,
}

fn environment_arrays(scene: &Scene) -> EnvArrays {
    let Some(env) = &scene.environment else {
        return EnvArrays::default();
    };
    let n = env.width() as usize * env.height() as usize;
    // Radiance and pdf from the very functions the CPU's `radiance`/`pdf` use, so both are bit-equal.
    let texels = (0..n)
        .map(|k| {
            let l = env.texel_radiance(k);
            [l.x, l.y, l.z, env.texel_pdf(k)]
        })
        .collect();
    let (q, f, _) = env.gpu_columns();
    let columns = q.iter().zip(f).map(|(&q, &f)| [q, f.to_bits()]).collect();
    let table = env
        .table_entries()
        .iter()
        .map(|s| {
            let b = |v: f32| v.to_bits();
            [b(s.dir.x), b(s.dir.y), b(s.dir.z), b(s.pdf), b(s.radiance.x), b(s.radiance.y), b(s.radiance.z), s.texel]
        })
        .collect();
    EnvArrays { texels, rows: env.gpu_rows().to_vec(), columns, table }
}

/// The real layer's array: per pixel camera rgb + coverage, position xyzw, normal xyz 0, albedo rgb 0,
/// then the depth pyramid of the layer seen by the scene's camera
/// ([`crate::kernels::screen_trace::DepthPyramid::gpu_elements`]; empty without a layer).
fn real_array(scene: &Scene) -> Vec<[f32; 4]> {
    let Some(real) = &scene.real else {
        return Vec::new();
    };
    let (cam, pos, nor, alb) = (real.camera_map(), real.position_map(), real.normal_map(), real.albedo_map());
    let mut v = Vec::with_capacity(cam.len() * 4);
    for k in 0..cam.len() {
        let c = cam[k];
        let n = nor[k];
        let a = alb[k];
        v.extend([[c[0], c[1], c[2], pos[k][3]], pos[k], [n[0], n[1], n[2], 0.0], [a[0], a[1], a[2], 0.0]]);
    }
    // The pyramid depends on the camera, and so does this array's hash: a new camera uploads anew.
    let pyramid = crate::kernels::screen_trace::DepthPyramid::of(real, &scene.camera);
    v.extend(pyramid.gpu_elements().iter().map(|e| e.map(f32::from_bits)));
    v
}

/// The instance light `i` moves with (`Scene::light_object`'s), or [`NO_INSTANCE`].
fn light_instance(scene: &Scene, i: usize) -> u32 {
    scene
        .light_object
        .get(i)
        .and_then(|&o| scene.objects.get(o as usize))
        .and_then(|o| o.instance)
        .unwrap_or(NO_INSTANCE)
}

/// The uniform `SceneLayout`: the arrays' first elements ([`pack`]), then the instance count, the
/// top-level tree's root, the environment's width, height (0, 0 without a map) and the map column
/// its first sorted column boundary starts, and the real layer's width and height (0, 0 without one);
/// see [`LAYOUT_TAIL`].
pub fn layout(offsets: &[u32; ARRAY_COUNT], scene: &Scene) -> [u32; LAYOUT_WORDS] {
    let mut words = [0u32; LAYOUT_WORDS];
    words[..ARRAY_COUNT].copy_from_slice(offsets);
    words[ARRAY_COUNT] = scene.instances.len() as u32;
    words[ARRAY_COUNT + 1] = scene.instance_root;
    if let Some(env) = &scene.environment {
        words[ARRAY_COUNT + 2] = env.width();
        words[ARRAY_COUNT + 3] = env.height();
        words[ARRAY_COUNT + 4] = env.gpu_columns().2;
    }
    if let Some(real) = &scene.real {
        words[ARRAY_COUNT + 5] = real.width();
        words[ARRAY_COUNT + 6] = real.height();
    }
    words
}

/// All scene arrays in one buffer (each starting on a 16-byte element) and the element index where
/// each starts, in [`SCENE_ARRAYS`] order (the first words of the uniform `SceneLayout`, [`layout`]).
pub fn pack<const N: usize>(arrays: &[Vec<u8>; N]) -> (Vec<u8>, [u32; N]) {
    let mut data = Vec::with_capacity(arrays.iter().map(|a| a.len() + 16).sum());
    let mut offsets = [0u32; N];
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

    /// The WGSL top-level walk's stack is as large as the CPU's (which the scene build keeps trees
    /// within; the per-tree stack is generated per scene, see `traversal_stack_entries`), its nodes as wide, and its triangle test's error-bound constants have the CPU's bits.
    #[test]
    fn wgsl_constants_are_the_cpus() {
        let bvh = include_str!("../../../shaders/bvh.wgsl");
        for line in [
            format!("const TOP_STACK_SIZE: u32 = {}u;", wedge_scene::bvh::build::TOP_STACK_SIZE),
            format!("const GAMMA_2: u32 = {:#x}u;", wedge_scene::bvh::triangle::GAMMA[0].to_bits()),
            format!("const GAMMA_3: u32 = {:#x}u;", wedge_scene::bvh::triangle::GAMMA[1].to_bits()),
            format!("const GAMMA_5: u32 = {:#x}u;", wedge_scene::bvh::triangle::GAMMA[2].to_bits()),
        ] {
            assert!(bvh.contains(&line), "shaders/bvh.wgsl lacks `{line}`");
        }
        // scene.wgsl reads a node as 8 · BVH_GROUPS 16-byte elements, six rows of bounds first.
        let width = wedge_scene::bvh::WIDTH;
        assert_eq!(std::mem::size_of::<wedge_scene::WideNode>(), 8 * (width / 4) * 16);
        let scene = include_str!("../../../shaders/scene.wgsl");
        for line in [
            format!("const BVH_WIDTH: u32 = {width}u;"),
            format!("const BVH_GROUPS: u32 = {}u;", width / 4),
            format!("const BVH_NODE_ELEMENTS: u32 = {}u;", 8 * width / 4),
        ] {
            assert!(scene.contains(&line), "shaders/scene.wgsl lacks `{line}`");
        }
    }

    /// `struct SceneLayout` in scene.wgsl has exactly the words [`layout`] writes, in order: the
    /// arrays of [`SCENE_ARRAYS`], then [`LAYOUT_TAIL`] (a field added on one side only would shift
    /// every later one and read garbage offsets).
    #[test]
    fn wgsl_scene_layout_matches_the_words_written() {
        let wgsl = include_str!("../../../shaders/scene.wgsl");
        let start = wgsl.find("struct SceneLayout {").expect("scene.wgsl declares SceneLayout");
        let body = &wgsl[start..start + wgsl[start..].find('}').unwrap()];
        let fields: Vec<&str> = body
            .lines()
            .skip(1)
            .filter_map(|l| l.split("//").next()?.trim().split_once(':'))
            .map(|(name, ty)| {
                assert_eq!(ty.trim().trim_end_matches(','), "u32", "SceneLayout.{name} must be u32");
                name.trim()
            })
            .collect();
        let expected: Vec<&str> = SCENE_ARRAYS.iter().chain(LAYOUT_TAIL.iter()).copied().collect();
        assert_eq!(fields, expected);
        assert_eq!(fields.len() % 4, 0, "a uniform struct's size is a multiple of 16 bytes");
    }

    #[test]
    fn packed_arrays_start_on_16_byte_elements_in_order() {
        let arrays =
            [vec![1u8; 32], vec![2; 48], vec![3; 80], vec![4; 48], vec![5; 16], vec![6; 20], vec![7; 112], vec![8; 4]];
        let (data, offsets) = pack(&arrays);
        assert_eq!(offsets, [0, 2, 5, 10, 13, 14, 16, 23]);
        assert_eq!(data.len(), 24 * 16);
        for (k, a) in arrays.iter().enumerate() {
            let at = offsets[k] as usize * 16;
            assert_eq!(&data[at..at + a.len()], &a[..], "array {k}");
        }
    }

    /// The GPU stack holds every tree of each built-in scene (its need, not the 128-entry bound),
    /// as a power of two between 16 and the bound.
    #[test]
    fn traversal_stacks_fit_each_scene() {
        for name in wedge_scene::builtin_names() {
            let scene = wedge_scene::load(&wedge_scene::SceneSource::Builtin(name.to_string())).unwrap();
            let (need, entries) = (scene.traversal_stack_need(), crate::gpu::traversal_stack_entries(&scene) as usize);
            println!("{name}: the trees need {need} stack entries, the kernels get {entries}");
            assert!(
                need <= entries && entries.is_power_of_two() && (16..=wedge_scene::bvh::STACK_SIZE).contains(&entries),
                "{name}"
            );
        }
    }
}
