//! Hostile and broken scene inputs (issue 10): each must fail with a message naming the file, the place
//! (glTF JSON path, OBJ line, RON field) and the fix — or load with a warning — and never panic, hang or
//! allocate without bound. Files from `tests/data/bad/scene/` plus variants generated here.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use wedge_scene::bvh::{intersect_triangle, stack_need, tree_depth, STACK_SIZE};
use wedge_scene::*;

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("wedge-bad-scene-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/bad/scene").join(name)
}

fn load_file(path: &Path) -> Result<Scene, SceneError> {
    load(&SceneSource::File(path.to_path_buf()))
}

/// Load `path`, expect an error, check that its message names the file and holds every fragment.
fn fails(path: &Path, fragments: &[&str]) -> SceneError {
    let e = match load_file(path) {
        Err(e) => e,
        Ok(s) => panic!("{} should fail, loaded {} triangles", path.display(), s.triangle_count()),
    };
    let msg = e.to_string();
    let name = path.file_name().unwrap().to_string_lossy();
    assert!(msg.contains(&*name), "message should name {name}: {msg}");
    for f in fragments {
        assert!(msg.contains(f), "message should contain {f:?}: {msg}");
    }
    e
}

/// One triangle (0,0,0) (1,0,0) (0,1,0) with u16 indices: 36 bytes of positions, 6 of indices, 2 pad.
fn tri_buffer(p: [f32; 9], idx: [u16; 3]) -> Vec<u8> {
    let mut b: Vec<u8> = p.iter().flat_map(|x| x.to_le_bytes()).collect();
    b.extend(idx.iter().flat_map(|x| x.to_le_bytes()));
    b.extend([0, 0]);
    b
}

const TRI: [f32; 9] = [0., 0., 0., 1., 0., 0., 0., 1., 0.];

fn base_json(buf: &[u8]) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}},{{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}],
"materials":[{{"emissiveFactor":[0,0,0]}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"material":0}}]}}],
"nodes":[{{"mesh":0}}],
"scenes":[{{"nodes":[0]}}],"scene":0}}"#,
        buf.len(),
        base64::encode(buf)
    )
}

/// Write the base glTF with `edits` (substring replacements) applied; each edit must apply.
fn gltf_variant(dir: &Path, name: &str, buf: &[u8], edits: &[(&str, &str)]) -> PathBuf {
    let mut json = base_json(buf);
    for (from, to) in edits {
        assert!(json.contains(from), "edit {from:?} does not apply");
        json = json.replacen(from, to, 1);
    }
    let path = dir.join(name);
    std::fs::write(&path, json).unwrap();
    path
}

#[test]
fn base_gltf_loads() {
    let dir = temp_dir("base");
    let p = gltf_variant(&dir, "ok.gltf", &tri_buffer(TRI, [0, 1, 2]), &[]);
    let s = load_file(&p).unwrap();
    assert_eq!(s.triangle_count(), 1);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn the_four_gltf_crate_panics_are_errors() {
    fails(
        &data("position_index_out_of_range.gltf"),
        &["meshes[0].primitives[0].attributes.POSITION = 7", "3 accessors"],
    );
    fails(
        &data("stride_smaller_than_element.gltf"),
        &["bufferViews[0].byteStride is 4", "12-byte elements", "at least 12"],
    );
    fails(&data("indices_float.gltf"), &["meshes[0].primitives[0].indices must be SCALAR", "is SCALAR FLOAT"]);
    fails(&data("texcoord_unsigned_int.gltf"), &["attributes.TEXCOORD_0 must be VEC2", "VEC2 UNSIGNED_INT"]);
}

#[test]
fn gltf_node_graphs_must_be_trees() {
    fails(&data("node_cycle.gltf"), &["nodes[0].children[0] = 0 reaches nodes[0] a second time", "tree"]);
    let dir = temp_dir("nodes");
    let buf = tri_buffer(TRI, [0, 1, 2]);
    // A node with two parents (a DAG: each level doubling would instance a mesh 2^depth times).
    let p = gltf_variant(
        &dir,
        "two_parents.gltf",
        &buf,
        &[
            (r#""nodes":[{"mesh":0}]"#, r#""nodes":[{"mesh":0},{"children":[0]},{"children":[0]}]"#),
            (r#""scenes":[{"nodes":[0]}]"#, r#""scenes":[{"nodes":[1,2]}]"#),
        ],
    );
    fails(&p, &["nodes[2].children[0] = 0 reaches nodes[0] a second time"]);
    // Distinct nodes sharing a mesh are fine, but the instanced total is capped before reading.
    let big = 3 * ((limits::MAX_TRIANGLES as u64) / 2 + 1);
    let p = gltf_variant(
        &dir,
        "instanced.gltf",
        &buf,
        &[
            (r#""count":3,"type":"SCALAR""#, &format!(r#""count":{big},"type":"SCALAR""#)),
            (r#""nodes":[{"mesh":0}]"#, r#""nodes":[{"mesh":0},{"mesh":0}]"#),
            (r#""scenes":[{"nodes":[0]}]"#, r#""scenes":[{"nodes":[0,1]}]"#),
        ],
    );
    fails(&p, &["instances more than 67108864 triangles", "nodes[1]"]);
    let p = gltf_variant(
        &dir,
        "bad_child.gltf",
        &buf,
        &[(r#""nodes":[{"mesh":0}]"#, r#""nodes":[{"mesh":0,"children":[9]}]"#)],
    );
    fails(&p, &["nodes[0].children[0] = 9 but the file has 1 nodes"]);
}

#[test]
fn gltf_index_counts_are_checked() {
    let dir = temp_dir("indices");
    let buf = tri_buffer(TRI, [0, 1, 2]);
    let count = |n: &str| format!(r#""count":{n},"type":"SCALAR""#);
    let c = r#""count":3,"type":"SCALAR""#;
    let p = gltf_variant(&dir, "too_many.gltf", &buf, &[(c, &count("6"))]);
    fails(&p, &["accessors[1] (used as meshes[0].primitives[0].indices) needs 12 bytes", "byteLength 6"]);
    let p = gltf_variant(&dir, "zero.gltf", &buf, &[(c, &count("0"))]);
    fails(&p, &["meshes[0].primitives[0].indices) has count 0"]);
    let p = gltf_variant(&dir, "two.gltf", &buf, &[(c, &count("2"))]);
    fails(&p, &["meshes[0].primitives[0].indices: 2 indices is not a multiple of 3"]);
    let p = gltf_variant(&dir, "range.gltf", &tri_buffer(TRI, [0, 1, 5]), &[]);
    fails(&p, &["indices: index 5 at position 2 is out of range (POSITION has 3 vertices)"]);
    let p = gltf_variant(
        &dir,
        "view.gltf",
        &buf,
        &[(r#""byteOffset":36,"byteLength":6"#, r#""byteOffset":36,"byteLength":600"#)],
    );
    fails(&p, &["bufferViews[1] (byteOffset 36 + byteLength 600) runs past buffers[0].byteLength 44"]);
    let p = gltf_variant(&dir, "short.gltf", &buf, &[(r#""byteLength":44"#, r#""byteLength":100"#)]);
    fails(&p, &["buffers[0] declares byteLength 100 but its data has 44 bytes"]);
    let p = gltf_variant(
        &dir,
        "sparse.gltf",
        &buf,
        &[(
            r#""componentType":5126,"count":3,"type":"VEC3""#,
            r#""componentType":5126,"count":3,"type":"VEC3","sparse":{"count":1,"indices":{"bufferView":1,"componentType":5123},"values":{"bufferView":0}}"#,
        )],
    );
    fails(&p, &["accessors[0]", "sparse accessor"]);
}

#[test]
fn gltf_non_finite_and_overflowing_values_are_refused() {
    let dir = temp_dir("finite");
    let buf = tri_buffer(TRI, [0, 1, 2]);
    let mut nan = TRI;
    nan[4] = f32::NAN;
    let p = gltf_variant(&dir, "nan.gltf", &tri_buffer(nan, [0, 1, 2]), &[]);
    fails(&p, &["meshes[0].primitives[0].attributes.POSITION: element 1 (accessors[0]) is NaN or infinite"]);
    let p = gltf_variant(
        &dir,
        "strength.gltf",
        &buf,
        &[(
            r#""materials":[{"emissiveFactor":[0,0,0]}]"#,
            r#""materials":[{"emissiveFactor":[1,1,1],"extensions":{"KHR_materials_emissive_strength":{"emissiveStrength":3e38}}}]"#,
        )],
    );
    fails(&p, &["materials[0]: emissiveFactor", "more than the limit of 1e12", "emissiveStrength"]);
    let p = gltf_variant(
        &dir,
        "scale.gltf",
        &buf,
        &[(r#""nodes":[{"mesh":0}]"#, r#""nodes":[{"mesh":0,"scale":[1e38,1e38,1e38]}]"#)],
    );
    fails(&p, &["nodes[0] places meshes[0] vertices at", "beyond ±1e8"]);
    // 1e39 does not fit an f32: serde reads it as infinity.
    let p = gltf_variant(
        &dir,
        "translation.gltf",
        &buf,
        &[(r#""nodes":[{"mesh":0}]"#, r#""nodes":[{"mesh":0,"translation":[1e39,0,0]}]"#)],
    );
    fails(&p, &["nodes[0].translation", "not finite"]);
    let p = gltf_variant(
        &dir,
        "matrix.gltf",
        &buf,
        &[(r#""nodes":[{"mesh":0}]"#, r#""nodes":[{"mesh":0,"matrix":[1e39,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]"#)],
    );
    fails(&p, &["nodes[0].matrix", "not finite"]);
    let p = gltf_variant(
        &dir,
        "base_color.gltf",
        &buf,
        &[(
            r#""materials":[{"emissiveFactor":[0,0,0]}]"#,
            r#""materials":[{"pbrMetallicRoughness":{"baseColorFactor":[1,-1,1,1]}}]"#,
        )],
    );
    fails(&p, &["materials[0].pbrMetallicRoughness.baseColorFactor"]);
}

#[test]
fn gltf_camera_sanity() {
    fails(&data("camera_negative_yfov.gltf"), &["cameras[0].perspective.yfov is -0.5", "0 < yfov < π"]);
    let dir = temp_dir("camera");
    let buf = tri_buffer(TRI, [0, 1, 2]);
    let with_camera = |name: &str, perspective: &str, node: &str| {
        gltf_variant(
            &dir,
            name,
            &buf,
            &[
                (
                    r#""nodes":[{"mesh":0}]"#,
                    &format!(
                        r#""cameras":[{{"type":"perspective","perspective":{perspective}}}],"nodes":[{{"mesh":0}},{node}]"#
                    ),
                ),
                (r#""scenes":[{"nodes":[0]}]"#, r#""scenes":[{"nodes":[0,1]}]"#),
            ],
        )
    };
    let p = with_camera("wide.gltf", r#"{"yfov":3.2,"znear":0.1}"#, r#"{"camera":0,"translation":[0,0,3]}"#);
    fails(&p, &["cameras[0].perspective.yfov is 3.2"]);
    let p = with_camera(
        "aspect.gltf",
        r#"{"yfov":0.8,"aspectRatio":0,"znear":0.1}"#,
        r#"{"camera":0,"translation":[0,0,3]}"#,
    );
    fails(&p, &["cameras[0].perspective.aspectRatio is 0"]);
    let p = with_camera(
        "flat.gltf",
        r#"{"yfov":0.8,"znear":0.1}"#,
        r#"{"camera":0,"translation":[0,0,3],"scale":[0,0,0]}"#,
    );
    fails(&p, &["the camera of nodes[1]"]);
    let p = with_camera("good.gltf", r#"{"yfov":0.8,"znear":0.1}"#, r#"{"camera":0,"translation":[0.2,0.2,3]}"#);
    let s = load_file(&p).unwrap();
    assert!((s.camera.vfov_deg - 0.8f32.to_degrees()).abs() < 1e-4);
}

#[test]
fn ron_camera_sanity() {
    fails(
        &data("camera_look_at_position.ron"),
        &["camera: look_at [0, 1, 3] and position [0, 1, 3] give no view direction"],
    );
    fails(&data("camera_up_parallel.ron"), &["camera: up [0, 1, 0] is parallel to the view direction"]);
    fails(&data("camera_fov_180.ron"), &["camera: vfov_deg 180 is outside 0 < vfov_deg < 180"]);
    let dir = temp_dir("ron_nan");
    let p = dir.join("nan.ron");
    std::fs::write(
        &p,
        r#"Scene(builtin: Some("grids"), camera: Some((position: (0, 1, 3), look_at: (0, 0, 0), vfov_deg: NaN)))"#,
    )
    .unwrap();
    fails(&p, &["vfov_deg NaN is not finite"]);
}

#[test]
fn camera_validate_rules() {
    let ok = Camera::default();
    assert_eq!(ok.validate(), Ok(()));
    let bad = [
        Camera { vfov_deg: 0.0, ..ok },
        Camera { vfov_deg: 180.0, ..ok },
        Camera { vfov_deg: f32::NAN, ..ok },
        Camera { position: Vec3::new(f32::INFINITY, 0.0, 0.0), ..ok },
        Camera { look_at: ok.position, ..ok },
        Camera { up: Vec3::ZERO, ..ok },
        Camera { up: ok.look_at - ok.position, ..ok },
        Camera { aperture_radius: -1.0, ..ok },
        // Finite, but the difference overflows f32.
        Camera { position: Vec3::splat(-3e38), look_at: Vec3::splat(3e38), ..ok },
    ];
    for c in bad {
        assert!(c.validate().is_err(), "{c:?} should be refused");
    }
    assert_eq!(Camera { vfov_deg: 179.0, up: Vec3::new(0.0, 1.0, 0.01), ..ok }.validate(), Ok(()));
}

#[test]
fn resources_outside_the_scene_dir_are_refused_unless_allowed() {
    let p = data("outside/scene/buffer_outside.gltf");
    let e = fails(&p, &["buffers[0].uri = \"../outside.bin\"", "outside the scene directory", "--allow-outside-dir"]);
    assert!(matches!(e, SceneError::OutsideDir { .. }), "{e:?}");
    let allow = LoadOptions { allow_outside_dir: true };
    let s = load_with(&SceneSource::File(p), &allow).unwrap();
    assert_eq!((s.triangle_count(), s.lights.len()), (2, 1));

    let dir = temp_dir("outside");
    std::fs::create_dir_all(dir.join("scene")).unwrap();
    let buf = tri_buffer(TRI, [0, 1, 2]);
    std::fs::write(dir.join("secret.bin"), &buf).unwrap();
    // Absolute paths, file: URIs and symlinks that leave the directory are all caught.
    let abs = dir.join("secret.bin").display().to_string();
    for (name, uri) in [("abs.gltf", abs.clone()), ("file_uri.gltf", format!("file://{abs}"))] {
        let p = gltf_variant(&dir.join("scene"), name, &buf, &[("data:application/octet-stream;base64,", "")]);
        let json = std::fs::read_to_string(&p).unwrap().replace(&base64::encode(&buf), &uri);
        std::fs::write(&p, json).unwrap();
        let e = fails(&p, &["outside the scene directory"]);
        assert!(matches!(e, SceneError::OutsideDir { .. }));
    }
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(dir.join("secret.bin"), dir.join("scene/link.bin")).unwrap();
        let p = gltf_variant(&dir.join("scene"), "link.gltf", &buf, &[("data:application/octet-stream;base64,", "")]);
        let json = std::fs::read_to_string(&p).unwrap().replace(&base64::encode(&buf), "link.bin");
        std::fs::write(&p, json).unwrap();
        fails(&p, &["buffers[0].uri = \"link.bin\"", "outside the scene directory"]);
        let s = load_with(&SceneSource::File(p), &LoadOptions { allow_outside_dir: true }).unwrap();
        assert_eq!(s.triangle_count(), 1);
    }
    // A .ron scene's mesh path is checked the same way.
    std::fs::write(dir.join("mesh.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let ron = dir.join("scene/s.ron");
    std::fs::write(&ron, r#"Scene(meshes: [(path: "../mesh.obj")])"#).unwrap();
    fails(&ron, &["meshes[0].path = \"../mesh.obj\"", "outside the scene directory"]);
    // An OBJ's mtllib too.
    std::fs::write(dir.join("lib.mtl"), "newmtl a\nKd 1 1 1\n").unwrap();
    let obj = dir.join("scene/m.obj");
    std::fs::write(&obj, "mtllib ../lib.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n").unwrap();
    fails(&obj, &["mtllib ../lib.mtl", "outside the scene directory"]);
}

#[test]
fn missing_and_unreadable_files_name_the_file_and_the_referrer() {
    let dir = temp_dir("missing");
    let buf = tri_buffer(TRI, [0, 1, 2]);
    let p = gltf_variant(&dir, "nobin.gltf", &buf, &[("data:application/octet-stream;base64,", "")]);
    let json = std::fs::read_to_string(&p).unwrap().replace(&base64::encode(&buf), "gone.bin");
    std::fs::write(&p, json).unwrap();
    let e = load_file(&p).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, SceneError::Io { .. }), "{e:?}");
    for f in ["gone.bin", "nobin.gltf buffers[0].uri = \"gone.bin\"", "it does not exist"] {
        assert!(msg.contains(f), "{f:?} missing from {msg}");
    }
    // Percent-escapes that are not UTF-8 (urlencoding().unwrap() in the gltf crate panicked).
    let p = gltf_variant(&dir, "escape.gltf", &buf, &[("data:application/octet-stream;base64,", "")]);
    let json = std::fs::read_to_string(&p).unwrap().replace(&base64::encode(&buf), "%FF%FE.bin");
    std::fs::write(&p, json).unwrap();
    fails(&p, &["buffers[0].uri", "percent-escapes"]);

    let obj = dir.join("m.obj");
    std::fs::write(&obj, "mtllib nope.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let e = load_file(&obj).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, SceneError::Io { .. }), "{e:?}");
    for f in ["nope.mtl", "m.obj mtllib nope.mtl", "does not exist"] {
        assert!(msg.contains(f), "{f:?} missing from {msg}");
    }
    std::fs::write(dir.join("t.mtl"), "newmtl wood\nKd 1 1 1\nmap_Kd wood.png\n").unwrap();
    let obj = dir.join("t.obj");
    std::fs::write(&obj, "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl wood\nf 1 2 3\n").unwrap();
    let msg = load_file(&obj).unwrap_err().to_string();
    for f in ["wood.png", "material 'wood' map_Kd wood.png", "does not exist"] {
        assert!(msg.contains(f), "{f:?} missing from {msg}");
    }
    let e = load_file(&dir.join("absent.obj")).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }) && e.to_string().contains("does not exist"), "{e}");
    // Permission denied reads as such (tests often run as root, where chmod 000 does not deny, so the
    // message is checked on the error value).
    let e = SceneError::Io {
        path: obj.clone(),
        referenced_by: None,
        source: std::io::Error::from(std::io::ErrorKind::PermissionDenied),
    };
    let msg = e.to_string();
    assert!(msg.contains("permission denied") && msg.contains("chmod") && !msg.contains("not a valid"), "{msg}");
}

#[test]
fn obj_unknown_usemtl_is_a_warning_with_the_line() {
    let s = load_file(&data("usemtl_unknown.obj")).unwrap();
    assert_eq!((s.triangle_count(), s.lights.len()), (4, 1));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    let w = &s.warnings[0];
    for f in ["usemtl_unknown.obj:11: usemtl 'no_such_material'", "usemtl_unknown.mtl", "default"] {
        assert!(w.contains(f), "{f:?} missing from {w}");
    }
    let dir = temp_dir("mtl_nan");
    std::fs::write(dir.join("n.mtl"), "newmtl a\nKd nan 1 1\n").unwrap();
    let obj = dir.join("n.obj");
    std::fs::write(&obj, "mtllib n.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n").unwrap();
    fails(&obj, &["material 'a' in n.mtl has Kd"]);
    let obj = dir.join("vn.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 nan\nf 1//1 2//1 3//1\n").unwrap();
    fails(&obj, &["NaN or infinite normal"]);
    let obj = dir.join("vt.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/9 3/1\n").unwrap();
    fails(&obj, &["vt.obj", "texcoord index out of bounds"]);
}

/// A PNG claiming `w`×`h` pixels with an empty IDAT: enough for the header-based size check.
fn png_header(w: u32, h: u32) -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in bytes {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
            }
        }
        !c
    }
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(w.to_be_bytes());
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]); // 8-bit RGB
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    for chunk in [ihdr, b"IDAT".to_vec(), b"IEND".to_vec()] {
        png.extend((chunk.len() as u32 - 4).to_be_bytes());
        png.extend(&chunk);
        png.extend(crc32(&chunk).to_be_bytes());
    }
    png
}

#[test]
fn oversized_textures_are_refused_before_decoding() {
    let dir = temp_dir("texture");
    let buf = tri_buffer(TRI, [0, 1, 2]);
    let png = base64::encode(png_header(100_000, 100_000));
    let p = gltf_variant(
        &dir,
        "huge.gltf",
        &buf,
        &[(
            r#""materials":[{"emissiveFactor":[0,0,0]}]"#,
            &format!(
                r#""images":[{{"uri":"data:image/png;base64,{png}"}}],"textures":[{{"source":0}}],"materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}}]"#
            ),
        )],
    );
    fails(&p, &["images[0] is 100000x100000 pixels", "downscale"]);
    std::fs::write(dir.join("big.png"), png_header(20_000, 10)).unwrap();
    std::fs::write(dir.join("b.mtl"), "newmtl a\nmap_Kd big.png\n").unwrap();
    let obj = dir.join("b.obj");
    std::fs::write(&obj, "mtllib b.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n").unwrap();
    fails(&obj, &["map_Kd big.png", "20000x10 pixels"]);
}

fn shading() -> TriangleShading {
    TriangleShading { n: [Vec3::Z; 3], uv: [Vec2::ZERO; 3], material: 0, object: 0 }
}

fn build(name: &str, tris: Vec<[Vec3; 3]>) -> (Result<Scene, SceneError>, Duration) {
    let tris = tris.into_iter().map(|t| (t[0], t[1], t[2], shading())).collect();
    let t0 = Instant::now();
    let s =
        Scene::from_triangles(name, tris, vec![Material::diffuse("m", Vec3::splat(0.5))], vec![], Camera::default());
    (s, t0.elapsed())
}

#[test]
fn copies_of_one_triangle_are_deduplicated() {
    let (s, t) = build("copies", vec![[Vec3::ZERO, Vec3::X, Vec3::Y]; 200_000]);
    let s = s.unwrap();
    assert_eq!(s.triangle_count(), 1);
    assert_eq!(s.warnings.len(), 1);
    assert!(s.warnings[0].contains("dropped 199999 exact duplicate triangle(s) of 200000"), "{:?}", s.warnings);
    assert!(t < Duration::from_secs(10), "{t:?}");
    // Same vertices, other starting vertex: still the same triangle; reversed winding is kept.
    let (s, _) = build(
        "rotated",
        vec![[Vec3::ZERO, Vec3::X, Vec3::Y], [Vec3::X, Vec3::Y, Vec3::ZERO], [Vec3::ZERO, Vec3::Y, Vec3::X]],
    );
    let s = s.unwrap();
    assert_eq!(s.triangle_count(), 2);
    assert!(s.warnings[0].contains("dropped 1 exact duplicate"), "{:?}", s.warnings);
}

#[test]
fn zero_area_triangles_are_dropped_with_a_warning() {
    let mut tris = vec![[Vec3::ZERO, Vec3::X, Vec3::X * 2.0]; 1000];
    tris.push([Vec3::ZERO, Vec3::X, Vec3::Y]);
    let (s, _) = build("flat", tris);
    let s = s.unwrap();
    assert_eq!(s.triangle_count(), 1);
    assert!(s.warnings[0].contains("dropped 1000 zero-area triangle(s) of 1001"), "{:?}", s.warnings);
    let (s, _) = build("all_flat", vec![[Vec3::ZERO, Vec3::X, Vec3::X * 2.0]; 10]);
    assert!(s.unwrap_err().to_string().contains("all 10 triangles have zero area"));
}

/// Distinct triangles whose bounding boxes share one centre (`box`) or nest along one axis (`fan`):
/// PLOC pairs them one per pass (quadratic, a chain-shaped tree); the builder must notice and still
/// finish quickly with a shallow tree.
fn degenerate_centres(n: usize, kind: &str) -> Vec<[Vec3; 3]> {
    let mut seed = 7u64;
    let mut rnd = move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    };
    (0..n)
        .map(|_| match kind {
            "box" => [Vec3::splat(-1.0), Vec3::splat(1.0), Vec3::new(rnd(), rnd(), rnd())],
            _ => {
                let (a, r) = (3.0 * rnd(), 1.0 + 0.5 * rnd());
                let d = Vec3::new(a.cos(), a.sin(), 0.0) * r;
                [d, -d, Vec3::new(0.0, 0.0, r)]
            }
        })
        .collect()
}

#[test]
fn identical_centres_build_in_bounded_time() {
    for kind in ["box", "fan"] {
        let (s, t) = build(kind, degenerate_centres(200_000, kind));
        let s = s.unwrap();
        assert_eq!(s.triangle_count(), 200_000);
        assert!(stack_need(&s.bvh.nodes) <= STACK_SIZE, "{kind}: depth {}", tree_depth(&s.bvh.nodes));
        assert!(t < Duration::from_secs(20), "{kind}: {t:?}");
        // Still a correct BVH: closest hits agree with testing every triangle.
        for k in 0..16 {
            let a = k as f32 * 0.4;
            let o = Vec3::new(4.0 * a.cos(), 4.0 * a.sin(), 0.3 + 0.02 * k as f32);
            let d = -o + Vec3::new(0.1, -0.05, 0.2);
            let brute = s
                .triangles
                .iter()
                .filter_map(|t| intersect_triangle(t, o, d, 0.0, f32::INFINITY).map(|h| h.0))
                .fold(f32::INFINITY, f32::min);
            let got = s.intersect(o, d, 0.0, f32::INFINITY).map_or(f32::INFINITY, |h| h.t);
            assert_eq!(got, brute, "{kind} ray {k}");
            assert!(got.is_finite(), "{kind} ray {k} should hit");
        }
        println!("{kind}: 200k triangles with degenerate centres built in {t:?}, depth {}", tree_depth(&s.bvh.nodes));
    }
}

/// The issue's sizes: 1M triangles with one shared centre, nested along one axis, and 1M copies of
/// one triangle all build (about 0.7 s, 1.3 s and 0.1 s in release on 2 cores) into trees the
/// fixed traversal stack can walk. `--nocapture` prints the times.
#[test]
fn identical_centres_one_million() {
    for kind in ["box", "fan"] {
        let (s, t) = build(kind, degenerate_centres(1_000_000, kind));
        let s = s.unwrap();
        let (depth, need) = (tree_depth(&s.bvh.nodes), stack_need(&s.bvh.nodes));
        println!("{kind}: 1M triangles built in {t:?}, depth {depth}, stack need {need}");
        assert!(need <= STACK_SIZE, "{kind}: stack need {need}");
        assert_eq!(s.triangle_count(), 1_000_000);
    }
    let (s, t) = build("copies", vec![[Vec3::ZERO, Vec3::X, Vec3::Y]; 1_000_000]);
    let s = s.unwrap();
    println!("copies: 1M copies built in {t:?}: {:?}", s.warnings);
    assert_eq!(s.triangle_count(), 1);
}

/// The base triangle animated: node 0 (with the mesh) under node 1; buffer = triangle (36 bytes),
/// times (8), translations (24), rotations (32), three scales (36). Accessors: 0 positions, 1 times,
/// 2 translations (VEC3), 3 rotations (VEC4), 4 scales (VEC3 ×3).
fn animated_json(times: [f32; 2], rotations: [[f32; 4]; 2], scales: [[f32; 3]; 3]) -> String {
    let f = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let mut buf = f(&TRI);
    buf.extend(f(&times));
    buf.extend(f(&[0., 0., 0., 1., 0., 0.]));
    buf.extend(f(&rotations.concat()));
    buf.extend(f(&scales.concat()));
    format!(
        r#"{{"asset":{{"version":"2.0"}},
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":8}},
 {{"buffer":0,"byteOffset":44,"byteLength":24}},{{"buffer":0,"byteOffset":68,"byteLength":32}},{{"buffer":0,"byteOffset":100,"byteLength":36}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}},{{"bufferView":1,"componentType":5126,"count":2,"type":"SCALAR"}},
 {{"bufferView":2,"componentType":5126,"count":2,"type":"VEC3"}},{{"bufferView":3,"componentType":5126,"count":2,"type":"VEC4"}},
 {{"bufferView":4,"componentType":5126,"count":3,"type":"VEC3"}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"nodes":[{{"mesh":0}},{{"children":[0]}}],
"scenes":[{{"nodes":[1]}}],"scene":0,
"animations":[{{"channels":[{{"sampler":0,"target":{{"node":1,"path":"translation"}}}},{{"sampler":1,"target":{{"node":0,"path":"rotation"}}}}],
 "samplers":[{{"input":1,"output":2,"interpolation":"LINEAR"}},{{"input":1,"output":3,"interpolation":"STEP"}}]}}]}}"#,
        buf.len(),
        base64::encode(&buf)
    )
}

const UNIT_Q: [[f32; 4]; 2] = [[0., 0., 0., 1.], [0., 0.70710677, 0., 0.70710677]];
const ONES: [[f32; 3]; 3] = [[1., 1., 1.]; 3];

/// Write the animated glTF with `edits` applied (each must apply) and load it at shutter (0.2, 0.8).
fn animated(dir: &Path, name: &str, json: String, edits: &[(&str, &str)]) -> (PathBuf, Result<Scene, SceneError>) {
    let mut json = json;
    for (from, to) in edits {
        assert!(json.contains(from), "edit {from:?} does not apply");
        json = json.replacen(from, to, 1);
    }
    let path = dir.join(name);
    std::fs::write(&path, json).unwrap();
    let r = load_with_shutter(&SceneSource::File(path.clone()), &LoadOptions::default(), Some((0.2, 0.8)));
    (path, r)
}

/// Load must fail with a message naming the file and holding every fragment.
fn animated_fails(dir: &Path, name: &str, json: String, edits: &[(&str, &str)], fragments: &[&str]) {
    let (path, r) = animated(dir, name, json, edits);
    let msg = match r {
        Err(e) => e.to_string(),
        Ok(_) => panic!("{name} should fail"),
    };
    assert!(msg.contains(path.file_name().unwrap().to_str().unwrap()), "{msg}");
    for f in fragments {
        assert!(msg.contains(f), "{name}: message should contain {f:?}: {msg}");
    }
}

#[test]
fn gltf_animations_load_and_malformed_ones_are_located_errors() {
    let dir = temp_dir("animations");
    let ok = || animated_json([0.0, 1.0], UNIT_Q, ONES);
    let (_, r) = animated(&dir, "ok.gltf", ok(), &[]);
    let s = r.unwrap();
    assert!(s.has_motion() && s.warnings.is_empty(), "{:?}", s.warnings);

    let nan = |v: [f32; 2]| animated_json(v, UNIT_Q, ONES);
    animated_fails(
        &dir,
        "times.gltf",
        nan([0.5, 0.5]),
        &[],
        &[
            "animations[0].samplers[0].input (accessors[1]): keyframe time 1 (0.5) is not after time 0 (0.5)",
            "increase strictly",
        ],
    );
    animated_fails(
        &dir,
        "times_nan.gltf",
        nan([0.0, f32::NAN]),
        &[],
        &["animations[0].samplers[0].input: element 1 (accessors[1]) is NaN or infinite"],
    );
    let q = |a: [f32; 4]| animated_json([0.0, 1.0], [UNIT_Q[0], a], ONES);
    animated_fails(
        &dir,
        "nonunit.gltf",
        q([0., 0., 0., 2.]),
        &[],
        &["animations[0].samplers[1].output (accessors[3]): keyframe 1 rotation", "not a unit quaternion", "normalise"],
    );
    animated_fails(
        &dir,
        "qnan.gltf",
        q([0., f32::NAN, 0., 1.]),
        &[],
        &["animations[0].samplers[1].output: element 1 (accessors[3]) is NaN or infinite"],
    );
    type Case<'a> = (&'a str, &'a [(&'a str, &'a str)], &'a [&'a str]);
    let cases: &[Case] = &[
        ("count.gltf", &[(r#""count":2,"type":"VEC3""#, r#""count":1,"type":"VEC3""#)],
         &["animations[0].samplers[0].output (accessors[2]) has 1 values but animations[0].samplers[0].input has 2 keyframes", "one value per keyframe"]),
        ("cubic.gltf", &[(r#""interpolation":"LINEAR""#, r#""interpolation":"CUBICSPLINE""#)],
         &["has 2 values", "CUBICSPLINE needs 6", "in-tangent, value, out-tangent"]),
        ("node.gltf", &[(r#""node":1,"path":"translation""#, r#""node":7,"path":"translation""#)],
         &["animations[0].channels[0].target.node = 7 but the file has 2 nodes"]),
        ("sampler.gltf", &[(r#"{"sampler":1,"#, r#"{"sampler":5,"#)],
         &["animations[0].channels[1].sampler = 5 but the file has 2 samplers in animations[0]"]),
        ("accessor.gltf", &[(r#""input":1,"output":2"#, r#""input":9,"output":2"#)],
         &["animations[0].samplers[0].input = 9 but the file has 5 accessors"]),
        ("type.gltf", &[(r#""input":1,"output":2"#, r#""input":1,"output":3"#)],
         &["accessors[3] (used as animations[0].samplers[0].output) is VEC4 FLOAT", "must be VEC3"]),
        ("interp.gltf", &[(r#""interpolation":"STEP""#, r#""interpolation":"BOUNCY""#)],
         &["animations[0].samplers[1].interpolation is not LINEAR, STEP or CUBICSPLINE"]),
        ("path.gltf", &[(r#""path":"rotation""#, r#""path":"size""#)],
         &["animations[0].channels[1].target.path is not"]),
        ("matrix.gltf", &[(r#"{"children":[0]}"#, r#"{"children":[0],"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]}"#)],
         &["animations[0].channels[0] animates nodes[1].translation, but nodes[1] has a matrix"]),
        ("twice.gltf", &[(r#"{"sampler":1,"target":{"node":0,"path":"rotation"}}"#, r#"{"sampler":0,"target":{"node":1,"path":"translation"}}"#)],
         &["animations[0].channels[1] animates nodes[1].translation, which animations[0].channels[0] animates already"]),
    ];
    for (name, edits, fragments) in cases {
        animated_fails(&dir, name, ok(), edits, fragments);
    }
    // A scale that changes over the shutter (1 → 2 between 0 and 1 s, shutter 0.2–0.8).
    let growing = animated_json([0.0, 1.0], UNIT_Q, [[1., 1., 1.], [2., 2., 2.], [1., 1., 1.]]);
    animated_fails(
        &dir,
        "scale.gltf",
        growing,
        &[
            (
                r#"{"sampler":1,"target":{"node":0,"path":"rotation"}}"#,
                r#"{"sampler":2,"target":{"node":0,"path":"scale"}}"#,
            ),
            (
                r#""interpolation":"STEP"}"#,
                r#""interpolation":"STEP"},{"input":1,"output":4,"interpolation":"LINEAR"}"#,
            ),
            (r#""count":3,"type":"VEC3"}],"#, r#""count":2,"type":"VEC3"}],"#),
        ],
        &["nodes[0] (meshes[0]): its transform at shutter close is not a rigid motion", "constant scale"],
    );
    // Morph-target weights are skipped with a warning, not an error.
    let (_, r) = animated(&dir, "weights.gltf", ok(), &[(r#""path":"rotation""#, r#""path":"weights""#)]);
    let s = r.unwrap();
    assert!(s.warnings.iter().any(|w| w.contains("morph-target weights")), "{:?}", s.warnings);
}

#[test]
fn ron_motion_and_shutter_errors_are_located() {
    let dir = temp_dir("ron_motion");
    std::fs::write(dir.join("t.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let cases = [
        (
            "turn.ron",
            r#"Scene(meshes: [(path: "t.obj", motion: Some((rotate_deg: (0, 200))))])"#,
            "turns by more than 180°",
        ),
        (
            "axis.ron",
            r#"Scene(meshes: [(path: "t.obj", motion: Some((axis: (0, 0, 0), rotate_deg: (0, 20))))])"#,
            "axis [0, 0, 0] has no direction",
        ),
        (
            "nan.ron",
            r#"Scene(meshes: [(path: "t.obj", motion: Some((translation: ((0, 0, 0), (NaN, 0, 0)))))])"#,
            "is not finite",
        ),
        ("field.ron", r#"Scene(meshes: [(path: "t.obj", motion: Some((spin: 3)))])"#, "spin"),
        (
            "shutter.ron",
            r#"Scene(meshes: [(path: "t.obj")], camera: Some((position: (0, 1, 3), look_at: (0, 0, 0), vfov_deg: 40, shutter: (1, 0))))"#,
            "shutter_open 1 is after shutter_close 0",
        ),
    ];
    for (name, text, fragment) in cases {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        fails(&p, &[fragment]);
    }
}

/// Environment maps (issue 14): every broken map is a `SceneError` naming the file and the fix;
/// non-finite and negative texels are counted by kind and the map refused, never clamped.
#[test]
fn bad_environment_maps_are_refused_with_counts() {
    let dir = temp_dir("envmaps");
    let env_fails = |path: &Path, fragments: &[&str]| {
        let e = match EnvironmentMap::open(&path.display().to_string()) {
            Err(e) => e.to_string(),
            Ok(m) => panic!("{} should fail, loaded {}x{}", path.display(), m.width(), m.height()),
        };
        let name = path.file_name().unwrap().to_string_lossy();
        assert!(e.contains(&*name), "message should name {name}: {e}");
        for f in fragments {
            assert!(e.contains(f), "{name}: expected {f:?} in: {e}");
        }
        println!("{name}: {e}");
    };
    let write_exr = |name: &str, w: usize, h: usize, f: &(dyn Fn(usize, usize) -> [f32; 3] + Sync)| {
        let p = dir.join(name);
        exr::prelude::write_rgb_file(&p, w, h, |x, y| {
            let c = f(x, y);
            (c[0], c[1], c[2])
        })
        .unwrap();
        p
    };
    // A good one loads (EXR and HDR), in the documented orientation: row 0 is the zenith.
    let good = write_exr("good.exr", 16, 8, &|_, y| if y == 0 { [5.0; 3] } else { [0.5; 3] });
    let m = EnvironmentMap::open(&good.display().to_string()).unwrap();
    assert_eq!((m.width(), m.height()), (16, 8));
    assert_eq!(m.radiance(Vec3::Y), Vec3::splat(5.0));
    let hdr = dir.join("good.hdr");
    {
        let f = std::io::BufWriter::new(std::fs::File::create(&hdr).unwrap());
        let px: Vec<image::Rgb<f32>> =
            (0..32 * 16).map(|k| image::Rgb([if k < 32 { 4.0 } else { 0.25 }, 0.25, 0.25])).collect();
        image::codecs::hdr::HdrEncoder::new(f).encode(&px, 32, 16).unwrap();
    }
    let m = EnvironmentMap::open(&hdr.display().to_string()).unwrap();
    assert_eq!((m.width(), m.height()), (32, 16));
    assert_eq!(m.radiance(Vec3::Y).x, 4.0);

    // NaN / infinite / negative texels, counted.
    let bad = write_exr("nan.exr", 16, 8, &|x, y| match (x, y) {
        (0..=11, 0) => [f32::NAN, 1.0, 1.0],
        (0..=2, 1) => [1.0, f32::INFINITY, 1.0],
        (5, 5) => [1.0, 1.0, -0.5],
        _ => [1.0; 3],
    });
    env_fails(
        &bad,
        &[
            "12 NaN, 3 infinite, 1 negative texels",
            "first NaN at column 0, row 0",
            "first negative at column 5, row 5",
            "refused rather than clamped",
        ],
    );
    let neg = write_exr("negative.exr", 8, 4, &|x, _| if x == 3 { [-1.0, 0.0, 0.0] } else { [0.2; 3] });
    env_fails(&neg, &["0 NaN, 0 infinite, 4 negative texels"]);
    let huge = write_exr("huge.exr", 8, 4, &|x, _| if x == 1 { [1e30, 1.0, 1.0] } else { [0.2; 3] });
    env_fails(&huge, &["4 over the radiance limit"]);
    // Not 2:1.
    let square = write_exr("square.exr", 8, 8, &|_, _| [1.0; 3]);
    env_fails(&square, &["8x8", "not 2:1", "twice its height"]);
    let wide = write_exr("wide.exr", 24, 8, &|_, _| [1.0; 3]);
    env_fails(&wide, &["24x8", "not 2:1"]);
    // Not an image / unreadable / unsupported.
    let text = dir.join("text.exr");
    std::fs::write(&text, "this is not an image").unwrap();
    env_fails(&text, &["not a readable OpenEXR image", "magic number"]);
    let truncated = dir.join("truncated.exr");
    std::fs::write(&truncated, &std::fs::read(&good).unwrap()[..60]).unwrap();
    env_fails(&truncated, &["not a readable OpenEXR image"]);
    let text_hdr = dir.join("text.hdr");
    std::fs::write(&text_hdr, "#?RADIANCE\nnonsense").unwrap();
    env_fails(&text_hdr, &["not a readable Radiance HDR image"]);
    let png = dir.join("map.png");
    std::fs::write(&png, [0x89u8, b'P', b'N', b'G']).unwrap();
    env_fails(&png, &["not an environment map format", ".exr", ".hdr"]);
    env_fails(&dir.join("missing.exr"), &["cannot read", "does not exist"]);
    let folder = dir.join("folder.exr");
    std::fs::create_dir_all(&folder).unwrap();
    env_fails(&folder, &["cannot read", "directory"]);
    // Size caps before any texel is read or allocated.
    let e = EnvironmentMap::from_texels("big", 20_000, 10_000, Vec::new()).unwrap_err().to_string();
    assert!(e.contains("20000x10000") && e.contains("limit"), "{e}");
    let e = EnvironmentMap::from_texels("empty", 0, 0, Vec::new()).unwrap_err().to_string();
    assert!(e.contains("empty"), "{e}");
    let e = EnvironmentMap::from_texels("short", 4, 2, vec![[0.0; 3]; 7]).unwrap_err().to_string();
    assert!(e.contains("7 texels"), "{e}");
    let e = EnvironmentMap::open("builtin:moon").unwrap_err().to_string();
    assert!(e.contains("builtin:moon") && e.contains("builtin:sky"), "{e}");
}

#[test]
fn a_cubic_rotation_through_zero_names_the_channel_and_time() {
    // Keys q and -q (the same rotation) with zero tangents: the Hermite spline is (h00 - h01) q, the
    // zero quaternion at the segment's middle, which the shutter opens at (0.2 of 0..0.4).
    let dir = temp_dir("cubic_zero");
    let f = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let mut buf = f(&TRI);
    buf.extend(f(&[0.0, 0.4]));
    buf.extend(f(&[0., 0., 0., 0., 0., 0., 0., 1., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., -1., 0., 0., 0., 0.]));
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":8}},{{"buffer":0,"byteOffset":44,"byteLength":96}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}},{{"bufferView":1,"componentType":5126,"count":2,"type":"SCALAR"}},
 {{"bufferView":2,"componentType":5126,"count":6,"type":"VEC4"}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0,
"animations":[{{"channels":[{{"sampler":0,"target":{{"node":0,"path":"rotation"}}}}],
 "samplers":[{{"input":1,"output":2,"interpolation":"CUBICSPLINE"}}]}}]}}"#,
        buf.len(),
        base64::encode(&buf)
    );
    animated_fails(&dir, "through_zero.gltf", json, &[], &[
        "animations[0].channels[0]: the CUBICSPLINE rotation at time 0.2 (between keyframes 0 and 1) is the zero quaternion",
        "change the keyframes' tangents",
    ]);
}

#[test]
fn ron_scenes_that_include_scenes_and_unusable_scales_are_named() {
    let dir = temp_dir("ron_include");
    std::fs::write(dir.join("t.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let me = write("self.ron", r#"Scene(meshes: [(path: "self.ron")])"#);
    let e = fails(
        &me,
        &[
            r#"meshes[0].path = "self.ron" includes this scene file itself (self.ron → self.ron), an include cycle"#,
            "name a .gltf, .glb or .obj file",
        ],
    );
    assert!(!e.to_string().contains("unsupported scene format"), "{e}");
    let a = write("a.ron", r#"Scene(meshes: [(path: "t.obj"), (path: "b.ron")])"#);
    write("b.ron", r#"Scene(meshes: [(path: "a.ron")])"#);
    fails(&a, &[r#"meshes[1].path = "b.ron" includes another .ron scene (a.ron → b.ron); .ron scenes do not nest"#]);
    let tiny = write("tiny.ron", r#"Scene(meshes: [(path: "t.obj", scale: 1e-300)])"#);
    fails(
        &tiny,
        &[
            "mesh 0 ('t.obj') has scale = 1e-300, which is 0 in single precision",
            "use a non-zero scale of magnitude between",
        ],
    );
    let sub = write("sub.ron", r#"Scene(meshes: [(path: "t.obj", scale: -1e-40)])"#);
    fails(&sub, &["scale = -1e-40, which is subnormal"]);
}
