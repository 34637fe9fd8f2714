//! The `Environment` node end to end (thesis Ch. 6; `effects/src/environment/`, `docs/DESIGN-NOTES.md`
//! "The Environment node"): the furnace and white-furnace tests against their analytic radiance,
//! convergence to Monte Carlo as μ grows (with adaptive look-ups), temporal filtering on a still and
//! a moving camera, composition with an area light's SoftShadows, and bad map input.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use wedge::backends::cpu::CpuBackend;
use wedge::backends::{RunResult, Silent};
use wedge::graph::parse_pipeline;
use wedge::image::{write_exr, Image};
use wedge::outputs::buffer_to_image;
use wedge::{Overrides, Session};

const W: u32 = 48;
const H: u32 = 48;

/// A smooth UV sphere of radius 1 at the origin with diffuse albedo `albedo` (OBJ + MTL in `dir`).
fn sphere_obj(dir: &Path, albedo: f32) -> PathBuf {
    let (rings, segments) = (48, 96);
    let mut obj = String::from("mtllib sphere.mtl\nusemtl white\n");
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = 2.0 * std::f32::consts::PI * s as f32 / segments as f32;
            let (x, y, z) = (theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            obj.push_str(&format!("v {x} {y} {z}\nvn {x} {y} {z}\n"));
        }
    }
    let at = |r: u32, s: u32| r * (segments + 1) + s + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (at(r, s), at(r + 1, s), at(r + 1, s + 1), at(r, s + 1));
            // Counter-clockwise seen from outside.
            obj.push_str(&format!("f {a}//{a} {d}//{d} {c}//{c}\nf {a}//{a} {c}//{c} {b}//{b}\n"));
        }
    }
    std::fs::write(dir.join("sphere.mtl"), format!("newmtl white\nKd {albedo} {albedo} {albedo}\n")).unwrap();
    let path = dir.join("sphere.obj");
    std::fs::write(&path, obj).unwrap();
    path
}

/// A constant lat-long map of radiance `value` (EXR, 2:1).
fn constant_map(dir: &Path, value: f32) -> PathBuf {
    let path = dir.join("constant.exr");
    write_exr(&path, &Image::from_fn(64, 32, |_, _| [value; 3])).unwrap();
    path
}

/// An Environment node on `scene` with `params`, camera 4 m in front of the origin.
fn furnace(scene: &Path, map: &Path, params: &str) -> String {
    format!(
        r#"Pipeline(scene: "{}", width: {W}, height: {H}, seed: 5,
            camera: Some((position: (0, 0, 4), look_at: (0, 0, 0), vfov_deg: 40)),
            nodes: [
                (name: "env", kind: "Environment", params: {{"map": "{}", {params}}}),
                (name: "out", kind: "Output", inputs: {{"color": "env.radiance", "unfiltered": "env.unfiltered", "rays_per_pixel": "env.rays_per_pixel"}}),
            ])"#,
        scene.display(),
        map.display()
    )
}

/// Overrides for the pipelines given as text: their scene and map files lie in a temp dir, outside
/// the directory of the text's nominal path `test.ron`, which confines a pipeline's files.
fn text_overrides() -> Overrides {
    Overrides { allow_outside_dir: true, ..Overrides::default() }
}

fn reference(text: &str, spp: u32) -> Image {
    let loaded = parse_pipeline(Path::new("test.ron"), text).expect("pipeline parses");
    let (nodes, kernels) = wedge::effects::builtin();
    let s = Session::build_reference(loaded, &text_overrides(), nodes, kernels, spp, "stratified")
        .expect("reference builds");
    color(&s, &run(&s))
}

fn output(s: &Session, r: &RunResult, name: &str) -> Image {
    buffer_to_image(r.output(name).expect("output"), s.width, s.height)
}

/// Pixels whose centre ray meets the unit sphere at least `margin` inside its silhouette (camera at
/// z = 4, 40° field of view): they see only the sphere, whatever the jitter.
fn sphere_pixels(margin: f32) -> Vec<(u32, u32)> {
    let cam = wedge::scene::Camera {
        position: glam::Vec3::new(0.0, 0.0, 4.0),
        look_at: glam::Vec3::ZERO,
        up: glam::Vec3::Y,
        vfov_deg: 40.0,
        aperture_radius: 0.0,
        focus_distance: 4.0,
        shutter_open: 0.0,
        shutter_close: 0.0,
    };
    let mut out = Vec::new();
    for y in 0..H {
        for x in 0..W {
            let (o, d) = cam.generate_ray(x as f32 + 0.5, y as f32 + 0.5, W, H, glam::Vec2::splat(0.5));
            // Distance from the centre to the ray.
            let closest = (o + d * (-o.dot(d))).length();
            if closest < 1.0 - margin {
                out.push((x, y));
            }
        }
    }
    out
}

/// Mean and largest deviation from `expected` of `img` over `pixels` (luminance-free: every channel).
fn deviation(img: &Image, pixels: &[(u32, u32)], expected: f32) -> (f64, f64) {
    let (mut sum, mut worst) = (0.0f64, 0.0f64);
    for &(x, y) in pixels {
        let p = img.get(x, y);
        for c in p {
            sum += c as f64;
            worst = worst.max((c - expected).abs() as f64);
        }
    }
    (sum / (3 * pixels.len()) as f64, worst)
}

#[test]
fn a_constant_environment_lights_a_diffuse_sphere_analytically() {
    // L = 2 from every direction on a convex diffuse sphere of albedo 0.5: every point receives
    // irradiance πL and sends (0.5/π)·πL = 1, with no occlusion. The table's quadrature of a
    // constant map is exact to 1.6e-4 (scene/tests/environment.rs), so the filtered image and the
    // Monte Carlo reference must both give 1.
    let dir = tempfile::tempdir().unwrap();
    let text = furnace(&sphere_obj(dir.path(), 0.5), &constant_map(dir.path(), 2.0), r#""per_primary": 16"#);
    let s = session_from_text(&text, &text_overrides());
    let r = run(&s);
    let inside = sphere_pixels(0.05);
    assert!(inside.len() > 500, "{}", inside.len());
    let (mean, worst) = deviation(&output(&s, &r, "color"), &inside, 1.0);
    let (mean_u, worst_u) = deviation(&output(&s, &r, "unfiltered"), &inside, 1.0);
    println!("furnace: filtered mean {mean:.5} worst {worst:.4}; unfiltered mean {mean_u:.5} worst {worst_u:.4}");
    assert!((mean - 1.0).abs() < 5e-3, "{mean}");
    assert!(worst < 0.05, "{worst}");
    // The filter removes most of the noise of 64 look-ups (unfiltered worst pixel much further off).
    assert!(worst < 0.5 * worst_u, "{worst} vs {worst_u}");
    let (mean_ref, worst_ref) = deviation(&reference(&text, 256), &inside, 1.0);
    println!("furnace reference 256 spp: mean {mean_ref:.5} worst {worst_ref:.4}");
    assert!((mean_ref - 1.0).abs() < 5e-3, "{mean_ref}");
    // Camera rays that miss see the map itself: its radiance exactly.
    let c = output(&s, &r, "color").get(0, 0);
    assert_eq!(c, [2.0; 3]);
}

#[test]
fn a_white_furnace_converges_to_the_map() {
    // Albedo 1 and L = 1: the sphere disappears into the map. With the indirect part on (a convex
    // object has no reflector, so its indirect light is 0) the sum is still 1.
    let dir = tempfile::tempdir().unwrap();
    let text =
        furnace(&sphere_obj(dir.path(), 1.0), &constant_map(dir.path(), 1.0), r#""per_primary": 16, "indirect": true"#);
    let s = session_from_text(&text, &text_overrides());
    let r = run(&s);
    let inside = sphere_pixels(0.05);
    let (mean, worst) = deviation(&output(&s, &r, "color"), &inside, 1.0);
    println!("white furnace: filtered mean {mean:.5} worst {worst:.4}");
    assert!((mean - 1.0).abs() < 5e-3, "{mean}");
    assert!(worst < 0.05, "{worst}");
    let (mean_ref, _) = deviation(&reference(&text, 512), &inside, 1.0);
    assert!((mean_ref - 1.0).abs() < 3e-3, "{mean_ref}");
}

/// `pipelines/environment.ron`'s node on `envmap` at 64×48 with extra parameters.
fn envmap(params: &str, extra: &str) -> String {
    format!(
        r#"Pipeline(scene: "builtin:envmap", width: 64, height: 48, seed: 2, {extra} nodes: [
            (name: "env", kind: "Environment", params: {{{params}}}),
            (name: "out", kind: "Output", inputs: {{"color": "env.radiance", "unfiltered": "env.unfiltered", "rays_per_pixel": "env.rays_per_pixel"}}),
        ])"#
    )
}

#[test]
fn the_filter_converges_to_monte_carlo_as_mu_grows() {
    // μ scales every bandwidth (the extension): the filtered image approaches its own unfiltered
    // Monte Carlo estimate, and where the look-ups are adaptive the rays grow as the filters shrink —
    // at every receiver (`all`), and at the glossy ones alone (`glossy`, the default: `envmap`'s torus is glossy, its
    // ground and sphere diffuse) — and never under `off` (the thesis's count).
    let mut all_rays = Vec::new();
    for adaptive in ["all", "glossy", "off"] {
        let mut last = f64::INFINITY;
        let mut rays = Vec::new();
        for mu in [1.0, 4.0, 32.0, 1e4] {
            let params = format!(r#""mu": {mu}, "adaptive": "{adaptive}""#);
            let s = session_from_text(&envmap(&params, ""), &Overrides::default());
            let r = run(&s);
            let d = rmse(&output(&s, &r, "color"), &output(&s, &r, "unfiltered"));
            println!("{adaptive}, mu {mu}: RMSE(filtered, unfiltered) {d:.4e}, rays {:?}", r.rays);
            assert!(d < last, "{adaptive}, mu {mu}: {d} after {last}");
            (last, rays) = (d, [rays, vec![r.rays.shadow_rays]].concat());
        }
        assert!(last < 1e-3, "{adaptive}: {last}");
        assert!(rays.windows(2).all(|w| w[1] >= w[0]), "{adaptive}: rays fell: {rays:?}");
        match adaptive {
            "all" => assert!(rays[3] > 2 * rays[0], "all: the count follows μ: {rays:?}"),
            // Only the torus's pixels add look-ups: more than at μ = 1, fewer than `all`.
            "glossy" => assert!(rays[3] > rays[0] && rays[3] < all_rays[3], "glossy: {rays:?} vs all {all_rays:?}"),
            _ => assert_eq!(rays[0], rays[3], "off: the count does not follow μ"),
        }
        if adaptive == "all" {
            all_rays = rays;
        }
    }
}

/// Mean of every channel of every pixel.
fn image_mean(img: &Image) -> f64 {
    img.pixels.iter().flatten().map(|&c| c as f64).sum::<f64>() / (3 * img.pixels.len()) as f64
}

#[test]
fn glossy_receivers_take_the_lobe_and_the_map() {
    // `glossy_sampling: "mis"` pairs each look-up at a glossy receiver with a lobe direction (balance
    // heuristic). Both estimate the same light: their converged images agree (the table's quadrature
    // against the continuous map). MIS's estimates vary far less on `envmap`, whose glossy torus
    // catches the map's table in a sharp lobe (docs/DESIGN-NOTES.md "Glossy receivers: the lobe and
    // the map"), for one more shadow ray per look-up there; a scene with no glossy receiver renders
    // the same image either way.
    let at = |sampling: &str, seed: u32| {
        envmap(&format!(r#""glossy_sampling": "{sampling}""#), "").replace("seed: 2,", &format!("seed: {seed},"))
    };
    let (table, mis) = (reference(&at("table", 2), 512), reference(&at("mis", 2), 512));
    let (m_table, m_mis) = (image_mean(&table), image_mean(&mis));
    println!("converged means: table {m_table:.5}, mis {m_mis:.5}");
    assert!((m_mis / m_table - 1.0).abs() < 5e-3, "{m_mis} vs {m_table}");
    // The noise of a 64-spp Monte Carlo image: half the RMSE between two seeds' (~ one image's).
    let noise = |sampling: &str| rmse(&reference(&at(sampling, 3), 64), &reference(&at(sampling, 4), 64)) / 2f64.sqrt();
    let (n_table, n_mis) = (noise("table"), noise("mis"));
    println!("64-spp noise RMSE: table {n_table:.4e}, mis {n_mis:.4e} ({:.2}x)", n_table / n_mis);
    assert!(n_mis < 0.6 * n_table, "{n_mis} vs {n_table}");
    let rays = |sampling: &str| {
        let s = session_from_text(&at(sampling, 2), &Overrides::default());
        run(&s).rays.shadow_rays
    };
    let (rays_table, rays_mis) = (rays("table"), rays("mis"));
    println!("the node's shadow rays: table {rays_table}, mis {rays_mis}");
    assert!(rays_table < rays_mis && rays_mis < 2 * rays_table, "{rays_mis} vs {rays_table}");
    // A diffuse sphere under a constant map: no lobe to sample, the same bytes.
    let dir = tempfile::tempdir().unwrap();
    let (obj, map) = (sphere_obj(dir.path(), 0.5), constant_map(dir.path(), 2.0));
    let image = |sampling: &str| {
        let text = furnace(&obj, &map, &format!(r#""glossy_sampling": "{sampling}""#));
        let s = session_from_text(&text, &text_overrides());
        color(&s, &run(&s))
    };
    assert_eq!(image("table"), image("mis"));
}

/// Frames `first..=last` of `text` with its camera path on the CPU; their colour images.
fn frames(text: &str, first: u32, last: u32) -> Vec<Image> {
    let mut s = session_from_text(text, &Overrides::default());
    let (mut out, mut previous): (Vec<Image>, Option<RunResult>) = (Vec::new(), None);
    for f in first..=last {
        let r = s.run_frame(&mut CpuBackend::new(), &Silent, f, first, previous.as_ref()).expect("frame runs");
        out.push(output(&s, &r, "color"));
        previous = Some(r);
    }
    out
}

#[test]
fn temporal_filtering_damps_the_flicker_of_a_still_camera() {
    // The same camera every frame, each frame with its own noise: the frame-to-frame difference is
    // the flicker. Joining the previous frame's irradiance (eqs. 6.24–6.26) averages two frames' noise.
    let flicker = |temporal: bool| {
        let f = frames(&envmap(&format!(r#""temporal": {temporal}"#), ""), 0, 4);
        f.windows(2).map(|w| rmse(&w[0], &w[1])).sum::<f64>() / 4.0
    };
    let (off, on) = (flicker(false), flicker(true));
    println!("frame-to-frame RMSE: spatial only {off:.4e}, temporal {on:.4e} ({:.2}x)", off / on);
    assert!(on < 0.85 * off, "{on} vs {off}");
}

#[test]
fn a_moving_camera_leaves_no_ghost() {
    // The camera moves 0.3 m sideways between frames 0 and 1: the reprojection must find the same
    // world points, so frame 1 with temporal filtering is no further from the converged image than
    // frame 1 without it — at the sphere's silhouette too, where a ghost of frame 0 would show.
    let path = "camera_path: [(frame: 0, position: (-0.3, 1.6, 3.4), look_at: (-0.3, 0.45, 0)), \
                (frame: 1, position: (0, 1.6, 3.4), look_at: (0, 0.45, 0))],";
    let temporal = frames(&envmap(r#""temporal": true"#, path), 0, 1).pop().unwrap();
    let spatial = frames(&envmap(r#""temporal": false"#, path), 0, 1).pop().unwrap();
    // The converged frame 1: its camera as the pipeline's camera block.
    let still = "camera: Some((position: (0, 1.6, 3.4), look_at: (0, 0.45, 0), vfov_deg: 40)),";
    let truth = reference(&envmap("", still), 1024);
    // Rows through the sphere; the profile of |error| across its left silhouette.
    let (mut err_t, mut err_s) = (0.0f64, 0.0f64);
    for y in 20..32 {
        for x in 0..64 {
            let (t, s, r) = (temporal.get(x, y), spatial.get(x, y), truth.get(x, y));
            err_t += (0..3).map(|c| ((t[c] - r[c]) as f64).abs()).sum::<f64>();
            err_s += (0..3).map(|c| ((s[c] - r[c]) as f64).abs()).sum::<f64>();
        }
    }
    let profile: Vec<String> =
        (0..64).map(|x| format!("{:.2}", temporal.get(x, 26)[1] - truth.get(x, 26)[1])).collect();
    println!("row 26, temporal − converged: {}", profile.join(" "));
    println!(
        "mean |error| over rows 20..32: temporal {:.4e}, spatial {:.4e}",
        err_t / (12.0 * 64.0 * 3.0),
        err_s / (12.0 * 64.0 * 3.0)
    );
    assert!(err_t <= 1.05 * err_s, "temporal {err_t} vs spatial {err_s}");
}

#[test]
fn an_area_light_and_the_environment_compose() {
    // SoftShadows (the area light of envmap_light, Ch. 3) + Environment (the sky) summed by Add; the
    // Environment node leaves emission and the visible map to SoftShadows and shares its sampler
    // (one path through the pixel centre, 16 look-ups).
    let text = r#"Pipeline(scene: "builtin:envmap_light", width: 64, height: 48, seed: 1, nodes: [
        (name: "primary", kind: "Primary"),
        (name: "shadows", kind: "SoftShadows", params: {"light": 0},
         inputs: {"position": "primary.position", "normal": "primary.normal", "albedo": "primary.albedo", "emission": "primary.emission"}),
        (name: "env", kind: "Environment", params: {"primary": 1, "per_primary": 16, "emission": false}),
        (name: "sum", kind: "Add", inputs: {"a": "shadows.radiance", "b": "env.radiance"}),
        (name: "out", kind: "Output", inputs: {"color": "sum.radiance"}),
    ])"#;
    let s = session_from_text(text, &Overrides::default());
    let img = color(&s, &run(&s));
    let truth = reference(text, 512);
    let mean = |i: &Image| i.luminance().iter().map(|&v| v as f64).sum::<f64>() / (64.0 * 48.0);
    let rel = rmse(&img, &truth) / mean(&truth);
    println!("composed: mean {:.4} vs reference {:.4}; RMSE / mean {rel:.4}", mean(&img), mean(&truth));
    assert!((mean(&img) / mean(&truth) - 1.0).abs() < 0.02);
    assert!(rel < 0.5, "{rel}");
}

fn build_error(text: &str) -> String {
    let loaded = parse_pipeline(Path::new("test.ron"), text).expect("pipeline parses");
    let (nodes, kernels) = wedge::effects::builtin();
    match Session::build(loaded, &text_overrides(), nodes, kernels) {
        Ok(_) => panic!("session builds"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_maps_are_clear_errors_at_the_node() {
    let dir = tempfile::tempdir().unwrap();
    let scene = sphere_obj(dir.path(), 0.5);
    // Missing file.
    let e = build_error(&furnace(&scene, &dir.path().join("nope.exr"), ""));
    println!("{e}");
    assert!(e.contains("node `env`") && e.contains("nope.exr") && e.contains("`map`"), "{e}");
    // Not 2:1.
    let square = dir.path().join("square.exr");
    write_exr(&square, &Image::from_fn(32, 32, |_, _| [1.0; 3])).unwrap();
    let e = build_error(&furnace(&scene, &square, ""));
    println!("{e}");
    assert!(e.contains("2:1") && e.contains("node `env`"), "{e}");
    // NaN and negative texels are counted and refused.
    let bad = dir.path().join("bad.exr");
    write_exr(
        &bad,
        &Image::from_fn(64, 32, |x, y| {
            if (x, y) == (3, 3) {
                [f32::NAN; 3]
            } else if x == 5 {
                [-1.0; 3]
            } else {
                [1.0; 3]
            }
        }),
    )
    .unwrap();
    let e = build_error(&furnace(&scene, &bad, ""));
    println!("{e}");
    assert!(e.contains("NaN") && e.contains("negative"), "{e}");
    // No map anywhere: the scene (an OBJ) has none and the node gives none.
    let text = furnace(&scene, Path::new(""), "").replace(r#""map": "", "#, "");
    let e = build_error(&text);
    println!("{e}");
    assert!(e.contains("has none") && e.contains("builtin:sky"), "{e}");
}
