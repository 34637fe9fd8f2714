//! Helpers for the progressive nodes' tests (PixelFilter, RadianceFilter): frame loops, image
//! errors, and the error-versus-time measurement both nodes report in docs/DESIGN-NOTES.md.

use wedge::backends::cpu::CpuBackend;
use wedge::backends::{BufferData, KernelClass, RunResult, Silent};
use wedge::bench::plots::{write_plot, Plot, Series, SeriesStyle, BLUE, GREEN, GREY, RED};
use wedge::Session;

/// Frames 0..n of a progressive render on the CPU, every frame's run kept.
pub fn progressive(s: &Session, n: u32) -> Vec<RunResult> {
    let mut runs: Vec<RunResult> = Vec::new();
    for frame in 0..n {
        let run = s.run_progressive_frame(&mut CpuBackend::new(), &Silent, frame, runs.last()).expect("frame");
        runs.push(run);
    }
    runs
}

pub fn vec3s(b: &BufferData) -> Vec<[f32; 3]> {
    (0..b.len()).map(|i| [b.component(i, 0), b.component(i, 1), b.component(i, 2)]).collect()
}

/// The mean of a vec3 image's components.
pub fn mean(b: &BufferData) -> f64 {
    let v = vec3s(b);
    v.iter().map(|p| f64::from(p[0]) + f64::from(p[1]) + f64::from(p[2])).sum::<f64>() / (3 * v.len()) as f64
}

pub fn rmse(a: &BufferData, b: &BufferData) -> f64 {
    let (a, b) = (vec3s(a), vec3s(b));
    let sum: f64 =
        a.iter().zip(&b).map(|(x, y)| (0..3).map(|c| (x[c] as f64 - y[c] as f64).powi(2)).sum::<f64>()).sum();
    (sum / (3 * a.len()) as f64).sqrt()
}

/// Relative MSE, `(a − b)² / (b² + 0.01)` per component, averaged.
pub fn rel_mse(a: &BufferData, b: &BufferData) -> f64 {
    let (a, b) = (vec3s(a), vec3s(b));
    let sum: f64 = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (0..3).map(|c| (x[c] as f64 - y[c] as f64).powi(2) / ((y[c] as f64).powi(2) + 0.01)).sum::<f64>())
        .sum();
    sum / (3 * a.len()) as f64
}

/// One progressive pipeline's error after each frame: `(plain time, filtered time, plain RMSE,
/// plain relMSE, filtered RMSE, filtered relMSE)`. "Plain" is progressive accumulation without the
/// filter: the same run's `unfiltered` output, timed by its node's `sample` and `accumulate` passes
/// only; the filtered image (`color`) is timed by every pass.
pub struct Curve {
    pub name: String,
    pub rows: Vec<(f64, f64, f64, f64, f64, f64)>,
    /// Seconds in the Filter-class passes of the frames that filter, and how many frames did.
    pub filter_seconds: f64,
    pub filter_frames: u32,
}

/// `filters(frame)`: whether the node filters in that frame (PixelFilter's schedule; every frame for
/// RadianceFilter), for the time per filter pass.
pub fn measure_curve(
    s: &Session,
    name: &str,
    node: &str,
    frames: u32,
    reference: &BufferData,
    filters: impl Fn(u32) -> bool,
) -> Curve {
    let plain = [format!("{node}.sample"), format!("{node}.accumulate")];
    let mut previous: Option<RunResult> = None;
    let mut rows = Vec::new();
    let (mut tp, mut tf, mut filter_seconds, mut filter_frames) = (0.0f64, 0.0f64, 0.0f64, 0u32);
    for frame in 0..frames {
        let run = s.run_progressive_frame(&mut CpuBackend::new(), &Silent, frame, previous.as_ref()).unwrap();
        tp += run.timings.iter().filter(|t| plain.contains(&t.pass)).map(|t| t.seconds).sum::<f64>();
        tf += run.total_seconds();
        if filters(frame) {
            filter_seconds += run.seconds(KernelClass::Filter);
            filter_frames += 1;
        }
        let (c, u) = (run.output("color").unwrap(), run.output("unfiltered").unwrap());
        rows.push((tp, tf, rmse(u, reference), rel_mse(u, reference), rmse(c, reference), rel_mse(c, reference)));
        previous = Some(run);
    }
    Curve { name: name.to_string(), rows, filter_seconds, filter_frames }
}

/// The tables of docs/DESIGN-NOTES.md for one curve: at the plain run's time after 1, 2, 4, …
/// frames, the filtered image is the last one finished by then; then the same at equal frames.
pub fn print_curve(c: &Curve) {
    let (tp_all, tf_all) = (c.rows.last().unwrap().0, c.rows.last().unwrap().1);
    println!(
        "\n{}: {} frames: {:.2} ms per filter frame's Filter passes ({} frames filtered); everything beyond plain \
         accumulation {:.1}% of the pass time; {:.2} s in all",
        c.name,
        c.rows.len(),
        c.filter_seconds / f64::from(c.filter_frames.max(1)) * 1e3,
        c.filter_frames,
        100.0 * (tf_all - tp_all) / tf_all,
        tf_all
    );
    println!("| plain frames | time (s) | plain RMSE | plain relMSE | filtered frames by then | filtered RMSE | filtered relMSE | relMSE plain/filtered |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut n = 1usize;
    while n <= c.rows.len() {
        let t = c.rows[n - 1].0;
        if let Some(k) = c.rows.iter().rposition(|r| r.1 <= t) {
            let (p, f) = (c.rows[n - 1], c.rows[k]);
            println!(
                "| {n} | {t:.3} | {:.4} | {:.5} | {} | {:.4} | {:.5} | {:.2} |",
                p.2,
                p.3,
                k + 1,
                f.4,
                f.5,
                p.3 / f.5
            );
        } else {
            println!("| {n} | {t:.3} | {:.4} | {:.5} | none yet | | | |", c.rows[n - 1].2, c.rows[n - 1].3);
        }
        n *= 2;
    }
    println!("equal frames: | frames | plain relMSE | filtered relMSE | plain RMSE | filtered RMSE |");
    let mut n = 1usize;
    while n <= c.rows.len() {
        let r = c.rows[n - 1];
        println!("| {n} | {:.5} | {:.5} | {:.4} | {:.4} |", r.3, r.5, r.2, r.4);
        n *= 2;
    }
}

/// relMSE against seconds, log-log: plain accumulation (from the first curve), each filtered
/// pipeline, and `extra` series (e.g. single-image pipelines' points), written as a PNG.
pub fn plot_curves(path: &std::path::Path, title: &str, curves: &[Curve], extra: Vec<Series>) {
    let colours = [RED, GREEN, BLUE, [148, 103, 189]];
    let mut series = vec![Series {
        label: "plain progressive accumulation".into(),
        color: GREY,
        style: SeriesStyle::LinePoints,
        points: curves[0].rows.iter().map(|r| (r.0, r.3)).collect(),
    }];
    for (k, c) in curves.iter().enumerate() {
        series.push(Series {
            label: c.name.clone(),
            color: colours[k % colours.len()],
            style: SeriesStyle::LinePoints,
            points: c.rows.iter().map(|r| (r.1, r.5)).collect(),
        });
    }
    series.extend(extra);
    let plot = Plot {
        title: title.into(),
        x_label: "seconds (CPU, passes)".into(),
        y_label: "relMSE vs reference".into(),
        series,
    };
    write_plot(path, &plot).expect("plot written");
    println!("wrote {}", path.display());
}

/// GPU parity of a progressive pipeline: frames `0..frame` on the CPU, then frame `frame` pass by
/// pass on `gpu` from the CPU's history (asserted ok; the report is returned for more checks); then
/// `whole` frames end to end on each backend, whose `color` and `unfiltered` must agree to a relative
/// MSE below 1e-4 (a wrong kernel is far above; float round-off compounds to ~1e-16).
pub fn gpu_parity_with_history(
    s: &Session,
    gpu: &mut wedge::backends::gpu::GpuBackend,
    frame: u32,
    whole: u32,
) -> wedge::backends::parity::ParityReport {
    let runs = progressive(s, frame);
    let job = s.job(s.seed.wrapping_add(frame), frame, &Silent);
    let name = s.pipeline.path.display();
    let report = wedge::backends::parity::run_parity_with_history(&job, gpu, &runs[frame as usize - 1].history)
        .expect("parity runs");
    println!("{name} frame {frame}\n{}", report.table());
    assert!(report.ok(), "{name}: parity at frame {frame} (table above)");
    let mut previous: Option<RunResult> = None;
    for f in 0..whole {
        previous = Some(s.run_progressive_frame(gpu, &Silent, f, previous.as_ref()).expect("gpu frame"));
    }
    let g = previous.unwrap();
    let c = progressive(s, whole).pop().unwrap();
    for port in ["color", "unfiltered"] {
        let (a, b) = (vec3s(c.output(port).unwrap()), vec3s(g.output(port).unwrap()));
        let num: f64 =
            a.iter().zip(&b).map(|(x, y)| (0..3).map(|k| (x[k] as f64 - y[k] as f64).powi(2)).sum::<f64>()).sum();
        let den: f64 = a.iter().map(|x| (0..3).map(|k| (x[k] as f64).powi(2)).sum::<f64>()).sum();
        println!("{name} {port}: relative MSE gpu vs cpu after {whole} frames {:.2e}", num / den.max(1e-30));
        assert!(num / den.max(1e-30) < 1e-4, "{name} {port}");
    }
    report
}

/// The image size a bench renders at: `WEDGE_BENCH_SIZE` (`WIDTHxHEIGHT`, e.g. `320x240`), else
/// 32×24 for the smoke run `cargo test --all-targets` makes and 160×120 for `cargo bench`. A value
/// that is not two positive integers stops the bench with a message rather than running at a size
/// nobody asked for.
pub fn bench_size(smoke: bool) -> (u32, u32) {
    let Ok(v) = std::env::var("WEDGE_BENCH_SIZE") else {
        return if smoke { (32, 24) } else { (160, 120) };
    };
    let parsed =
        v.split_once('x').and_then(|(a, b)| Some((a.trim().parse::<u32>().ok()?, b.trim().parse::<u32>().ok()?)));
    match parsed {
        Some((w, h)) if w > 0 && h > 0 => (w, h),
        _ => {
            eprintln!("WEDGE_BENCH_SIZE={v:?}: expected WIDTHxHEIGHT with two positive integers, e.g. 320x240");
            std::process::exit(2);
        }
    }
}
