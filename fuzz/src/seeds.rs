//! Seed inputs, generated in code so that no binary corpus needs to be committed: the shipped
//! pipelines; small glTF/GLB scenes covering the features the loader reads (indexed and
//! non-indexed meshes, u8/u16/u32 indices, normals, texture coordinates, an external buffer and
//! texture, node hierarchy with transforms, cameras, emissive strength, punctual lights, translation
//! and rotation animations); OBJ + MTL
//! variants; EXR images in every compression the `exr` crate writes, in f32 and f16, as scanlines
//! and tiles. `--corpus DIR` adds files on top of these.

use std::io::Cursor;

use crate::targets::MTL_MARKER;

/// The seeds of target `name` (empty for an unknown name).
pub fn seeds(name: &str) -> Vec<Vec<u8>> {
    match name {
        "pipeline" => pipelines(),
        "gltf" => gltf_scenes().into_iter().map(String::into_bytes).collect(),
        "glb" => gltf_scenes()
            .into_iter()
            .filter(|json| !json.contains(r#""uri": "data:"#) && !json.contains("buffer.bin"))
            .map(|json| to_glb(&json))
            .collect(),
        "obj" => obj_scenes(),
        "exr" => exr_images(),
        "camera_path" => camera_paths(),
        "set" => sets(),
        _ => Vec::new(),
    }
}

fn pipelines() -> Vec<Vec<u8>> {
    let mut v: Vec<Vec<u8>> = [
        include_str!("../../pipelines/shadows.ron"),
        include_str!("../../pipelines/ao.ron"),
        include_str!("../../pipelines/indirect.ron"),
        include_str!("../../pipelines/shadows_indirect.ron"),
    ]
    .iter()
    .map(|s| s.as_bytes().to_vec())
    .collect();
    // The camera block, which the shipped pipelines do not use.
    v.push(
        include_str!("../../pipelines/shadows.ron")
            .replacen(
                "seed: 1,",
                "seed: 1,\n    camera: Some((position: (0.0, 1.0, 4.0), look_at: (0.0, 0.0, 0.0), \
                 up: (0.0, 1.0, 0.0), vfov_deg: 45.0, aperture_radius: 0.05, focus_distance: Some(4.0))),",
                1,
            )
            .into_bytes(),
    );
    v
}

/// Pipelines with camera paths: the shipped temporal ones, with a camera block, a three-key path
/// that turns, a held path, and a long one (the shapes the validator's analysis distinguishes).
fn camera_paths() -> Vec<Vec<u8>> {
    let temporal = include_str!("../../pipelines/environment_temporal.ron");
    let with_camera = temporal.replacen(
        "seed: 1,",
        "seed: 1,\n    camera: Some((position: (0, 1.6, 3.3), look_at: (0, 0.45, 0), up: (0, 1, 0), vfov_deg: 40)),",
        1,
    );
    let keys = |k: &str| temporal.replacen("(frame: 23, position: (0.8, 1.6, 3.3), look_at: (0, 0.45, 0)),", k, 1);
    [
        temporal.to_string(),
        include_str!("../../pipelines/mixed_reality_temporal.ron").to_string(),
        with_camera.clone(),
        keys("(frame: 10, position: (0, 1.6, -3.3), look_at: (0, 0.45, 0)),\n        (frame: 20, position: (3.3, 0.2, 0), look_at: (0, 0.45, 0.5)),"),
        keys("(frame: 5, position: (-0.8, 1.6, 3.3), look_at: (0, 0.45, 0)),"),
        keys("(frame: 4000000000, position: (0.8, 1.6, 3.3), look_at: (0.1, 0.45, 0)),"),
    ]
    .into_iter()
    .map(String::into_bytes)
    .collect()
}

/// `--set` lines for the `set` target's pipeline: every value type, and several at once.
fn sets() -> Vec<Vec<u8>> {
    [
        "shadows.mu=2",
        "shadows.light=0\nshadows.max_rays=64",
        "shadows.mu=0.5\nshadows.fill_radius=4",
        "shadows.form_factor=light_centre\nshadows.alpha=0.5",
    ]
    .iter()
    .map(|s| s.as_bytes().to_vec())
    .collect()
}

/// A 2×2 RGB PNG (the texture companion file `tex.png`).
pub fn tiny_png() -> Vec<u8> {
    let img = image::RgbImage::from_fn(2, 2, |x, y| {
        if (x + y) % 2 == 0 {
            image::Rgb([255, 255, 255])
        } else {
            image::Rgb([188, 0, 0])
        }
    });
    let mut out = Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).expect("encoding a 2x2 PNG in memory cannot fail");
    out.into_inner()
}

/// The binary buffer of the glTF seeds (also written as the companion file `buffer.bin`):
/// offset 0 ground positions (6 × vec3), 72 light positions (4 × vec3), 120 u16 indices (6),
/// 132 ground uv (6 × vec2), 180 ground normals (6 × vec3), 252 u32 indices (6), 276 u8 indices
/// (6), padded to 284 bytes; then animation keyframes: 284 times (2 × f32: 0, 1), 292 translations
/// (2 × vec3), 316 rotations (2 × vec4: identity, 90° about y); 348 bytes.
pub fn gltf_buffer() -> Vec<u8> {
    let ground: [[f32; 3]; 6] =
        [[-1., 0., 1.], [1., 0., 1.], [1., 0., -1.], [-1., 0., 1.], [1., 0., -1.], [-1., 0., -1.]];
    let light: [[f32; 3]; 4] = [[-0.25, 2., -0.25], [0.25, 2., -0.25], [0.25, 2., 0.25], [-0.25, 2., 0.25]];
    let uv: [[f32; 2]; 6] = [[0., 1.], [1., 1.], [1., 0.], [0., 1.], [1., 0.], [0., 0.]];
    let mut b = Vec::new();
    for p in ground.iter().chain(light.iter()) {
        p.iter().for_each(|c| b.extend_from_slice(&c.to_le_bytes()));
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    for t in uv {
        t.iter().for_each(|c| b.extend_from_slice(&c.to_le_bytes()));
    }
    for _ in 0..6 {
        [0f32, 1., 0.].iter().for_each(|c| b.extend_from_slice(&c.to_le_bytes()));
    }
    for i in [0u32, 1, 2, 0, 2, 3] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b.extend_from_slice(&[0, 1, 2, 0, 2, 3, 0, 0]);
    debug_assert_eq!(b.len(), 284);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    for v in [0f32, 1.] // times
        .iter()
        .chain(&[0., 0., 0., 1., 0., 0.5]) // translations
        .chain(&[0., 0., 0., 1., 0., h, 0., h])
    // rotations
    {
        b.extend_from_slice(&v.to_le_bytes());
    }
    debug_assert_eq!(b.len(), 348);
    b
}

const BUFFER_VIEWS: &str = r#"[
    {"buffer": 0, "byteOffset": 0, "byteLength": 72},
    {"buffer": 0, "byteOffset": 72, "byteLength": 48, "byteStride": 12},
    {"buffer": 0, "byteOffset": 120, "byteLength": 12},
    {"buffer": 0, "byteOffset": 132, "byteLength": 48},
    {"buffer": 0, "byteOffset": 180, "byteLength": 72},
    {"buffer": 0, "byteOffset": 252, "byteLength": 24},
    {"buffer": 0, "byteOffset": 276, "byteLength": 6},
    {"buffer": 0, "byteOffset": 284, "byteLength": 8},
    {"buffer": 0, "byteOffset": 292, "byteLength": 24},
    {"buffer": 0, "byteOffset": 316, "byteLength": 32}
  ]"#;

const ACCESSORS: &str = r#"[
    {"bufferView": 0, "componentType": 5126, "count": 6, "type": "VEC3", "min": [-1, 0, -1], "max": [1, 0, 1]},
    {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-0.25, 2, -0.25], "max": [0.25, 2, 0.25]},
    {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
    {"bufferView": 3, "componentType": 5126, "count": 6, "type": "VEC2"},
    {"bufferView": 4, "componentType": 5126, "count": 6, "type": "VEC3"},
    {"bufferView": 5, "componentType": 5125, "count": 6, "type": "SCALAR"},
    {"bufferView": 6, "componentType": 5121, "count": 6, "type": "SCALAR"},
    {"bufferView": 7, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]},
    {"bufferView": 8, "componentType": 5126, "count": 2, "type": "VEC3"},
    {"bufferView": 9, "componentType": 5126, "count": 2, "type": "VEC4"}
  ]"#;

/// glTF JSON documents: each body with its buffer as a data URI, as the external `buffer.bin`, and
/// without a URI (the GLB form).
fn gltf_scenes() -> Vec<String> {
    let buffer = gltf_buffer();
    let data_uri = format!(r#""uri": "data:application/octet-stream;base64,{}""#, base64::encode(&buffer));
    let doc = |uri: &str, body: &str| {
        let comma = if uri.is_empty() { "" } else { ", " };
        format!(
            r#"{{
  "asset": {{"version": "2.0"}},
  "buffers": [{{"byteLength": {len}{comma}{uri}}}],
  "bufferViews": {BUFFER_VIEWS},
  "accessors": {ACCESSORS},
{body}
}}"#,
            len = buffer.len()
        )
    };
    // Non-indexed ground + u16-indexed emissive quad + a camera.
    let basic = r#"  "scene": 0,
  "scenes": [{"nodes": [0, 1, 2]}],
  "nodes": [
    {"mesh": 0},
    {"mesh": 1},
    {"camera": 0, "translation": [0, 1, 5]}
  ],
  "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1, "aspectRatio": 1.5}}],
  "meshes": [
    {"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]},
    {"primitives": [{"attributes": {"POSITION": 1}, "indices": 2, "material": 1}]}
  ],
  "materials": [
    {"name": "grey", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}},
    {"name": "lamp", "emissiveFactor": [1, 0.5, 0.25]}
  ]"#;
    // Normals, texture coordinates and an external texture; u32 and u8 indices.
    let textured = r#"  "scene": 0,
  "scenes": [{"nodes": [0, 1]}],
  "nodes": [{"mesh": 0}, {"mesh": 1}],
  "meshes": [
    {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 4, "TEXCOORD_0": 3}, "material": 0, "mode": 4}]},
    {"primitives": [
      {"attributes": {"POSITION": 1}, "indices": 5, "material": 1},
      {"attributes": {"POSITION": 1}, "indices": 6, "material": 1}
    ]}
  ],
  "textures": [{"source": 0, "sampler": 0}],
  "samplers": [{"magFilter": 9728, "wrapS": 10497}],
  "images": [{"uri": "tex.png"}],
  "materials": [
    {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 1], "baseColorTexture": {"index": 0}, "roughnessFactor": 0.5}},
    {"name": "lamp", "emissiveFactor": [1, 1, 1]}
  ]"#;
    // A node hierarchy with every transform form, emissive strength and a punctual light.
    let hierarchy = r#"  "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_lights_punctual"],
  "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 10, "color": [1, 1, 1]}]}},
  "scene": 0,
  "scenes": [{"nodes": [0]}],
  "nodes": [
    {"children": [1, 2, 3], "rotation": [0, 0.3826834, 0, 0.9238795], "scale": [2, 2, 2]},
    {"mesh": 0, "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0.5,0,1]},
    {"mesh": 1, "translation": [0, 1, 0]},
    {"camera": 0, "translation": [0, 2, 6], "extensions": {"KHR_lights_punctual": {"light": 0}}}
  ],
  "cameras": [{"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.05, "zfar": 100}}],
  "meshes": [
    {"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]},
    {"primitives": [{"attributes": {"POSITION": 1}, "indices": 2, "material": 1}]}
  ],
  "materials": [
    {"name": "grey", "doubleSided": true},
    {"name": "lamp", "emissiveFactor": [1, 1, 1], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5}}}
  ]"#;
    // An animated parent (LINEAR translation) over a child (STEP rotation), and the light at rest;
    // the fuzz target loads at a shutter, so this reaches the motion code.
    let animated = r#"  "scene": 0,
  "scenes": [{"nodes": [0, 2, 3]}],
  "nodes": [
    {"name": "carrier", "children": [1]},
    {"name": "spinner", "mesh": 0, "translation": [0, 0.2, 0]},
    {"mesh": 1},
    {"camera": 0, "translation": [0, 1, 5]}
  ],
  "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1}}],
  "meshes": [
    {"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]},
    {"primitives": [{"attributes": {"POSITION": 1}, "indices": 2, "material": 1}]}
  ],
  "materials": [
    {"name": "grey", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]}},
    {"name": "lamp", "emissiveFactor": [1, 1, 1]}
  ],
  "animations": [{"name": "move", "channels": [
      {"sampler": 0, "target": {"node": 0, "path": "translation"}},
      {"sampler": 1, "target": {"node": 1, "path": "rotation"}}
    ],
    "samplers": [
      {"input": 7, "output": 8, "interpolation": "LINEAR"},
      {"input": 7, "output": 9, "interpolation": "STEP"}
    ]}]"#;
    let mut v = Vec::new();
    for body in [basic, textured, hierarchy, animated] {
        v.push(doc(&data_uri, body));
        v.push(doc(r#""uri": "buffer.bin""#, body));
    }
    // Without a URI, for GLB: the buffer is the BIN chunk; images still refer to tex.png.
    v.extend([basic, textured, hierarchy, animated].iter().map(|body| doc("", body)));
    v
}

/// Wrap a glTF JSON document in a GLB container: its first buffer (no URI) is the BIN chunk
/// holding [`gltf_buffer`]. A document whose buffer has a URI is not a valid GLB seed.
fn to_glb(json: &str) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    j.resize(j.len().next_multiple_of(4), b' ');
    let mut bin = gltf_buffer();
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + j.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

fn obj_scenes() -> Vec<Vec<u8>> {
    let mtl = "newmtl floor\nKd 0.8 0.8 0.8\nKs 0.2 0.2 0.2\nNs 50\nmap_Kd tex.png\n\n\
               newmtl lamp\nKd 0 0 0\nKe 4 4 4\nillum 2\nd 1.0\n";
    let objs = [
        // Textured quad + emissive quad, as in the scene tests.
        "mtllib scene.mtl\no floor\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         vn 0 1 0\nusemtl floor\nf 1/1/1 2/2/1 3/3/1 4/4/1\no lamp\nv -0.3 1.5 -0.3\nv 0.3 1.5 -0.3\n\
         v 0.3 1.5 0.3\nv -0.3 1.5 0.3\nusemtl lamp\nf 5 6 7 8\n",
        // Negative (relative) indices, v//vn faces, a pentagon, groups and smoothing.
        "mtllib scene.mtl\ng ground\ns 1\nv -2 0 2\nv 2 0 2\nv 2 0 -2\nv 0 0 -3\nv -2 0 -2\nvn 0 1 0\n\
         usemtl floor\nf -5//1 -4//1 -3//1 -2//1 -1//1\ng lamp\nv 0 2 0\nv 0.5 2 0\nv 0 2 0.5\n\
         usemtl lamp\nf -3 -1 -2\n",
        // No MTL: default material; triangles only.
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\n",
    ];
    let mut v: Vec<Vec<u8>> = objs
        .iter()
        .map(|o| {
            let mut b = o.as_bytes().to_vec();
            b.extend_from_slice(MTL_MARKER);
            b.extend_from_slice(mtl.as_bytes());
            b
        })
        .collect();
    v.push(objs[2].as_bytes().to_vec());
    v
}

fn exr_images() -> Vec<Vec<u8>> {
    use exr::prelude::{f16, Blocks, Compression, Encoding, LineOrder, SpecificChannels, Vec2, WritableImage};
    let (w, h) = (5usize, 3usize);
    let value = |x: usize, y: usize, c: usize| (x + 2 * y + c) as f32 * 0.25;
    let scan = |compression| Encoding { compression, blocks: Blocks::ScanLines, line_order: LineOrder::Increasing };
    let mut out = Vec::new();
    // The project's own writer first.
    let img = wedge::image::Image::from_fn(w as u32, h as u32, |x, y| {
        let (x, y) = (x as usize, y as usize);
        [value(x, y, 0), value(x, y, 1), value(x, y, 2)]
    });
    let dir = crate::targets::scratch_dir();
    let path = dir.join("seed.exr");
    wedge::image::write_exr(&path, &img).expect("writing a seed EXR to the scratch directory");
    out.push(std::fs::read(&path).expect("reading the seed EXR back"));
    let mut push =
        |bytes: Result<Vec<u8>, exr::error::Error>| out.push(bytes.expect("writing a small EXR in memory cannot fail"));

    for compression in [
        Compression::Uncompressed,
        Compression::RLE,
        Compression::ZIP1,
        Compression::ZIP16,
        Compression::PIZ,
        Compression::PXR24,
        Compression::B44,
    ] {
        let f32_rgb = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| (value(x, y, 0), value(x, y, 1), value(x, y, 2)));
        let image = exr::image::Image::from_encoded_channels((w, h), scan(compression), f32_rgb);
        let mut buf = Cursor::new(Vec::new());
        push(image.write().to_buffered(&mut buf).map(|_| buf.into_inner()));

        let f16_rgba = SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
            (
                f16::from_f32(value(x, y, 0)),
                f16::from_f32(value(x, y, 1)),
                f16::from_f32(value(x, y, 2)),
                f16::from_f32(1.0),
            )
        });
        let image = exr::image::Image::from_encoded_channels((w, h), scan(compression), f16_rgba);
        let mut buf = Cursor::new(Vec::new());
        push(image.write().to_buffered(&mut buf).map(|_| buf.into_inner()));
    }
    // Tiles.
    let tiles = Encoding {
        compression: Compression::ZIP1,
        blocks: Blocks::Tiles(Vec2(2, 2)),
        line_order: LineOrder::Increasing,
    };
    let rgb = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| (value(x, y, 0), value(x, y, 1), value(x, y, 2)));
    let image = exr::image::Image::from_encoded_channels((w, h), tiles, rgb);
    let mut buf = Cursor::new(Vec::new());
    push(image.write().to_buffered(&mut buf).map(|_| buf.into_inner()));
    out
}
