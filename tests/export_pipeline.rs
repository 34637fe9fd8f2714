//! `wedge export-scene` exports what the pipeline adds to its scene (src/export.rs, issue 33): the
//! environment map of an `Environment` node (written as environment.exr, exact, with its scale and
//! rotation and the same light as a Mitsuba 3 `envmap`), the pipeline's per-object motion as
//! keyframes at shutter open and close with the shutter interval, and the camera path; a
//! mixed-reality real layer is neither exported nor captured, and the output and scene.json say so.
//! Inputs are made by each test in a temp dir; the exported files are parsed back.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use glam::Vec3;
use serde_json::Value;
use wedge::image::{read_exr, write_exr, Image};
use wedge::{Overrides, Session};

fn wedge(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wedge")).args(args).current_dir(cwd).output().expect("wedge runs")
}

/// Export `pipeline` into `dir/out`; stdout and the parsed scene.json.
fn export(pipeline: &Path, dir: &Path) -> (String, Value) {
    let out = dir.join("out");
    let o = wedge(&["export-scene", pipeline.to_str().unwrap(), "--out", out.to_str().unwrap()], dir);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json =
        serde_json::from_str(&std::fs::read_to_string(out.join("scene.json")).unwrap()).expect("scene.json parses");
    (String::from_utf8_lossy(&o.stdout).into_owned(), json)
}

fn f(v: &Value) -> f32 {
    v.as_f64().unwrap_or_else(|| panic!("{v} is a number")) as f32
}

fn v3(v: &Value) -> Vec3 {
    Vec3::new(f(&v[0]), f(&v[1]), f(&v[2]))
}

/// A one-triangle OBJ object `bar` and a pipeline over it at `dir/p.ron` with an Environment node of
/// `env_params` and the top-level fields `extra`.
fn pipeline(dir: &Path, env_params: &str, extra: &str) -> PathBuf {
    std::fs::write(dir.join("bar.obj"), "o bar\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let text = format!(
        "Pipeline(scene: \"bar.obj\", width: 8, height: 6, {extra}\n nodes: [\n    (name: \"env\", kind: \"Environment\", params: {{{env_params}}}),\n    \
         (name: \"out\", kind: \"Output\", inputs: {{\"color\": \"env.radiance\"}}),\n])\n"
    );
    let path = dir.join("p.ron");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn the_environment_node_s_map_is_exported_exactly_with_scale_and_rotation() {
    let dir = tempfile::tempdir().unwrap();
    let sky = Image::from_fn(8, 4, |x, y| [0.25 * x as f32 + 0.5, 1.0 + y as f32, 3.0 - 0.125 * (x + y) as f32]);
    write_exr(&dir.path().join("sky.exr"), &sky).unwrap();
    let p = pipeline(dir.path(), "\"map\": \"sky.exr\", \"scale\": 2.5, \"rotation_deg\": 30", "");
    let (stdout, json) = export(&p, dir.path());
    assert!(stdout.contains("environment.exr"), "{stdout}");
    let env = &json["environment"];
    assert_eq!(
        (env["exr"].as_str(), env["width"].as_u64(), env["height"].as_u64()),
        (Some("environment.exr"), Some(8), Some(4))
    );
    assert_eq!((f(&env["scale"]), f(&env["rotation_deg"])), (2.5, 30.0));
    // Mitsuba's envmap has u = 0 at -Z where wedge has u = 0.5: half a turn more about +Y.
    let m = &env["mitsuba"];
    assert_eq!(
        (m["type"].as_str(), m["filename"].as_str(), f(&m["scale"])),
        (Some("envmap"), Some("environment.exr"), 2.5)
    );
    assert_eq!((v3(&m["to_world"]["rotate"]["axis"]), f(&m["to_world"]["rotate"]["angle"])), (Vec3::Y, 210.0));
    // Mitsuba 3's envmap looks a world direction d up at u = atan2(x, -z)/(2 pi), v = acos(y)/pi of
    // d in its local frame (to_world^-1 d): with the exported angle that is wedge's texel for d.
    let map = wedge::scene::EnvironmentMap::open(dir.path().join("sky.exr").to_str().unwrap())
        .unwrap()
        .with_params(2.5, 30.0)
        .unwrap();
    let to_local = glam::Quat::from_rotation_y(-f(&m["to_world"]["rotate"]["angle"]).to_radians());
    for k in 0..64 {
        let d = Vec3::new((k as f32 * 0.7).sin(), (k as f32 * 0.31).cos(), (k as f32 * 1.3).cos()).normalize();
        let l = to_local * d;
        let (u, v) = (
            (l.x.atan2(-l.z) / std::f32::consts::TAU).rem_euclid(1.0),
            l.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI,
        );
        let want = map.uv_of(d);
        let du = (u - want.x).abs();
        assert!(du.min(1.0 - du) < 1e-5 && (v - want.y).abs() < 1e-5, "{d}: mitsuba ({u}, {v}), wedge {want}");
    }
    // The texels as given (unscaled), bit for bit.
    let back = read_exr(&dir.path().join("out/environment.exr")).unwrap();
    assert_eq!((back.width, back.height), (8, 4));
    assert_eq!(back.pixels, sky.pixels);
    assert_eq!(json["not_exported"], Value::Array(vec![]));
}

#[test]
fn a_scene_without_an_environment_exports_none() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bar.obj"), "o bar\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let text =
        "Pipeline(scene: \"bar.obj\", width: 8, height: 6, nodes: [\n    (name: \"p\", kind: \"Primary\"),\n    \
                (name: \"out\", kind: \"Output\", inputs: {\"color\": \"p.albedo\"}),\n])\n";
    std::fs::write(dir.path().join("none.ron"), text).unwrap();
    let (_, json) = export(&dir.path().join("none.ron"), dir.path());
    assert_eq!(json["environment"], Value::Null);
    assert!(!dir.path().join("out/environment.exr").exists());
    assert_eq!(json["objects"][0]["motion"], Value::Null);
}

#[test]
fn pipeline_motion_is_exported_as_keyframes_at_shutter_open_and_close() {
    let dir = tempfile::tempdir().unwrap();
    let extra = "camera: Some((position: (0, 0.5, 4), look_at: (0, 0.5, 0), vfov_deg: 40, shutter: Some((2, 3)))),\n \
                 motion: [(object: \"bar\", translate: (0.6, 0, 0), rotate_deg: 90, axis: (0, 1, 0), pivot: Some((0, 0, 0)))],\n \
                 camera_path: [(frame: 0, position: (0, 0.5, 4), look_at: (0, 0.5, 0)), (frame: 9, position: (1, 0.5, 4), look_at: (0, 0.5, 0))],";
    let p = pipeline(dir.path(), "\"map\": \"builtin:sky\"", extra);
    let (_, json) = export(&p, dir.path());
    let camera = &json["camera"];
    assert_eq!((f(&camera["shutter_open"]), f(&camera["shutter_close"])), (2.0, 3.0));
    let path = json["camera_path"].as_array().unwrap();
    assert_eq!(
        (path.len(), path[1]["frame"].as_u64(), v3(&path[1]["position"])),
        (2, Some(9), Vec3::new(1.0, 0.5, 4.0))
    );

    // What wedge renders: the session's motion of `bar`.
    let s = Session::open(Some(&p), &Overrides::default()).unwrap();
    let motion = s.scene.objects[0].motion.expect("bar moves");
    let objects = json["objects"].as_array().unwrap();
    assert_eq!((objects.len(), objects[0]["name"].as_str()), (1, Some("bar")));
    let keys = objects[0]["motion"]["keyframes"].as_array().unwrap();
    assert_eq!(keys.len(), 2);
    let x = Vec3::new(1.0, 1.0, 0.5);
    for (key, (t, time)) in keys.iter().zip([(-1.0, 2.0), (1.0, 3.0)]) {
        assert_eq!((f(&key["t"]), f(&key["time"])), (t, time));
        let want = motion.prepare().at(t);
        assert_eq!(v3(&key["translation"]), want.translation);
        // to_world (row-major 4x4) moves a rest-pose point where wedge puts it at that time.
        let m = &key["to_world"];
        let row = |r: usize| Vec3::new(f(&m[r][0]), f(&m[r][1]), f(&m[r][2]));
        let moved = Vec3::new(row(0).dot(x) + f(&m[0][3]), row(1).dot(x) + f(&m[1][3]), row(2).dot(x) + f(&m[2][3]));
        assert!((moved - want.point(x)).length() < 1e-5, "t {t}: {moved} vs {}", want.point(x));
        assert_eq!(m[3], serde_json::json!([0, 0, 0, 1]));
    }
    // Open to close: 0.6 along x and a quarter turn about +Y.
    let (open, close) = (v3(&keys[0]["translation"]), v3(&keys[1]["translation"]));
    assert!(((close - open) - Vec3::new(0.6, 0.0, 0.0)).length() < 1e-6, "{open} {close}");
    let q = |k: &Value| glam::Quat::from_xyzw(f(&k[0]), f(&k[1]), f(&k[2]), f(&k[3]));
    let turn = q(&keys[1]["rotation_xyzw"]) * q(&keys[0]["rotation_xyzw"]).inverse();
    let (axis, angle) = turn.to_axis_angle();
    assert!((angle.to_degrees() - 90.0).abs() < 1e-3 && (axis - Vec3::Y).length() < 1e-4, "{axis} {angle}");
}

#[test]
fn a_mixed_reality_real_layer_is_neither_captured_nor_exported_and_that_is_said() {
    let dir = tempfile::tempdir().unwrap();
    // Neither a capture scene nor maps exist: reading or capturing either would fail the export.
    for (name, real) in [
        ("capture", "\"capture\": \"missing.obj\", \"capture_spp\": 65536"),
        ("maps", "\"camera_image\": \"c.exr\", \"position_map\": \"p.exr\", \"normal_map\": \"n.exr\""),
    ] {
        let text = format!(
            "Pipeline(scene: \"builtin:envmap_virtual\", width: 64, height: 48, nodes: [\n    (name: \"mr\", kind: \"MixedReality\", params: {{{real}}}),\n    \
             (name: \"out\", kind: \"Output\", inputs: {{\"color\": \"mr.radiance\"}}),\n])\n"
        );
        let p = dir.path().join(format!("{name}.ron"));
        std::fs::write(&p, text).unwrap();
        let (stdout, json) = export(&p, dir.path());
        let lost = json["not_exported"].as_array().unwrap();
        assert_eq!(lost.len(), 1, "{lost:?}");
        let lost = lost[0].as_str().unwrap();
        assert!(
            lost.starts_with("the mixed-reality real layer of node `mr`") && lost.contains("not a scene"),
            "{lost}"
        );
        assert!(stdout.contains(&format!("not exported: {lost}")), "{stdout}");
        // The virtual objects and their light are exported.
        assert_eq!(json["environment"]["exr"].as_str(), Some("environment.exr"));
        std::fs::remove_dir_all(dir.path().join("out")).unwrap();
    }
}

#[cfg(unix)]
#[test]
fn an_export_over_a_symlink_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = pipeline(dir.path(), "\"map\": \"builtin:sky\"", "");
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(dir.path().join("target.json"), "keep").unwrap();
    std::os::unix::fs::symlink(dir.path().join("target.json"), out.join("scene.json")).unwrap();
    let o = wedge(&["export-scene", p.to_str().unwrap(), "--out", out.to_str().unwrap()], dir.path());
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("scene.json"), "{e}");
    let left: Vec<_> = std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left, vec![std::ffi::OsString::from("scene.json")], "{e}");
    assert_eq!(std::fs::read_to_string(dir.path().join("target.json")).unwrap(), "keep");
}
