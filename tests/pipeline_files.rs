//! Files a pipeline names (its `scene`, an environment `map`, real-layer maps, a `capture` scene) are
//! confined to the pipeline file's directory, by the rule a scene's own files follow
//! (scene/src/resource.rs `Confinement`, issue 33): `../`, absolute paths and symlinks that leave it
//! are refused with the pipeline file, the line, the resolved path and the fix, unless
//! `--allow-outside-dir` (or its old name `--allow-outside-scene-dir`); `builtin:` names and
//! `--scene PATH` are not confined. Inputs are made by each test in a temp dir.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use wedge::image::{write_exr, Image};

fn wedge(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wedge")).args(args).current_dir(cwd).output().expect("wedge runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit code 1 with every needle in the message; the message.
fn refused(o: &Output, needles: &[&str]) -> String {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    for n in needles {
        assert!(e.contains(n), "`{n}` not in: {e}");
    }
    e
}

/// A temp dir holding `p/` (the pipeline's directory) and, outside it, `sky.exr` (a 2:1 lat-long map)
/// and `tri.obj` (one triangle); returns the dir, canonical.
fn layout() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let root = std::fs::canonicalize(dir.path()).unwrap();
    std::fs::create_dir(root.join("p")).unwrap();
    write_exr(&root.join("sky.exr"), &Image::from_fn(8, 4, |x, y| [0.1 * x as f32, 0.2 * y as f32, 0.5])).unwrap();
    std::fs::write(root.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    (dir, root)
}

/// A pipeline over `scene` whose node `env` is `node_params` of kind `kind`, written to `p/NAME`.
fn pipeline(root: &Path, name: &str, scene: &str, kind: &str, node_params: &str) -> PathBuf {
    let text = format!(
        "Pipeline(scene: {scene:?}, width: 8, height: 6, nodes: [\n    (name: \"env\", kind: \"{kind}\", params: {{{node_params}}}),\n    \
         (name: \"out\", kind: \"Output\", inputs: {{\"color\": \"env.radiance\"}}),\n])\n"
    );
    let path = root.join("p").join(name);
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn an_environment_map_outside_the_pipeline_dir_needs_the_flag() {
    let (_dir, root) = layout();
    let sky = root.join("sky.exr");
    let up = pipeline(&root, "up.ron", "builtin:envmap", "Environment", "\"map\": \"../sky.exr\"");
    let abs = pipeline(
        &root,
        "abs.ron",
        "builtin:envmap",
        "Environment",
        &format!("\"map\": {:?}", sky.display().to_string()),
    );
    std::os::unix::fs::symlink(&sky, root.join("p/link.exr")).unwrap();
    let link = pipeline(&root, "link.ron", "builtin:envmap", "Environment", "\"map\": \"link.exr\"");
    let out = root.join("out");
    for (p, written) in
        [(&up, "\"../sky.exr\""), (&abs, &format!("{:?}", sky.display().to_string())[..]), (&link, "\"link.exr\"")]
    {
        let o = wedge(&["render", p.to_str().unwrap(), "--out", out.to_str().unwrap()], &root);
        let e = refused(
            &o,
            &[
                &p.display().to_string(),
                &format!("line 2: node `env`, parameter `map` = {written} points to {}", sky.display()),
                &format!("outside the pipeline directory {}", root.join("p").display()),
                "move the file under that directory, or allow it with --allow-outside-dir",
            ],
        );
        assert!(!out.exists(), "nothing written: {e}");
    }
    // With the flag (new name or old) the map is read and the render runs.
    for flag in ["--allow-outside-dir", "--allow-outside-scene-dir"] {
        for p in [&up, &abs, &link] {
            let o = wedge(&["render", p.to_str().unwrap(), "--out", out.to_str().unwrap(), flag], &root);
            assert!(o.status.success(), "{flag} {}: {}", p.display(), stderr(&o));
        }
    }
    // Built-in maps and a map beside the pipeline need nothing.
    std::fs::copy(&sky, root.join("p/sky.exr")).unwrap();
    for map in ["builtin:sky", "sky.exr"] {
        let p = pipeline(&root, "inside.ron", "builtin:envmap", "Environment", &format!("\"map\": {map:?}"));
        let o = wedge(&["render", p.to_str().unwrap(), "--out", out.to_str().unwrap()], &root);
        assert!(o.status.success(), "{map}: {}", stderr(&o));
    }
}

#[test]
fn real_layer_maps_and_captures_outside_the_pipeline_dir_are_refused() {
    let (_dir, root) = layout();
    let sky = root.join("sky.exr").display().to_string();
    // Refused before anything is read: the maps need not be valid real-layer maps.
    let maps = format!("\"camera_image\": {sky:?}, \"position_map\": \"../sky.exr\", \"normal_map\": \"../sky.exr\"");
    let p = pipeline(&root, "maps.ron", "builtin:envmap_virtual", "MixedReality", &maps);
    let o = wedge(&["render", p.to_str().unwrap(), "--out", "out"], &root);
    refused(
        &o,
        &[
            &format!("line 2: node `env`, parameter `camera_image` = {sky:?} points to {sky}"),
            "outside the pipeline directory",
            "--allow-outside-dir",
        ],
    );
    // A frame sequence's file names say the frame they were made for.
    let framed = "\"camera_image\": \"../c_{frame:02}.exr\", \"position_map\": \"p.exr\", \"normal_map\": \"n.exr\"";
    std::fs::copy(root.join("sky.exr"), root.join("c_00.exr")).unwrap();
    let p = pipeline(&root, "framed.ron", "builtin:envmap_virtual", "MixedReality", framed);
    let o = wedge(&["render", p.to_str().unwrap(), "--out", "out"], &root);
    refused(
        &o,
        &[
            "parameter `camera_image` = \"../c_{frame:02}.exr\" (frame 0: \"../c_00.exr\")",
            "outside the pipeline directory",
        ],
    );
    let p = pipeline(&root, "capture.ron", "builtin:envmap_virtual", "MixedReality", "\"capture\": \"../tri.obj\"");
    let o = wedge(&["render", p.to_str().unwrap(), "--out", "out"], &root);
    refused(
        &o,
        &[
            &format!("parameter `capture` = \"../tri.obj\" points to {}", root.join("tri.obj").display()),
            "outside the pipeline directory",
        ],
    );
    assert!(!root.join("out").exists());
}

#[test]
fn the_pipeline_scene_is_confined_but_a_command_line_scene_is_not() {
    let (_dir, root) = layout();
    let p = pipeline(&root, "scene.ron", "../tri.obj", "Environment", "\"map\": \"builtin:sky\"");
    let out = root.join("out");
    let o = wedge(&["export-scene", p.to_str().unwrap(), "--out", out.to_str().unwrap()], &root);
    refused(
        &o,
        &[
            &format!("{}: line 1: scene = \"../tri.obj\" points to {}", p.display(), root.join("tri.obj").display()),
            "outside the pipeline directory",
        ],
    );
    assert!(!out.exists());
    for args in [&["--allow-outside-dir"][..], &["--scene", "tri.obj"][..]] {
        let mut all = vec!["export-scene", p.to_str().unwrap(), "--out", out.to_str().unwrap()];
        all.extend_from_slice(args);
        let o = wedge(&all, &root);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        assert!(String::from_utf8_lossy(&o.stdout).contains("(1 triangles, 0 lights, 0 textures)"), "{args:?}");
        std::fs::remove_dir_all(&out).unwrap();
    }
    // A scene that is not there is named with the pipeline line that names it.
    let p = pipeline(&root, "missing.ron", "nope.obj", "Environment", "\"map\": \"builtin:sky\"");
    let o = wedge(&["export-scene", p.to_str().unwrap(), "--out", out.to_str().unwrap()], &root);
    refused(
        &o,
        &[&format!(
            "cannot read the file referenced by {} line 1: scene = \"nope.obj\" (it does not exist)",
            p.display()
        )],
    );
    assert!(!out.exists());
}
