//! Progressive rendering and the PixelFilter node (issue 18; Schwenk's thesis, seed 002 Ch. 3):
//! accumulation over frames, determinism, convergence to plain accumulation, consistency against the
//! pipeline's own reference, the path splits, the CLI's `--progressive`, and GPU parity at a filter
//! frame with history. The blend algebra, the schedule, eq. 3.14–3.18 and the variance estimator's
//! unbiasedness are unit tests in `effects/src/pixel_filter/formulas.rs`.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::progressive::{gpu_parity_with_history, progressive, rel_mse, rmse, vec3s};
use common::{gpu_or_skip, sized};
use wedge::backends::cpu::CpuBackend;
use wedge::backends::{BufferData, RunResult, Silent};
use wedge::effects::pixel_filter::formulas::Stats;
use wedge::graph::ParamValue;
use wedge::Session;

fn pipeline(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines").join(name)
}

fn open(name: &str, w: u32, h: u32, params: &[(&str, &str, ParamValue)]) -> Session {
    Session::open(Some(&pipeline(name)), &sized(w, h, None, params)).expect("session")
}

/// The contents of `<buffer>@previous_frame` a run hands to the next frame (the accumulation).
fn handed_on<'a>(s: &Session, run: &'a RunResult, buffer: &str) -> &'a [[f32; 4]] {
    let name = format!("{buffer}@previous_frame");
    let h = s
        .schedule
        .history
        .iter()
        .find(|h| s.schedule.buffers[h.buffer.0].name == name)
        .unwrap_or_else(|| panic!("{name}"));
    match &run.history[&h.buffer] {
        BufferData::Vec4(v) => v,
        other => panic!("{name} is {}", other.format()),
    }
}

/// After N frames the accumulated mean is the mean of the N frames rendered alone (one path each):
/// bit for bit against the same Welford/Chan recurrence (`Stats::combine`) folded over the N one-path
/// renders, and to f32 rounding (≤ 2e-6 relative) against their mean in f64.
#[test]
fn accumulation_is_the_mean_of_independent_one_path_frames() {
    let s = open("progressive_pixel.ron", 24, 18, &[]);
    let n = 12;
    let runs = progressive(&s, n);
    let last = runs.last().unwrap();
    let (acc_lv, acc_hv) = (handed_on(&s, last, "pf.lv"), handed_on(&s, last, "pf.hv"));
    let alone: Vec<RunResult> = (0..n)
        .map(|f| s.run_progressive_frame(&mut CpuBackend::new(), &Silent, f, None).expect("frame alone"))
        .collect();
    let pixels = acc_lv.len();
    let mut worst = 0.0f64;
    for i in 0..pixels {
        let mut st = Stats::default();
        let mut mean = [0.0f64; 3];
        for r in &alone {
            let (lv, hv) = (handed_on(&s, r, "pf.lv")[i], handed_on(&s, r, "pf.hv")[i]);
            assert_eq!(lv[3], 1.0, "one path per frame");
            st = Stats::combine(st, Stats::from_buffers(lv, hv));
            for c in 0..3 {
                mean[c] += (lv[c] as f64 + hv[c] as f64) / n as f64;
            }
        }
        assert_eq!(st.lv_buffer(), acc_lv[i], "pixel {i}: L_lv and n, bit for bit");
        assert_eq!(st.u_buffer(), acc_hv[i], "pixel {i}: L_u and M2, bit for bit");
        for c in 0..3 {
            let acc = acc_lv[i][c] as f64 + acc_hv[i][c] as f64;
            worst = worst.max((acc - mean[c]).abs() / mean[c].abs().max(1e-3));
        }
    }
    println!("largest relative difference of the accumulated mean to the f64 mean of {n} frames: {worst:.2e}");
    assert!(worst < 2e-6, "{worst}");
    // And the unfiltered output is that accumulation.
    let unf = vec3s(last.output("unfiltered").unwrap());
    for i in 0..pixels {
        for c in 0..3 {
            assert_eq!(unf[i][c], acc_lv[i][c] + acc_hv[i][c]);
        }
    }
}

/// Same inputs and seed, same image, whatever the thread count (every output, every frame).
#[test]
fn progressive_frames_do_not_depend_on_the_thread_count() {
    for name in ["progressive_pixel.ron", "progressive_pixel_fast.ron"] {
        let s = open(name, 40, 30, &[]);
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| progressive(&s, 5))
        };
        let (a, b) = (on(1), on(3));
        for (ra, rb) in a.iter().zip(&b) {
            for (key, buf) in &ra.outputs {
                assert_eq!(Some(buf), rb.outputs.get(key), "{name}: output {key:?}");
            }
        }
    }
}

/// s → 1 as paths accumulate (the mean blend factor grows), and once a pixel's s is 1 its output is
/// the plain accumulation bit for bit; with enough frames every pixel gets there.
#[test]
fn blend_factor_goes_to_one_and_the_output_becomes_plain_accumulation() {
    for name in ["progressive_pixel.ron", "progressive_pixel_fast.ron"] {
        let s = open(name, 16, 12, &[("pf", "t", ParamValue::Float(0.5))]);
        let mut previous: Option<RunResult> = None;
        let mut means = Vec::new();
        let mut converged_at = None;
        for frame in 0..4096u32 {
            let run = s.run_progressive_frame(&mut CpuBackend::new(), &Silent, frame, previous.as_ref()).unwrap();
            let blend = run.output("value").map(BufferData::to_scalar).expect("blend heatmap input");
            let (rad, unf) = (run.output("color").unwrap(), run.output("unfiltered").unwrap());
            for (i, &sv) in blend.iter().enumerate() {
                assert!((0.0..=1.0).contains(&sv), "s = {sv}");
                if sv == 1.0 {
                    for c in 0..3 {
                        assert_eq!(
                            rad.component(i, c).to_bits(),
                            unf.component(i, c).to_bits(),
                            "{name}: s = 1 must be plain accumulation"
                        );
                    }
                }
            }
            let mean = blend.iter().map(|&v| v as f64).sum::<f64>() / blend.len() as f64;
            if (frame + 1).is_power_of_two() {
                means.push((frame + 1, mean));
            }
            if blend.iter().all(|&v| v == 1.0) && frame >= 15 {
                converged_at = Some(frame + 1);
                break;
            }
            previous = Some(run);
        }
        println!("{name}: mean s by paths per pixel {means:?}; every pixel s = 1 after {converged_at:?} paths");
        let n =
            converged_at.unwrap_or_else(|| panic!("{name}: s did not reach 1 everywhere in 4096 frames: {means:?}"));
        assert!(means.first().unwrap().1 < 1.0, "{name}: the first frame must blend in the filtered buffer somewhere");
        let at = |k: u32| means.iter().find(|(m, _)| *m == k).map(|(_, v)| *v);
        assert!(at(16).unwrap() >= at(4).unwrap(), "{name}: {means:?}");
        assert!(n > 4, "{name}");
    }
}

/// Relative MSE, `mean((a − b)² / (b² + 0.01))` per channel (`wedge compare`'s relMSE): robust to the
/// few pixels that see the light, whose jittered edges dominate an RMSE.
/// Consistency: against the pipeline's own reference (`wedge reference`: the same paths, filters
/// bypassed) at 1024 paths per pixel, the blended image's RMSE and relMSE fall from 4 to 16 to 64
/// frames on cornell at 64×48, and filtering beats plain accumulation early on.
#[test]
fn error_against_the_reference_falls_with_frames() {
    let ov = sized(64, 48, None, &[]);
    let reference = Session::reference(Some(&pipeline("progressive_pixel.ron")), 1024, "independent", &ov).unwrap();
    let r = reference.run(&mut CpuBackend::new(), &Silent).unwrap();
    let (rc, ru) = (r.output("color").unwrap(), r.output("unfiltered").unwrap());
    assert_eq!(rc, ru, "a reference is the plain accumulation (filters bypassed, s = 1)");
    assert!(r.output("value").unwrap().to_scalar().iter().all(|&s| s == 1.0));
    for name in ["progressive_pixel.ron", "progressive_pixel_fast.ron"] {
        let s = Session::open(Some(&pipeline(name)), &ov).unwrap();
        let runs = progressive(&s, 64);
        let at = |n: usize| {
            let run = &runs[n - 1];
            let (c, u) = (run.output("color").unwrap(), run.output("unfiltered").unwrap());
            ((rmse(c, rc), rmse(u, rc)), (rel_mse(c, rc), rel_mse(u, rc)))
        };
        let (e4, e16, e64) = (at(4), at(16), at(64));
        println!(
            "{name}: (RMSE filtered, plain), (relMSE filtered, plain) after 4 {e4:?}, 16 {e16:?}, 64 {e64:?} frames"
        );
        for k in [0, 1] {
            let m = |e: ((f64, f64), (f64, f64))| if k == 0 { e.0 } else { e.1 };
            assert!(
                m(e4).0 > m(e16).0 && m(e16).0 > m(e64).0,
                "{name}: filtered error must fall: {e4:?} {e16:?} {e64:?}"
            );
            assert!(m(e4).1 > m(e16).1 && m(e16).1 > m(e64).1, "{name}: plain error must fall");
            assert!(m(e4).0 < m(e4).1, "{name}: filtered beats plain accumulation at 4 frames: {e4:?}");
        }
    }
}

/// The three splits share the paths: `L_lv + L_u` is the same radiance (to rounding); `all` puts
/// everything in `L_u`, `caustics` only light that reached the first diffuse vertex through glossy
/// scattering (non-zero on cornell's glossy box and sphere, and less than the indirect light).
#[test]
fn splits_partition_the_same_paths() {
    let mean_hv = |s: &Session, run: &RunResult| -> f64 {
        let hv = handed_on(s, run, "pf.hv");
        hv.iter().map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>() / hv.len() as f64
    };
    let mut unfiltered = Vec::new();
    let mut hv = Vec::new();
    for split in ["indirect", "caustics", "all"] {
        let s = open("progressive_pixel.ron", 48, 36, &[("pf", "split", ParamValue::Str(split.into()))]);
        let run = s.run(&mut CpuBackend::new(), &Silent).unwrap();
        unfiltered.push(vec3s(run.output("unfiltered").unwrap()));
        hv.push(mean_hv(&s, &run));
    }
    for k in 1..3 {
        for (a, b) in unfiltered[0].iter().zip(&unfiltered[k]) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-5 * a[c].abs().max(1.0), "split {k}: {a:?} vs {b:?}");
            }
        }
    }
    println!("mean L_u: indirect {:.4}, caustics {:.5}, all {:.4}", hv[0], hv[1], hv[2]);
    assert!(hv[1] > 0.0 && hv[1] < hv[0] && hv[0] < hv[2], "{hv:?}");
}

fn wedge(args: &[&str], cwd: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_wedge")).args(args).current_dir(cwd).output().expect("wedge runs")
}

/// `render --progressive N` writes a snapshot after 1, 2, 4, … frames and the last, each with the full
/// outputs, and prints time per frame and per pass class; bad values are errors naming the flag.
#[test]
fn cli_progressive_writes_snapshots_and_refuses_bad_values() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let p = pipeline("progressive_pixel.ron");
    let o = wedge(
        &[
            "render",
            p.to_str().unwrap(),
            "--progressive",
            "6",
            "--width",
            "32",
            "--height",
            "24",
            "--out",
            out.to_str().unwrap(),
        ],
        repo,
    );
    let (stdout, stderr) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "{stderr}");
    for needle in ["progressive: 6 frames", "per frame by pass class", "filter frames: 2 of 6", "wrote "] {
        assert!(stdout.contains(needle), "{needle:?} in {stdout}");
    }
    let mut names: Vec<String> =
        std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    for f in [
        "progressive_0001.exr",
        "progressive_0001.png",
        "progressive_0002.exr",
        "progressive_0004.png",
        "progressive_0006.exr",
        "render.exr",
        "render.png",
        "unfiltered.exr",
        "blend_factor.png",
    ] {
        assert!(names.contains(&f.to_string()), "{f} in {names:?}");
    }
    assert!(!names.iter().any(|n| n.starts_with("progressive_0003") || n.starts_with('.')), "{names:?}");
    // The last snapshot is the final render.
    let a = wedge::image::read_exr(&out.join("progressive_0006.exr")).unwrap();
    let b = wedge::image::read_exr(&out.join("render.exr")).unwrap();
    assert_eq!(a.pixels, b.pixels);

    for (args, code, needles) in [
        (vec!["render", p.to_str().unwrap(), "--progressive", "0"], 2, vec!["--progressive <N>", "1..=1000000"]),
        (vec!["render", p.to_str().unwrap(), "--progressive", "abc"], 2, vec!["--progressive <N>"]),
        (vec!["render", p.to_str().unwrap(), "--progressive=-3"], 2, vec!["--progressive <N>"]),
        (vec!["render", p.to_str().unwrap(), "--progressive", "2000000"], 2, vec!["--progressive <N>", "1..=1000000"]),
        (
            vec!["render", p.to_str().unwrap(), "--progressive", "4", "--frames", "0..3"],
            2,
            vec!["--progressive <N>", "--frames"],
        ),
        (
            vec!["render", "pipelines/shadows.ron", "--progressive", "4", "--width", "16", "--height", "12"],
            1,
            vec!["no node that accumulates", "progressive_pixel.ron"],
        ),
    ] {
        let o = wedge(&args, repo);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        for n in needles {
            assert!(err.contains(n), "{args:?}: {n:?} in {err}");
        }
    }
}

/// GPU parity at a filter frame with history: frames 0–2 on the CPU, then frame 3 (4 paths per
/// pixel: the first scheduled filter pass, per-pixel variances from M2, the range buffer's second
/// pass, the adaptive width from the previous filtered buffer) pass by pass on the GPU with the
/// CPU's inputs; and whole progressive runs on both backends agree.
#[test]
fn gpu_parity_at_a_filter_frame_with_history() {
    let Some(mut gpu) = gpu_or_skip("gpu_parity_at_a_filter_frame_with_history") else { return };
    for name in ["progressive_pixel.ron", "progressive_pixel_fast.ron"] {
        let report = gpu_parity_with_history(&open(name, 48, 36, &[]), &mut gpu, 3, 6);
        assert!(report
            .rows
            .iter()
            .any(|r| r.kernel.starts_with("pixel_filter.") && r.class == wedge::backends::KernelClass::Filter));
    }
}
