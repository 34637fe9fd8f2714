//! The bench's files: `bench.csv` (one row per run), the convergence plots, image crops and
//! `report.md` (tables, goals with PASS/MISS and causes, plots, crops, heatmaps, definitions).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use super::classes;
use super::format::{ratio, sci};
use super::plots::{write_plot, Plot, Series, SeriesStyle, BLUE, GREEN, GREY, RED};
use super::{BenchResult, GoalOutcome, Goals, KeptImages, Method, Role, RunRecord};
use crate::heatmap::{write_heatmap_png, HeatmapSpec, Scale};
use crate::image::{write_png_srgb, Image, ImageError};
use crate::staging::Staging;
use crate::WedgeError;

/// Column names of `bench.csv`, in order.
pub const CSV_COLUMNS: &[&str] = &[
    "method",
    "role",
    "label",
    "mu",
    "spp",
    "seed",
    "rays_per_pixel",
    "primary_rays_per_pixel",
    "shadow_rays_per_pixel",
    "secondary_rays_per_pixel",
    "time_total_s",
    "time_sampling_s",
    "time_bandwidth_s",
    "time_filter_s",
    "time_compose_s",
    "filter_overhead",
    "rmse",
    "rel_mse",
    "psnr_db",
    "smape",
    "flip",
    "non_finite_pixels",
    "variance",
    "bias2",
    "bias2_clamped",
    "speedup_rays_vs_independent",
    "speedup_time_vs_independent",
    "extrapolated_vs_independent",
    "speedup_rays_vs_stratified",
    "speedup_time_vs_stratified",
    "extrapolated_vs_stratified",
    "primary",
];

fn num(v: f64) -> String {
    if v.is_nan() {
        String::new()
    } else {
        format!("{v}")
    }
}

fn opt<T: ToString>(v: Option<T>) -> String {
    v.map(|v| v.to_string()).unwrap_or_default()
}

pub(crate) fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The CSV text: a header and one row per run; fields that do not apply are empty.
pub fn csv(runs: &[RunRecord]) -> String {
    let mut out = CSV_COLUMNS.join(",");
    out.push('\n');
    for r in runs {
        let bv = r.bias_variance;
        let sp = |m: Method| r.speedup(m);
        let row: Vec<String> = vec![
            r.method.key().into(),
            r.role.key().into(),
            csv_field(&r.label),
            opt(r.mu),
            opt(r.spp),
            r.seed.to_string(),
            num(r.rays.total),
            num(r.rays.primary),
            num(r.rays.shadow),
            num(r.rays.secondary),
            num(r.time.total),
            num(r.time.sampling),
            num(r.time.bandwidth),
            num(r.time.filter),
            num(r.time.compose),
            num(r.time.filter_overhead()),
            num(r.metrics.rmse),
            num(r.metrics.rel_mse),
            num(r.metrics.psnr),
            num(r.metrics.smape),
            num(r.flip),
            r.metrics.non_finite.to_string(),
            opt(bv.map(|b| b.variance)),
            opt(bv.map(|b| b.bias2)),
            opt(bv.map(|b| b.clamped)),
            sp(Method::Independent).map_or(String::new(), |s| num(s.rays)),
            sp(Method::Independent).map_or(String::new(), |s| num(s.time)),
            sp(Method::Independent).map_or(String::new(), |s| s.extrapolated().to_string()),
            sp(Method::Stratified).map_or(String::new(), |s| num(s.rays)),
            sp(Method::Stratified).map_or(String::new(), |s| num(s.time)),
            sp(Method::Stratified).map_or(String::new(), |s| s.extrapolated().to_string()),
            r.primary.to_string(),
        ];
        out.push_str(&row.join(","));
        out.push('\n');
    }
    out
}

/// Check the goals on the primary pipeline run; a miss names its cause.
pub fn check_goals(runs: &[RunRecord], goals: &Goals) -> Vec<GoalOutcome> {
    let Some(p) = runs.iter().find(|r| r.primary) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let cause = |p: &RunRecord| match p.bias_variance {
        Some(bv) => format!(
            "error is {}-dominated: bias² {:.3e} vs variance {:.3e} ({:.0}% bias{})",
            bv.dominant().name(),
            bv.bias2,
            bv.variance,
            100.0 * bv.bias_fraction(),
            if bv.clamped { "; bias² clamped at 0" } else { "" }
        ),
        None => "no bias/variance split available".into(),
    };
    for (m, want) in
        [(Method::Independent, goals.speedup_vs_independent), (Method::Stratified, goals.speedup_vs_stratified)]
    {
        let s = p.speedup(m);
        let measured = s.map_or(f64::NAN, |s| s.rays);
        let pass = measured >= want;
        let mut note = String::new();
        if let Some(s) = s {
            if s.extrapolated() {
                note.push_str(&format!("{} curve {}; ", m.name(), s.flag()));
            }
        }
        if !pass {
            note.push_str(&cause(p));
        }
        out.push(GoalOutcome {
            name: format!("equal-RMSE speedup vs {}", m.name()),
            target: format!(">= {want}x"),
            measured,
            pass,
            note: note.trim_end_matches("; ").to_string(),
        });
    }
    let overhead = p.time.filter_overhead();
    let pass = overhead <= goals.max_filter_overhead;
    let note = if pass {
        String::new()
    } else {
        format!(
            "bandwidth {:.1} ms + filter {:.1} ms vs sampling {:.1} ms: {} time dominates",
            p.time.bandwidth * 1e3,
            p.time.filter * 1e3,
            p.time.sampling * 1e3,
            if p.time.bandwidth > p.time.filter { "bandwidth" } else { "filter" }
        )
    };
    out.push(GoalOutcome {
        name: "filter overhead (bandwidth + filter) / sampling".into(),
        target: format!("<= {:.0}%", goals.max_filter_overhead * 100.0),
        measured: overhead,
        pass,
        note,
    });
    out
}

/// The centre quarter of `img` (half the width and height), enlarged by an integer factor to at
/// least 256 pixels wide for viewing (nearest neighbour: pixels stay visible as pixels).
pub fn centre_crop(img: &Image) -> Image {
    let (cw, ch) = ((img.width / 2).max(1), (img.height / 2).max(1));
    let (x0, y0) = (img.width / 4, img.height / 4);
    let k = (256 / cw).max(1);
    Image::from_fn(cw * k, ch * k, |x, y| img.get((x0 + x / k).min(img.width - 1), (y0 + y / k).min(img.height - 1)))
}

fn series(label: String, color: [u8; 3], style: SeriesStyle, points: Vec<(f64, f64)>) -> Series {
    Series { label, color, style, points }
}

fn plot_for(result: &BenchResult, x_of: impl Fn(&RunRecord) -> f64, x_label: &str, title: &str) -> Plot {
    let mut s = Vec::new();
    for (m, c) in [(Method::Independent, RED), (Method::Stratified, BLUE)] {
        let pts: Vec<(f64, f64)> = result.curve_runs(m).map(|r| (x_of(r), r.metrics.rmse)).collect();
        s.push(series(m.name().into(), c, SeriesStyle::LinePoints, pts));
    }
    let ours: Vec<(f64, f64)> = result
        .runs
        .iter()
        .filter(|r| r.method == Method::Pipeline && r.role == Role::Sweep)
        .map(|r| (x_of(r), r.metrics.rmse))
        .collect();
    s.push(series(format!("{} (mu sweep)", Method::Pipeline.name()), GREEN, SeriesStyle::LinePoints, ours));
    if let Some(p) = result.primary() {
        s.push(series(
            format!("{} (pipeline's mu)", Method::Pipeline.name()),
            [0, 90, 0],
            SeriesStyle::Points,
            vec![(x_of(p), p.metrics.rmse)],
        ));
    }
    // Compared pipelines (`--compare`): one series each.
    let mut names: Vec<&str> = result.runs.iter().filter_map(|r| r.compared.as_deref()).collect();
    names.dedup();
    for (k, name) in names.into_iter().enumerate() {
        let pts: Vec<(f64, f64)> = result
            .runs
            .iter()
            .filter(|r| r.compared.as_deref() == Some(name) && r.role == Role::Sweep)
            .map(|r| (x_of(r), r.metrics.rmse))
            .collect();
        let colours = [[148, 103, 189], [255, 127, 14], [140, 86, 75]];
        s.push(series(name.to_string(), colours[k % colours.len()], SeriesStyle::LinePoints, pts));
    }
    let xs: Vec<f64> = result.runs.iter().map(&x_of).filter(|x| x.is_finite() && *x > 0.0).collect();
    let (lo, hi) = xs.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    if lo.is_finite() && result.reference.noise_rmse > 0.0 {
        let n = result.reference.noise_rmse;
        s.push(series("reference noise".into(), GREY, SeriesStyle::Dashed, vec![(lo, n), (hi, n)]));
    }
    Plot { title: title.into(), x_label: x_label.into(), y_label: "RMSE".into(), series: s }
}

fn rel(path: &Path, base: &Path) -> String {
    path.strip_prefix(base).unwrap_or(path).to_string_lossy().replace('\\', "/")
}

/// Write CSV, plots, crops and `report.md` as one all-or-nothing set ([`Staging`]); fills
/// `result.plots`, `result.images`, `result.seconds`.
pub(crate) fn write_all(
    result: &mut BenchResult,
    kept: &KeptImages,
    pipeline_dir: &Path,
    t0: Instant,
) -> Result<(), WedgeError> {
    let out = result.out.clone();
    let mut set = Staging::new(&out)?;
    write_text(&mut set, &out, &result.csv, csv(&result.runs))?;
    write_plots(&mut set, result)?;
    let img_dir = out.join("images");
    let crops = write_crops(&mut set, &out, &img_dir, kept, result.reference.spp)?;
    let full_ref = img_dir.join("reference.png");
    write_png_srgb(&set.file(staged(&full_ref, &out))?, &kept.reference, 1.0)?;
    let errors = write_error_maps(&mut set, &out, &img_dir, kept, result.reference.noise_rmse)?;
    result.images = crops.iter().map(|c| c.1.clone()).chain([full_ref]).chain(errors).collect();

    result.seconds = t0.elapsed().as_secs_f64();
    let md = markdown(result, &crops, pipeline_dir);
    let report = result.report.clone();
    write_text(&mut set, &out, &report, md)?;
    set.commit()?;
    Ok(())
}

/// Every file of the set is named relative to `out`, staged, and moved into place at the end.
fn staged(path: &Path, out: &Path) -> PathBuf {
    path.strip_prefix(out).map(Path::to_path_buf).unwrap_or_else(|_| path.file_name().unwrap_or_default().into())
}

/// Stage the text file `path` (under `out`), its error naming `path`.
fn write_text(set: &mut Staging, out: &Path, path: &Path, text: String) -> Result<(), WedgeError> {
    let staged = set.file(staged(path, out))?;
    std::fs::write(&staged, text)
        .map_err(|source| WedgeError::Image(ImageError::Write { path: path.to_path_buf(), source }))
}

/// The two convergence plots (RMSE against rays and against time), added to `result.plots`.
fn write_plots(set: &mut Staging, result: &mut BenchResult) -> Result<(), WedgeError> {
    let rays_plot = plot_for(result, |r| r.rays.total, "rays per pixel (total)", "RMSE vs rays per pixel (log-log)");
    let time_plot = plot_for(result, |r| r.time.total, "time (s)", "RMSE vs render time (log-log)");
    for (name, plot) in [("error_vs_rays.png", rays_plot), ("error_vs_time.png", time_plot)] {
        write_plot(&set.file(name)?, &plot)?;
        result.plots.push(result.out.join(name));
    }
    Ok(())
}

/// The centre crops the report shows side by side, in its column order: (caption, path) each.
fn write_crops(
    set: &mut Staging,
    out: &Path,
    img_dir: &Path,
    kept: &KeptImages,
    reference_spp: u32,
) -> Result<Vec<(String, PathBuf)>, WedgeError> {
    let mut crops: Vec<(String, PathBuf)> = Vec::new();
    let mut add = |set: &mut Staging, name: &str, caption: String, img: &Image| -> Result<(), WedgeError> {
        let p = img_dir.join(format!("crop_{name}.png"));
        write_png_srgb(&set.file(staged(&p, out))?, &centre_crop(img), 1.0)?;
        crops.push((caption, p));
        Ok(())
    };
    if let Some(u) = &kept.unfiltered {
        add(set, "input", "input (unfiltered)".into(), u)?;
    }
    add(set, "ours", Method::Pipeline.name().into(), &kept.ours)?;
    if let Some((img, n)) = &kept.equal_time {
        add(set, "equal_time_mc", format!("equal-time {} ({n} spp)", Method::Stratified.name()), img)?;
    }
    add(set, "reference", format!("reference ({reference_spp} spp)"), &kept.reference)?;
    Ok(crops)
}

/// Where the error is: squared error per pixel of ours and of equal-time stratified MC, and ours'
/// bias² and variance per 4×4 block, all on one log colour range so the maps compare; their paths.
fn write_error_maps(
    set: &mut Staging,
    out: &Path,
    img_dir: &Path,
    kept: &KeptImages,
    reference_noise_rmse: f64,
) -> Result<Vec<PathBuf>, WedgeError> {
    let ours_err = squared_error_map(&kept.ours, &kept.reference);
    let range = error_range(&ours_err);
    let mut errors = vec![(
        img_dir.join("error_ours.png"),
        format!("squared error: {} (pipeline's mu)", Method::Pipeline.name()),
        ours_err,
    )];
    if let Some((img, n)) = &kept.equal_time {
        let e = squared_error_map(img, &kept.reference);
        errors.push((
            img_dir.join("error_equal_time_mc.png"),
            format!("squared error: equal-time {} ({n} spp)", Method::Stratified.name()),
            e,
        ));
    }
    // Its two parts, per 4×4 block (classes.rs), on the same log range as the squared error.
    let (w, h) = (kept.reference.width, kept.reference.height);
    let reference_variance = reference_noise_rmse * reference_noise_rmse;
    errors.push((
        img_dir.join("error_bias2.png"),
        "bias² per 4x4 block: ours (pipeline's mu)".into(),
        classes::block_map(&kept.pixel_errors, w, h, 4, |mse, var| (mse - var - reference_variance).max(0.0)),
    ));
    errors.push((
        img_dir.join("error_variance.png"),
        "variance per 4x4 block: ours (pipeline's mu)".into(),
        classes::block_map(&kept.pixel_errors, w, h, 4, |_, var| var),
    ));
    for (path, title, values) in &errors {
        let spec = HeatmapSpec { title, unit: "", scale: Scale::Log, range, arrows: None };
        write_heatmap_png(&set.file(staged(path, out))?, w, h, values, None, &spec)?;
    }
    Ok(errors.into_iter().map(|e| e.0).collect())
}

/// Per pixel, the mean over channels of `(ours − reference)²` (the RMSE's own terms; NaN where either
/// is not finite or the sizes differ).
pub fn squared_error_map(test: &Image, reference: &Image) -> Vec<f32> {
    let same = test.width == reference.width && test.height == reference.height;
    test.pixels
        .iter()
        .enumerate()
        .map(|(i, t)| match reference.pixels.get(i).filter(|_| same) {
            Some(r) if t.iter().chain(r).all(|v| v.is_finite()) => {
                (0..3).map(|c| (t[c] - r[c]) * (t[c] - r[c])).sum::<f32>() / 3.0
            }
            _ => f32::NAN,
        })
        .collect()
}

/// A log colour range for squared-error maps: from the 1st to the 99.9th percentile of the positive
/// finite values (a few outliers do not wash out the rest); `None` without such values.
pub fn error_range(values: &[f32]) -> Option<(f32, f32)> {
    let mut v: Vec<f32> = values.iter().copied().filter(|x| x.is_finite() && *x > 0.0).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f32::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    let (lo, hi) = (at(0.01), at(0.999));
    Some(if hi > lo { (lo, hi) } else { (lo, lo * 10.0) })
}

/// A few lines for the terminal: goals and where the files are.
pub fn summary(r: &BenchResult) -> String {
    let mut s = String::new();
    for g in &r.goals {
        let _ = writeln!(
            s,
            "{:<5} {} {} (target {}){}",
            if g.pass { "PASS" } else { "MISS" },
            g.name,
            goal_measured(g),
            g.target,
            if g.note.is_empty() { String::new() } else { format!(": {}", g.note) }
        );
    }
    let _ = writeln!(
        s,
        "reference {} spp ({}), noise RMSE {}; {} runs in {:.1} s",
        r.reference.spp,
        if r.reference.from_cache { "cached" } else { "rendered" },
        sci(r.reference.noise_rmse, 3),
        r.runs.len(),
        r.seconds
    );
    let _ = write!(
        s,
        "wrote {}, {}, {}",
        r.report.display(),
        r.csv.display(),
        r.plots.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
    );
    s
}

/// `report.md`: its sections in reading order, each written by its own function below.
fn markdown(r: &BenchResult, crops: &[(String, PathBuf)], pipeline_dir: &Path) -> String {
    let mut s = String::new();
    let w = &mut s;
    title(w, r);
    reference_section(w, r);
    goals_section(w, r);
    results_section(w, r);
    speedup_section(w, r);
    convergence_section(w, r);
    images_section(w, r, crops);
    class_table(w, &r.error_by_class);
    heatmaps_section(w, pipeline_dir, &r.out);
    definitions_section(w);
    s
}

/// The title and the run's setting: scene, size, seed, quick mode, the whole bench's time.
fn title(w: &mut String, r: &BenchResult) {
    let _ = writeln!(w, "# wedge bench: `{}`\n", r.pipeline_name);
    let _ = writeln!(
        w,
        "Scene `{}`, {}×{}, seed {}{}; the whole bench took {:.1} s.\n",
        r.scene,
        r.width,
        r.height,
        r.seed,
        if r.quick { ", **quick mode**" } else { "" },
        r.seconds
    );
}

/// How the reference was made or found, and its own noise against ours' error (with a warning when
/// it is not much better than the method measured).
fn reference_section(w: &mut String, r: &BenchResult) {
    let rf = &r.reference;
    let _ = writeln!(w, "## Reference\n");
    let _ = writeln!(
        w,
        "Stratified Monte Carlo, {} light samples per pixel: the mean of two renders of {} spp with seeds {} and {}; {} (`{}`, key `{}`; rendering took {:.1} s, this run {:.2} s).",
        rf.spp,
        rf.spp / 2,
        rf.seeds[0],
        rf.seeds[1],
        if rf.from_cache { "**loaded from the cache**" } else { "rendered and cached" },
        rel(&rf.exr, &r.out),
        rf.key,
        rf.render_seconds,
        rf.obtain_seconds
    );
    let ours_rmse = r.primary().map_or(f64::NAN, |p| p.metrics.rmse);
    let _ = writeln!(
        w,
        "Its own estimated noise: RMSE **{}** = RMSE(half A, half B) / 2 ({:.1}% of ours' RMSE {}).{}\n",
        sci(rf.noise_rmse, 3),
        100.0 * rf.noise_rmse / ours_rmse,
        sci(ours_rmse, 3),
        if rf.noise_rmse > 0.5 * ours_rmse {
            " **Warning:** the reference is not much better than the method measured; raise its spp."
        } else {
            ""
        }
    );
}

/// A goal's measured value as the report and the terminal summary print it.
fn goal_measured(g: &GoalOutcome) -> String {
    if g.name.starts_with("filter overhead") {
        format!("{:.2}%", 100.0 * g.measured)
    } else {
        format!("{}x", ratio(g.measured))
    }
}

/// The goals table: target, measured, PASS/MISS and cause, checked on the pipeline's own run.
fn goals_section(w: &mut String, r: &BenchResult) {
    let _ = writeln!(w, "## Goals\n");
    let _ = writeln!(
        w,
        "Checked on {} (the pipeline file's own configuration).\n",
        r.primary().map_or("-".into(), |p| format!("`{}`", p.label))
    );
    let _ = writeln!(w, "| goal | target | measured | result | cause / note |\n|---|---|---|---|---|");
    for g in &r.goals {
        let _ = writeln!(
            w,
            "| {} | {} | {} | **{}** | {} |",
            g.name,
            g.target,
            goal_measured(g),
            if g.pass { "PASS" } else { "MISS" },
            g.note
        );
    }
}

/// The results table: one row per run (second-seed runs apart), its rays, times and error metrics.
fn results_section(w: &mut String, r: &BenchResult) {
    let _ = writeln!(w, "\n## Results\n");
    let _ = writeln!(
        w,
        "| method | mu / spp | rays/px | shadow rays/px | time ms (sampling / bandwidth / filter) | RMSE | relMSE | PSNR dB | SMAPE | FLIP |\n|---|---|---|---|---|---|---|---|---|---|"
    );
    for x in r.runs.iter().filter(|x| x.role != Role::SecondSeed) {
        let setting = match (x.mu, x.spp) {
            (Some(mu), _) => format!("mu {mu}{}", if x.primary { " (pipeline's)" } else { "" }),
            (None, Some(n)) => format!("{n} spp{}", if x.role == Role::EqualTime { " (equal time)" } else { "" }),
            _ => "-".into(),
        };
        let _ = writeln!(
            w,
            "| {} | {} | {:.1} | {:.1} | {:.0} ({:.0} / {:.1} / {:.1}) | {} | {} | {:.2} | {:.4} | {:.4} |",
            x.compared.as_deref().unwrap_or(x.method.name()),
            setting,
            x.rays.total,
            x.rays.shadow,
            x.time.total * 1e3,
            x.time.sampling * 1e3,
            x.time.bandwidth * 1e3,
            x.time.filter * 1e3,
            sci(x.metrics.rmse, 3),
            sci(x.metrics.rel_mse, 3),
            x.metrics.psnr,
            x.metrics.smape,
            x.flip
        );
    }
}

/// The equal-error speedup table (one row per sweep run) and each baseline's log-log fit.
fn speedup_section(w: &mut String, r: &BenchResult) {
    let _ = writeln!(w, "\n## Equal-error speedup, bias and variance\n");
    let _ = writeln!(
        w,
        "| ours | RMSE | bias² | variance | independent MC needs rays/px | speedup rays (time) | stratified MC needs rays/px | speedup rays (time) | filter overhead |\n|---|---|---|---|---|---|---|---|---|"
    );
    for x in r.runs.iter().filter(|x| x.role == Role::Sweep) {
        speedup_row(w, x);
    }
    let _ = writeln!(w);
    for (m, fit) in &r.fits {
        match fit {
            Some(f) => {
                let _ = writeln!(
                    w,
                    "- {}: least-squares log-log fit RMSE ∝ rays^{:.3} (r² = {:.4}).",
                    m.name(),
                    f.slope,
                    f.r2
                );
            }
            None => {
                let _ = writeln!(w, "- {}: too few points for a fit.", m.name());
            }
        }
    }
}

/// One sweep run's row: its error split into bias² and variance, and what each baseline needs for it.
fn speedup_row(w: &mut String, x: &RunRecord) {
    let bv = x.bias_variance;
    let cell = |m: Method| match x.speedup(m) {
        Some(s) => {
            let flag = if s.extrapolated() { format!(" ⚠ {}", s.flag()) } else { String::new() };
            (
                format!("{}{}", s.rays_needed.map_or("n/a".into(), |e| format!("{:.1}", e.cost)), flag),
                format!("{}x ({}x)", ratio(s.rays), ratio(s.time)),
            )
        }
        None => ("n/a".into(), "n/a".into()),
    };
    let (ni, si) = cell(Method::Independent);
    let (ns, ss) = cell(Method::Stratified);
    let _ = writeln!(
        w,
        "| {}{} | {} | {}{} | {} | {} | {} | {} | {} | {:.2}% |",
        match (&x.compared, x.mu) {
            (Some(c), Some(m)) => format!("{c}: mu {m}"),
            (Some(c), None) => c.clone(),
            (None, m) => format!("mu {}", m.map_or("-".into(), |m| m.to_string())),
        },
        if x.primary { " (pipeline's)" } else { "" },
        sci(x.metrics.rmse, 3),
        bv.map_or("n/a".into(), |b| sci(b.bias2, 3)),
        if bv.is_some_and(|b| b.clamped) { " (clamped at 0)" } else { "" },
        bv.map_or("n/a".into(), |b| sci(b.variance, 3)),
        ni,
        si,
        ns,
        ss,
        100.0 * x.time.filter_overhead()
    );
}

/// Links to the convergence plots.
fn convergence_section(w: &mut String, r: &BenchResult) {
    let _ = writeln!(w, "\n## Convergence\n");
    for p in &r.plots {
        let _ = writeln!(w, "![{}]({})", rel(p, &r.out), rel(p, &r.out));
    }
}

/// The crops side by side, then the squared-error maps (when there are any).
fn images_section(w: &mut String, r: &BenchResult, crops: &[(String, PathBuf)]) {
    let out = &r.out;
    let _ = writeln!(w, "\n## Images (centre quarter, sRGB, exposure 1)\n");
    let _ = writeln!(w, "| {} |", crops.iter().map(|c| c.0.clone()).collect::<Vec<_>>().join(" | "));
    let _ = writeln!(w, "|{}", "---|".repeat(crops.len()));
    let _ = writeln!(
        w,
        "| {} |",
        crops.iter().map(|c| format!("![{}]({})", c.0, rel(&c.1, out))).collect::<Vec<_>>().join(" | ")
    );
    let errors: Vec<&PathBuf> =
        r.images.iter().filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("error_"))).collect();
    if !errors.is_empty() {
        let _ = writeln!(w, "\n## Where the error is (squared error per pixel against the reference, one log scale)\n");
        for e in errors {
            let _ = writeln!(w, "![{}]({})", rel(e, out), rel(e, out));
        }
    }
}

/// The pipeline run's own heatmaps (filter width, rays per pixel) where it wrote them.
fn heatmaps_section(w: &mut String, pipeline_dir: &Path, out: &Path) {
    let heat: Vec<PathBuf> = ["filter_width.png", "rays_per_pixel.png"]
        .iter()
        .map(|n| pipeline_dir.join(n))
        .filter(|p| p.exists())
        .collect();
    if !heat.is_empty() {
        let _ = writeln!(w, "\n## Heatmaps of ours (pipeline's mu)\n");
        for h in heat {
            let _ = writeln!(w, "![{}]({})", rel(&h, out), rel(&h, out));
        }
        let _ = writeln!(w, "\nFull images of that run: `{}`.", rel(pipeline_dir, out));
    }
}

/// What the report's columns and terms mean.
fn definitions_section(w: &mut String) {
    let _ = writeln!(
        w,
        "\n## Definitions\n
- **rays/px**: total rays (primary + shadow + secondary) over pixels; the CSV also has each kind.
- **time**: sum of the passes' times; sampling / bandwidth / filter / compose by kernel class.
- **RMSE, relMSE, PSNR, SMAPE**: linear RGB against the reference (`wedge::metrics`); **FLIP**: mean LDR-FLIP of the sRGB 8-bit images.
- **Equal-error speedup**: the rays (seconds) a baseline needs for ours' RMSE, interpolated linearly in log-log between its two bracketing measured runs (first crossing if its curve is not monotone), divided by ours' rays (seconds). Outside its measured range it is extrapolated from the nearest end along its least-squares log-log slope and flagged ⚠ (`extrapolated-beyond`: the baseline needs more than its dearest run; `extrapolated-below`: less than its cheapest).
- **Bias and variance**: variance = mean((X₁ − X₂)²) / 2 from two seeds; bias² = MSE − variance − reference variance, clamped at 0 (and said so) when negative.
- **Reference noise**: RMSE of the two half references / 2 (each half's noise is that / √2, averaging two gains another √2).
- **Filter overhead**: (bandwidth + filter time) / sampling time. Timings on a shared machine are noisy."
    );
}

/// The "Where the error lives" table: each pixel class's share of the squared error, its bias² and
/// variance (classes.rs).
fn class_table(w: &mut String, errors: &[classes::ClassError]) {
    if errors.is_empty() {
        return;
    }
    let _ = writeln!(w, "\n## Where the error lives, by pixel class (ours, pipeline's mu)\n");
    let _ = writeln!(w, "{}\n", classes::summary(errors));
    let _ = writeln!(w, "| partition | class | pixels | share of squared error | MSE | bias² | variance | dominant |\n|---|---|---|---|---|---|---|---|");
    for e in errors {
        let _ = writeln!(
            w,
            "| {} | {} | {:.1}% | {:.1}% | {} | {} | {} | {} |",
            e.partition,
            e.class,
            100.0 * e.pixels,
            100.0 * e.share,
            sci(e.mse, 3),
            sci(e.bias2, 3),
            sci(e.variance, 3),
            e.dominant()
        );
    }
    let _ = writeln!(
        w,
        "\nClasses from the scene's pinhole G-buffer: in focus = circle of confusion ≤ {} px; moving = the surface \
         blurs over ≥ {} px in the shutter; texture edge = albedo luminance step > {} to a 4-neighbour. bias² = MSE − \
         variance − reference variance per class, clamped at 0.",
        classes::IN_FOCUS_COC_PX,
        classes::MOVING_BLUR_PX,
        classes::EDGE_STEP
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crop_is_the_centre_quarter_enlarged() {
        let img = Image::from_fn(8, 4, |x, y| [x as f32, y as f32, 0.0]);
        let c = centre_crop(&img);
        // 4×2 region from (2, 1), enlarged 64× to 256×128.
        assert_eq!((c.width, c.height), (256, 128));
        assert_eq!(c.get(0, 0), [2.0, 1.0, 0.0]);
        assert_eq!(c.get(255, 127), [5.0, 2.0, 0.0]);
    }

    #[test]
    fn squared_error_map_and_its_range() {
        let a = Image::from_fn(2, 1, |x, _| [x as f32, 0.0, 0.0]);
        let b = Image::from_fn(2, 1, |_, _| [0.0, 0.0, 0.0]);
        assert_eq!(squared_error_map(&a, &b), vec![0.0, 1.0 / 3.0]);
        assert!(squared_error_map(&a, &Image::from_fn(1, 1, |_, _| [0.0; 3])).iter().all(|v| v.is_nan()));
        let v: Vec<f32> = (1..=1000).map(|k| k as f32).chain([0.0, f32::NAN]).collect();
        assert_eq!(error_range(&v), Some((11.0, 999.0)));
        assert_eq!(error_range(&[0.0, f32::NAN]), None);
    }

    #[test]
    fn csv_quotes_commas() {
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("ab"), "ab");
        assert_eq!(num(f64::NAN), "");
        assert_eq!(num(0.5), "0.5");
    }
}
