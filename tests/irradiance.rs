//! End to end: a receiver lit by an unoccluded rectangular light. The rendered radiance of every
//! pixel must match the closed-form polygon (Lambert) irradiance, `ρ E / π`, within 1% — through
//! the whole pipeline (scene file → Primary → light sampling → compose), for the plain Monte Carlo
//! estimator and for SoftShadows (whose unoccluded pixels are not filtered).

mod common;

use std::path::Path;

use common::*;
use wedge::graph::parse_pipeline;
use wedge::scene::{load, SceneSource};
use wedge::Session;

const ALBEDO: f32 = 0.5;

/// A 4×4 m floor (OBJ, albedo 0.5) under a tilted 0.8×0.5 m light, camera looking down.
fn write_scene(dir: &Path) -> std::path::PathBuf {
    std::fs::write(
        dir.join("floor.obj"),
        "mtllib floor.mtl\nv -2 0 -2\nv 2 0 -2\nv 2 0 2\nv -2 0 2\nvn 0 1 0\nusemtl grey\nf 1//1 3//1 2//1\nf 1//1 4//1 3//1\n",
    )
    .unwrap();
    std::fs::write(dir.join("floor.mtl"), format!("newmtl grey\nKd {ALBEDO} {ALBEDO} {ALBEDO}\n")).unwrap();
    let scene = dir.join("lit.ron");
    std::fs::write(
        &scene,
        r#"Scene(
    meshes: [(path: "floor.obj")],
    lights: [Rect(corner: (-0.4, 1.5, -0.25), edge_u: (0.8, 0.0, 0.0), edge_v: (0.0, -0.2, 0.458), radiance: (4, 4, 4))],
    camera: Some((position: (0, 1.2, 2.6), look_at: (0, 0, 0), vfov_deg: 50)),
)"#,
    )
    .unwrap();
    scene
}

fn pipeline(scene: &Path, node: &str) -> String {
    format!(
        r#"Pipeline(scene: {scene:?}, width: 48, height: 36, seed: 3, nodes: [
    (name: "primary", kind: "Primary"),
    {node},
    (name: "out", kind: "Output", inputs: {{"color": "fx.radiance"}}),
])"#
    )
}

fn check(node: &str) {
    let dir = tempfile::tempdir().unwrap();
    let scene_path = write_scene(dir.path());
    let text = pipeline(&scene_path, node);
    let loaded = parse_pipeline(&dir.path().join("p.ron"), &text).unwrap();
    let (nodes, kernels) = wedge::effects::builtin();
    let session = Session::build(loaded, &Default::default(), nodes, kernels).unwrap();
    let result = run(&session);
    let img = color(&session, &result);
    let scene = load(&SceneSource::File(scene_path)).unwrap();
    let light = &scene.lights[0];
    let (w, h) = (session.width, session.height);
    let mut checked = 0;
    let mut worst = 0.0f32;
    for y in 0..h {
        for x in 0..w {
            let (o, d) = scene.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h, glam::Vec2::splat(0.5));
            let Some(hit) = scene.intersect(o, d, 0.0, f32::INFINITY) else { continue };
            if scene.light_of_triangle(hit.triangle).is_some() {
                continue;
            }
            let sp = scene.surface(&hit, o, d);
            let expected =
                ALBEDO * light.irradiance_unoccluded(sp.position, sp.shading_normal).x / std::f32::consts::PI;
            if expected < 1e-3 {
                continue;
            }
            let got = img.get(x, y)[0];
            let rel = (got - expected).abs() / expected;
            worst = worst.max(rel);
            checked += 1;
        }
    }
    assert!(checked > (w * h / 2) as usize, "only {checked} floor pixels");
    assert!(worst < 0.01, "{node}: worst relative error {worst} over {checked} pixels");
}

#[test]
fn monte_carlo_matches_the_polygon_formula() {
    check(
        r#"(name: "fx", kind: "MonteCarlo", params: {"spp": 4096, "sampling": "stratified"},
           inputs: {"position": "primary.position", "normal": "primary.normal", "albedo": "primary.albedo"})"#,
    );
}

#[test]
fn soft_shadows_unoccluded_matches_the_polygon_formula() {
    // No occluders: no pixel has occluder statistics, none is filtered; with initial_rays = 1024
    // stratified samples every pixel is within 1%.
    check(
        r#"(name: "fx", kind: "SoftShadows", params: {"initial_rays": 1024},
           inputs: {"position": "primary.position", "normal": "primary.normal", "albedo": "primary.albedo"})"#,
    );
}
