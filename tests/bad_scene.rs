//! Broken and hostile scene files through the `wedge` command line (issue 10): each is refused with
//! exit code 1 (never 101, a panic) and a message naming the file, the place and the fix; an outside
//! resource is refused unless `--allow-outside-dir`; an unknown `usemtl` renders with a warning.
//! Inputs are in `tests/data/bad/scene/` (see its README).

use std::path::Path;
use std::process::{Command, Output};

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A tiny, fast render of `scene` (16×12, one light sample per pixel).
fn render(scene: &str, extra: &[&str]) -> Output {
    let out = tempfile::tempdir().unwrap();
    let scene = repo().join("tests/data/bad/scene").join(scene);
    let mut args = vec!["reference", "--spp", "1", "--width", "16", "--height", "12", "--scene"];
    args.push(scene.to_str().unwrap());
    args.extend(["--out", out.path().to_str().unwrap()]);
    args.extend(extra);
    Command::new(env!("CARGO_BIN_EXE_wedge")).args(&args).current_dir(repo()).output().expect("wedge runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit code 1 and every fragment in stderr (which must also name the scene file).
fn refused(scene: &str, fragments: &[&str]) {
    let o = render(scene, &[]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{scene}: expected exit 1: {err}");
    assert!(!err.contains("panicked"), "{scene}: {err}");
    let name = Path::new(scene).file_name().unwrap().to_str().unwrap();
    assert!(err.contains(name), "{scene}: should name the file: {err}");
    for f in fragments {
        assert!(err.contains(f), "{scene}: stderr should contain {f:?}: {err}");
    }
}

#[test]
fn gltf_inputs_that_panicked_the_gltf_crate_exit_1() {
    refused(
        "position_index_out_of_range.gltf",
        &["meshes[0].primitives[0].attributes.POSITION = 7 but the file has 3 accessors"],
    );
    refused("stride_smaller_than_element.gltf", &["bufferViews[0].byteStride is 4", "set byteStride to at least 12"]);
    refused("indices_float.gltf", &["meshes[0].primitives[0].indices must be SCALAR of UNSIGNED_BYTE"]);
    refused("texcoord_unsigned_int.gltf", &["attributes.TEXCOORD_0 must be VEC2 of FLOAT"]);
}

#[test]
fn gltf_node_cycle_exits_1() {
    refused(
        "node_cycle.gltf",
        &["nodes[0].children[0] = 0 reaches nodes[0] a second time", "make the node hierarchy a tree"],
    );
}

#[test]
fn degenerate_scene_cameras_exit_1() {
    refused("camera_negative_yfov.gltf", &["cameras[0].perspective.yfov is -0.5 radians", "0 < yfov < π"]);
    refused(
        "camera_look_at_position.ron",
        &["camera: look_at [0, 1, 3] and position [0, 1, 3] give no view direction"],
    );
    refused("camera_up_parallel.ron", &["camera: up [0, 1, 0] is parallel to the view direction"]);
    refused("camera_fov_180.ron", &["camera: vfov_deg 180 is outside 0 < vfov_deg < 180"]);
}

#[test]
fn resources_outside_the_scene_dir_need_the_flag() {
    refused(
        "outside/scene/buffer_outside.gltf",
        &["buffers[0].uri = \"../outside.bin\"", "outside the scene directory", "--allow-outside-dir"],
    );
    // The flag's name before it covered pipelines too still works (a hidden alias).
    for flag in ["--allow-outside-dir", "--allow-outside-scene-dir"] {
        let o = render("outside/scene/buffer_outside.gltf", &[flag]);
        assert!(o.status.success(), "{flag}: {}", stderr(&o));
        assert!(stderr(&o).contains("(2 triangles, 1 lights)"), "{flag}: {}", stderr(&o));
    }
}

#[test]
fn unknown_usemtl_renders_with_a_warning() {
    let o = render("usemtl_unknown.obj", &[]);
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("(4 triangles, 1 lights)"), "{err}");
    assert!(err.contains("warning: "), "{err}");
    assert!(err.contains("usemtl_unknown.obj:11: usemtl 'no_such_material' is not defined"), "{err}");
}

#[test]
fn a_scene_without_lights_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("dark.obj");
    std::fs::write(&obj, "v -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 3 2\n").unwrap();
    let out = dir.path().join("out");
    // The default pipeline filters the shadows of light 0.
    let o = Command::new(env!("CARGO_BIN_EXE_wedge"))
        .args([
            "render",
            "--width",
            "16",
            "--height",
            "12",
            "--scene",
            obj.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .current_dir(repo())
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    // Refused as the pipeline is checked against the scene, with the node and its position, before
    // anything renders (graph/src/terms.rs `check_lights_exist`).
    assert!(
        err.contains(
            "error[missing-light]: node `shadows` (SoftShadows) renders area light 0, but the scene has no area light"
        ),
        "{err}"
    );
    assert!(err.contains("add an emissive material"), "{err}");
    assert!(!err.contains("pick 0.."), "{err}");
}

/// A node that renders an area light the scene lacks is refused by `wedge graph` and `wedge render`
/// alike, with the node's position in the file, before a pass runs: the light index out of range,
/// and a shipped pipeline with a SoftShadows node on a scene lit by its map alone (the environment
/// suite's scenes) — which `wedge bench --suite` then refuses before its first scene renders.
#[test]
fn a_node_rendering_a_light_the_scene_lacks_is_refused_up_front() {
    let out = tempfile::tempdir().unwrap();
    let wedge =
        |args: &[&str]| Command::new(env!("CARGO_BIN_EXE_wedge")).args(args).current_dir(repo()).output().unwrap();
    let dir = out.path().join("img").to_string_lossy().into_owned();
    let err = stderr(&wedge(&[
        "render",
        "pipelines/shadows.ron",
        "--scene",
        "grids",
        "--set",
        "shadows.light=2",
        "--out",
        &dir,
    ]));
    assert!(
        err.contains("pipelines/shadows.ron:11:19: error[missing-light]: node `shadows` (SoftShadows) renders area light 2, but the scene has 1 area light(s): 0..0"),
        "{err}"
    );
    for command in ["graph", "render"] {
        let mut args = vec![command, "pipelines/environment_shadows.ron", "--scene", "builtin:env_sun"];
        if command == "render" {
            args.extend(["--out", &dir]);
        }
        let err = stderr(&wedge(&args));
        let what =
            "error[missing-light]: node `shadows` (SoftShadows) renders area light 0, but the scene has no area light";
        assert!(err.contains(what), "{command}: {err}");
    }
    assert!(!out.path().join("img").exists(), "nothing written");
}

/// A pipeline that samples every light (`MonteCarlo` with `light: -1`, `Indirect`'s next-event
/// estimation) renders a light-less scene, and its reference too, but both warn that direct and
/// indirect light are black instead of exiting 0 in silence. A reference is the pipeline's own graph,
/// so the default pipeline's SoftShadows (`light: 0`) refuses the scene in `reference` exactly as in
/// `render`.
#[test]
fn sampling_every_light_of_a_scene_without_lights_warns() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("dark.obj");
    std::fs::write(&obj, "v -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 3 2\n").unwrap();
    let out = dir.path().join("out");
    let run = |pipeline: Option<&str>| {
        Command::new(env!("CARGO_BIN_EXE_wedge"))
            .arg("reference")
            .args(pipeline)
            .args(["--spp", "4", "--width", "16", "--height", "12", "--scene", obj.to_str().unwrap()])
            .args(["--out", out.to_str().unwrap()])
            .current_dir(repo())
            .output()
            .unwrap()
    };
    let o = run(Some("pipelines/indirect.ron"));
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        err.contains("has no area light (no emissive triangles) and no environment map: light sampling adds nothing"),
        "{err}"
    );
    let o = run(None);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    // The reference is the pipeline's own graph, checked against the scene as a render's is.
    assert!(err.contains("error[missing-light]") && err.contains("add an emissive material"), "{err}");
}
