//! `Heatmap` sinks (effects/src/heatmap.rs): any number of per-pixel scalars, each written by
//! `write_run` as `<node name>.png` drawn as its parameters say; wrong wiring and unusable names
//! are refused with the node named; the files are the same for any thread count.

mod common;

use std::path::Path;

use common::*;
use wedge::backends::BufferData;
use wedge::graph::parse_pipeline;
use wedge::heatmap::{render_heatmap, HeatmapSpec, Scale};
use wedge::outputs::write_run;
use wedge::{Overrides, Session};

/// pipelines/shadows.ron's graph with `extra` nodes added after the `Output`.
fn shadows_with(extra: &str) -> String {
    format!(
        r#"Pipeline(
    scene: "builtin:grids", width: 64, height: 48, seed: 3,
    nodes: [
        (name: "primary", kind: "Primary"),
        (name: "shadows", kind: "SoftShadows",
         inputs: {{"position": "primary.position", "normal": "primary.normal",
                  "albedo": "primary.albedo", "emission": "primary.emission"}}),
        (name: "out", kind: "Output", inputs: {{"color": "shadows.radiance",
                  "filter_width": "shadows.filter_width"}}),
{extra}
    ],
)"#
    )
}

const TWO_MAPS: &str = r#"
        (name: "beta", kind: "Heatmap", inputs: {"width": "shadows.filter_width"}),
        (name: "rays", kind: "Heatmap", params: {"scale": "linear", "unit": "samples"},
         inputs: {"count": "shadows.rays_per_pixel"}),
        (name: "raw_beta", kind: "Heatmap", params: {"mask_zero": false}, inputs: {"value": "shadows.filter_width"}),
"#;

fn build(text: &str) -> Result<Session, String> {
    let loaded = parse_pipeline(Path::new("maps.ron"), text).map_err(|e| e.to_string())?;
    let (nodes, kernels) = wedge::effects::builtin();
    Session::build(loaded, &Overrides::default(), nodes, kernels).map_err(|e| e.to_string())
}

/// The RGB8 pixels of a PNG.
fn pixels(path: &Path) -> (u32, u32, Vec<u8>) {
    let img = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgb8();
    (img.width(), img.height(), img.into_raw())
}

#[test]
fn each_heatmap_node_writes_its_png_as_its_parameters_say() {
    let s = build(&shadows_with(TWO_MAPS)).unwrap();
    let r = run(&s);
    let dir = tempfile::tempdir().unwrap();
    let written = write_run(dir.path(), "render", &r, s.width, s.height).unwrap();
    let names: Vec<String> =
        written.files.iter().map(|f| f.file_name().unwrap().to_string_lossy().into_owned()).collect();
    for f in ["render.png", "filter_width.png", "beta.png", "rays.png", "raw_beta.png"] {
        assert!(names.contains(&f.to_string()), "{f} not in {names:?}");
    }

    let width = r.outputs[&("beta".to_string(), "width".to_string())].to_scalar();
    let BufferData::U32(counts) = &r.outputs[&("rays".to_string(), "count".to_string())] else { panic!("u32 counts") };
    let counts: Vec<f32> = counts.iter().map(|&c| c as f32).collect();
    let zero: Vec<bool> = width.iter().map(|w| *w <= 0.0).collect();
    // The scene has both: unfiltered pixels (masked black) and filtered ones.
    assert!(zero.iter().any(|z| *z) && zero.iter().any(|z| !*z));
    assert!(counts.iter().any(|c| *c != counts[0]), "counts vary");

    // Each file is exactly the map its parameters describe: title = node name, the port's or the
    // parameter's unit, the scale, the mask.
    let expect = |values: &[f32], mask: Option<&[bool]>, title: &str, unit: &str, scale: Scale| {
        render_heatmap(s.width, s.height, values, mask, &HeatmapSpec { title, unit, scale, range: None, arrows: None })
    };
    let cases = [
        ("beta", expect(&width, Some(&zero), "beta", "px", Scale::Log)),
        ("rays", expect(&counts, None, "rays", "samples", Scale::Linear)),
        ("raw_beta", expect(&width, None, "raw_beta", "", Scale::Log)),
    ];
    let mut seen = Vec::new();
    for (name, want) in cases {
        let got = pixels(&dir.path().join(format!("{name}.png")));
        assert!(got.0 > s.width && got.1 > s.height, "{name}: map plus title and colour bar, {got:?}");
        assert!(got == want, "{name}.png is not the map its parameters describe");
        seen.push(got.2);
    }
    assert!(seen[0] != seen[1] && seen[0] != seen[2] && seen[1] != seen[2], "different maps, different pixels");
    // Masking is visible: beta.png has black where the width is 0, raw_beta.png does not.
    let black = |px: &[u8]| px.chunks(3).filter(|p| *p == [0, 0, 0]).count();
    assert!(black(&seen[0]) >= zero.iter().filter(|z| **z).count(), "masked pixels are black");
    assert!(black(&seen[0]) > black(&seen[2]));
}

#[test]
fn heatmap_files_are_the_same_for_any_thread_count() {
    let s = build(&shadows_with(TWO_MAPS)).unwrap();
    let files = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let r = pool.install(|| run(&s));
        let dir = tempfile::tempdir().unwrap();
        write_run(dir.path(), "render", &r, s.width, s.height).unwrap();
        ["beta.png", "rays.png", "raw_beta.png"].map(|f| std::fs::read(dir.path().join(f)).unwrap())
    };
    let one = files(1);
    assert!(one == files(2), "1 vs 2 threads");
    assert!(one == files(2), "run to run");
}

#[test]
fn wrong_wiring_and_unusable_names_are_refused_naming_the_node() {
    let cases = [
        (r#"(name: "m", kind: "Heatmap")"#, vec!["node `m`", "exactly one", "none is wired"]),
        (
            r#"(name: "m", kind: "Heatmap", inputs: {"width": "shadows.filter_width", "count": "shadows.rays_per_pixel"})"#,
            vec!["node `m`", "exactly one", "`width` and `count` are wired"],
        ),
        (r#"(name: "a/b", kind: "Heatmap", inputs: {"width": "shadows.filter_width"})"#, vec!["a/b", "rename"]),
        (r#"(name: "/tmp/m", kind: "Heatmap", inputs: {"width": "shadows.filter_width"})"#, vec!["/tmp/m", "rename"]),
        // A u32 count on the f32 port is a format conflict the validator reports with its position.
        (r#"(name: "m", kind: "Heatmap", inputs: {"width": "shadows.rays_per_pixel"})"#, vec!["maps.ron:", "width"]),
        (
            r#"(name: "m", kind: "Heatmap", params: {"scale": "cubic"}, inputs: {"width": "shadows.filter_width"})"#,
            vec!["maps.ron:", "scale", "linear"],
        ),
        (
            r#"(name: "m", kind: "Heatmap", params: {"unit": "m"}, inputs: {"width": "shadows.filter_width"})"#,
            vec!["maps.ron:", "unit", "samples"],
        ),
    ];
    for (node, wants) in cases {
        let e = build(&shadows_with(&format!("        {node},"))).err().unwrap_or_else(|| panic!("{node} accepted"));
        for w in wants {
            assert!(e.contains(w), "{node}: `{w}` not in: {e}");
        }
    }
}

#[test]
fn a_heatmap_named_like_another_output_is_an_error_and_writes_nothing() {
    let s = build(&shadows_with(
        r#"        (name: "filter_width", kind: "Heatmap", inputs: {"count": "shadows.rays_per_pixel"}),"#,
    ))
    .unwrap();
    let r = run(&s);
    let dir = tempfile::tempdir().unwrap();
    let e = write_run(dir.path(), "render", &r, s.width, s.height).unwrap_err().to_string();
    assert!(e.contains("filter_width.png") && e.contains("rename the Heatmap node"), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "all or nothing");
}
