//! `wedge bench --suite`: one pipeline over the built-in scene suite ([`wedge_scene::builtin::SUITE`],
//! issue 16), so a filter is measured on scenes nobody tuned it for.
//!
//! Every scene gets a whole [`super::run`] into `<out>/<scene>/` (its own `report.md`, `bench.csv`,
//! convergence plots, crops and heatmaps), with one reference cache for all of them
//! (`<out>/.cache` unless `cache_dir` is set). From each scene's **primary run** (the pipeline file's
//! own μ) the suite keeps one row: rays per pixel, RMSE, equal-RMSE speedups in rays against
//! independent and stratified Monte Carlo (with their extrapolation flags), bias² / variance, the
//! mean offset against the reference and the filter overhead. It then writes
//!
//! - `suite.md`: the table, a **median** row (per column, over the scenes with a finite value) and
//!   the **worst** row (the scene with the lowest speedup against stratified MC, the goal of issue 16),
//!   each scene's description, links to its report and convergence plots, and the speedup chart;
//! - `suite.csv` and `suite.json`: the same rows for scripts;
//! - `suite_speedup.png`: a bar chart of both speedups per scene (log axis, bars from 1×: slower
//!   than the baseline goes left), with the 1.5× and 2× lines of issue 16's goals.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use super::format::{ratio, sci};
use super::plots::{write_bar_chart, BarChart, BarSeries, BLUE, GREY, RED};
use super::{BenchOptions, BenchResult, Method};
use crate::graph::factoring::CameraSettings;
use crate::graph::{NodeRegistry, ParamValue};
use crate::image::ImageError;
use crate::staging::Staging;
use crate::WedgeError;
use wedge_scene::builtin::SuiteFamily;
use wedge_scene::SceneSource;

/// The default suite: every scene of [`wedge_scene::builtin::SUITE`], as `builtin:NAME` specs.
pub fn default_scenes() -> Vec<String> {
    family_scenes(SuiteFamily::Shadows)
}

/// Every scene of `family`'s suite, as `builtin:NAME` specs.
pub fn family_scenes(family: SuiteFamily) -> Vec<String> {
    family.scenes().iter().map(|(n, _)| format!("builtin:{n}")).collect()
}

/// The names of the camera parameters a node declares to take the thin lens from (the factoring
/// contract's [`CameraSettings::LENS`] without the lens shape): a node that declares both takes
/// each suite scene's lens.
pub(crate) const LENS_PARAMS: [&str; 2] = [CameraSettings::LENS[0], CameraSettings::LENS[1]];

/// The nodes of `pipeline` that declare the thin lens's parameters (by declaration, not by kind).
fn lens_nodes(registry: &NodeRegistry, pipeline: &Path) -> Result<Vec<String>, WedgeError> {
    let loaded = crate::session::load_pipeline_or_default(Some(pipeline))?;
    Ok(loaded
        .pipeline
        .nodes
        .iter()
        .filter(|n| {
            registry.get(&n.kind).is_some_and(|k| {
                let params = k.params();
                LENS_PARAMS.iter().all(|p| params.iter().any(|d| d.name == *p))
            })
        })
        .map(|n| n.name.clone())
        .collect())
}

/// The suite family for `pipeline` as far as its nodes say: the first of [`candidate_families`].
/// `registry` knows the pipeline's node kinds (a user's nodes can name a suite too).
pub fn family_of(registry: &NodeRegistry, pipeline: &Path) -> Result<SuiteFamily, WedgeError> {
    Ok(candidate_families(registry, pipeline)?[0])
}

/// The suites that could measure `pipeline`, in the order `--suite` tries them: the one its
/// factoring node names, then those its other nodes name in file order
/// ([`crate::graph::NodeKind::bench_suite`]: Defocus the defocus suite, Motion the motion suite,
/// Environment the environment suite), then the soft-shadow suite. The factoring node comes first
/// because the suite is there to stress what the pipeline factors: the environment suite's scenes
/// are static, so `motion_environment.ron` on them would measure its Environment node alone (Motion
/// factors nothing on a static scene). A name that is no family is an error naming the node kind.
pub fn candidate_families(registry: &NodeRegistry, pipeline: &Path) -> Result<Vec<SuiteFamily>, WedgeError> {
    let loaded = crate::session::load_pipeline_or_default(Some(pipeline))?;
    // Decided without a scene (a node factors where a scene could need it); an invalid pipeline
    // is refused with its own errors when the scenes are checked.
    let factoring = crate::graph::validate(&loaded, registry).ok().and_then(|v| v.factoring).map(|f| f.node);
    let nodes = &loaded.pipeline.nodes;
    let factoring_first = nodes.iter().filter(|n| Some(&n.name) == factoring.as_ref());
    let mut families = Vec::new();
    for node in factoring_first.chain(nodes.iter()) {
        let Some(name) = registry.get(&node.kind).and_then(|k| k.bench_suite()) else { continue };
        let family = SuiteFamily::parse(name).ok_or_else(|| {
            let known: Vec<&str> = SuiteFamily::ALL.iter().map(|f| f.name()).collect();
            WedgeError::Usage(format!(
                "node kind `{}` names the bench suite `{name}`, which is none of {}",
                node.kind,
                known.join(", ")
            ))
        })?;
        if !families.contains(&family) {
            families.push(family);
        }
    }
    if !families.contains(&SuiteFamily::Shadows) {
        families.push(SuiteFamily::Shadows);
    }
    Ok(families)
}

/// The suite `--suite` runs for `opts` without `--suite-scenes`: the first of
/// [`candidate_families`] whose every scene the pipeline can render (checked as the scenes would
/// run, `--set` included) — `defocus_environment.ron` needs a map the defocus suite's scenes lack, so
/// it runs the environment suite. Where none fits, the first family's refusals.
pub fn suite_for(opts: &BenchOptions) -> Result<(SuiteFamily, Vec<String>), WedgeError> {
    let families = candidate_families(&opts.registries.nodes, &opts.pipeline)?;
    let mut first_refusal = None;
    for &family in &families {
        let scenes = family_scenes(family);
        match scene_plan(opts, &scenes, &opts.out, None) {
            Ok(_) => return Ok((family, scenes)),
            Err(e) => {
                first_refusal.get_or_insert(e);
            }
        }
    }
    let tried: Vec<&str> = families.iter().map(|f| f.name()).collect();
    Err(match first_refusal {
        Some(WedgeError::Usage(m)) => {
            WedgeError::Usage(format!("no suite fits (tried the {} suites); the first: {m}", tried.join(", ")))
        }
        Some(other) => other,
        None => WedgeError::Usage("no suite to run".into()),
    })
}

/// The family whose suite holds every one of `scenes` (scene specs), if one does.
fn family_of_scenes(scenes: &[String]) -> Option<SuiteFamily> {
    SuiteFamily::ALL.into_iter().find(|f| scenes.iter().all(|s| f.scenes().iter().any(|(n, _)| scene_key(s) == *n)))
}

/// `--set` overrides that give every lens-taking node of `pipeline` the lens of the built-in scene
/// `spec`'s camera (none for a scene without an aperture): the defocus suite's scenes each state
/// their lens, as a pipeline states its own.
pub fn lens_params(
    registry: &NodeRegistry,
    pipeline: &Path,
    spec: &str,
) -> Result<Vec<(String, String, ParamValue)>, WedgeError> {
    let Some(name) = spec.strip_prefix("builtin:") else {
        return Ok(Vec::new());
    };
    let scene = wedge_scene::load(&SceneSource::Builtin(name.to_string()))?;
    let cam = scene.camera;
    if cam.aperture_radius <= 0.0 {
        return Ok(Vec::new());
    }
    let values = [cam.aperture_radius, cam.effective_focus_distance()];
    Ok(lens_nodes(registry, pipeline)?
        .into_iter()
        .flat_map(|node| {
            LENS_PARAMS
                .iter()
                .zip(values)
                .map(move |(p, v)| (node.clone(), p.to_string(), ParamValue::Float(f64::from(v))))
        })
        .collect())
}

/// The name a scene spec gets in the suite (its directory under `<out>`): a built-in's name, or a
/// file's stem.
pub fn scene_key(spec: &str) -> String {
    if let Some(name) = spec.strip_prefix("builtin:") {
        return name.to_string();
    }
    if wedge_scene::builtin_names().contains(&spec) {
        return spec.to_string();
    }
    Path::new(spec).file_stem().map_or_else(|| spec.to_string(), |s| s.to_string_lossy().into_owned())
}

/// One scene's primary run.
#[derive(Clone, Debug, Serialize)]
pub struct SuiteRow {
    /// The scene's key (built-in name or file stem) and directory name under the suite's `out`.
    pub scene: String,
    /// What the scene tests ([`wedge_scene::builtin::describe`]; empty for a scene outside the suite).
    pub description: String,
    /// The pipeline's μ for this row (`None` when no node has one).
    pub mu: Option<f64>,
    pub rays_per_pixel: f64,
    pub rmse: f64,
    /// Equal-RMSE speedup in rays against independent Monte Carlo (NaN: no estimate).
    pub speedup_vs_independent: f64,
    pub extrapolated_vs_independent: bool,
    /// Equal-RMSE speedup in rays against stratified Monte Carlo (NaN: no estimate).
    pub speedup_vs_stratified: f64,
    pub extrapolated_vs_stratified: bool,
    pub bias2: f64,
    pub variance: f64,
    /// bias² / (bias² + variance).
    pub bias_fraction: f64,
    /// mean(ours) / mean(reference) − 1 over all pixels and channels.
    pub mean_offset: f64,
    /// (bandwidth + filter time) / sampling time.
    pub filter_overhead: f64,
    /// The reference's own estimated RMSE.
    pub reference_noise_rmse: f64,
    /// The scene's whole bench, seconds.
    pub seconds: f64,
    /// Where the error lives ([`super::classes::summary`]): per pixel partition, the class with
    /// the largest share of the squared error and what dominates it.
    pub error_home: String,
}

impl SuiteRow {
    /// The row of `r`'s primary run (`scene` and `description` as given).
    pub fn from_result(scene: &str, description: &str, r: &BenchResult) -> SuiteRow {
        let p = r.primary();
        let speed = |m: Method| p.and_then(|p| p.speedup(m));
        let bv = p.and_then(|p| p.bias_variance);
        SuiteRow {
            scene: scene.to_string(),
            description: description.to_string(),
            mu: p.and_then(|p| p.mu),
            rays_per_pixel: p.map_or(f64::NAN, |p| p.rays.total),
            rmse: p.map_or(f64::NAN, |p| p.metrics.rmse),
            speedup_vs_independent: speed(Method::Independent).map_or(f64::NAN, |s| s.rays),
            extrapolated_vs_independent: speed(Method::Independent).is_some_and(|s| s.extrapolated()),
            speedup_vs_stratified: speed(Method::Stratified).map_or(f64::NAN, |s| s.rays),
            extrapolated_vs_stratified: speed(Method::Stratified).is_some_and(|s| s.extrapolated()),
            bias2: bv.map_or(f64::NAN, |b| b.bias2),
            variance: bv.map_or(f64::NAN, |b| b.variance),
            bias_fraction: bv.map_or(f64::NAN, |b| b.bias_fraction()),
            mean_offset: r.mean_offset,
            filter_overhead: p.map_or(f64::NAN, |p| p.time.filter_overhead()),
            reference_noise_rmse: r.reference.noise_rmse,
            seconds: r.seconds,
            error_home: super::classes::summary(&r.error_by_class),
        }
    }

    /// The numeric columns, in [`SUITE_COLUMNS`] order after `scene` and `mu`.
    fn numbers(&self) -> [f64; 12] {
        [
            self.rays_per_pixel,
            self.rmse,
            self.speedup_vs_independent,
            self.speedup_vs_stratified,
            self.bias2,
            self.variance,
            self.bias_fraction,
            self.mean_offset,
            self.filter_overhead,
            self.reference_noise_rmse,
            self.seconds,
            self.mu.unwrap_or(f64::NAN),
        ]
    }
}

/// Column names of `suite.csv`, in order.
pub const SUITE_COLUMNS: &[&str] = &[
    "scene",
    "mu",
    "rays_per_pixel",
    "rmse",
    "speedup_rays_vs_independent",
    "extrapolated_vs_independent",
    "speedup_rays_vs_stratified",
    "extrapolated_vs_stratified",
    "bias2",
    "variance",
    "bias_fraction",
    "mean_offset",
    "filter_overhead",
    "reference_noise_rmse",
    "seconds",
];

/// Per-column medians over the rows (each over the rows where that column is finite; NaN where none).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct SuiteMedian {
    pub rays_per_pixel: f64,
    pub rmse: f64,
    pub speedup_vs_independent: f64,
    pub speedup_vs_stratified: f64,
    pub bias2: f64,
    pub variance: f64,
    pub bias_fraction: f64,
    pub mean_offset: f64,
    pub filter_overhead: f64,
    pub reference_noise_rmse: f64,
    pub seconds: f64,
}

/// The median of the finite values (the mean of the two middle ones for an even count); NaN when
/// there is none.
pub fn median(values: impl IntoIterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.into_iter().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Medians of every numeric column of `rows`.
pub fn column_medians(rows: &[SuiteRow]) -> SuiteMedian {
    let col = |k: usize| median(rows.iter().map(|r| r.numbers()[k]));
    SuiteMedian {
        rays_per_pixel: col(0),
        rmse: col(1),
        speedup_vs_independent: col(2),
        speedup_vs_stratified: col(3),
        bias2: col(4),
        variance: col(5),
        bias_fraction: col(6),
        mean_offset: col(7),
        filter_overhead: col(8),
        reference_noise_rmse: col(9),
        seconds: col(10),
    }
}

/// Index of the worst row: the lowest finite speedup against stratified Monte Carlo (ties: the
/// first). A row without an estimate (NaN) is never the worst; `None` when no row has one.
pub fn worst_row(rows: &[SuiteRow]) -> Option<usize> {
    rows.iter()
        .enumerate()
        .filter(|(_, r)| r.speedup_vs_stratified.is_finite())
        .min_by(|a, b| a.1.speedup_vs_stratified.total_cmp(&b.1.speedup_vs_stratified))
        .map(|(i, _)| i)
}

/// What `wedge bench --suite` measured and wrote.
#[derive(Clone, Debug, Serialize)]
pub struct SuiteResult {
    pub pipeline_name: String,
    /// Which suite's goals the table is read against.
    #[serde(serialize_with = "family_name")]
    pub family: SuiteFamily,
    pub width: u32,
    pub height: u32,
    pub quick: bool,
    pub reference_spp: u32,
    pub rows: Vec<SuiteRow>,
    pub median: SuiteMedian,
    /// Index into `rows` of the worst scene ([`worst_row`]).
    pub worst: Option<usize>,
    pub out: PathBuf,
    /// `suite.md`, `suite.csv`, `suite.json`, `suite_speedup.png`.
    pub table: PathBuf,
    pub csv: PathBuf,
    pub json: PathBuf,
    pub plot: PathBuf,
    pub seconds: f64,
}

fn family_name<S: serde::Serializer>(f: &SuiteFamily, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(f.name())
}

impl SuiteResult {
    pub fn worst_row(&self) -> Option<&SuiteRow> {
        self.worst.map(|i| &self.rows[i])
    }
}

/// A bar over the scenes (indicatif, on a terminal only).
fn scene_bar(len: u64) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("suite [{bar:30}] {pos}/{len} scenes {elapsed_precise} {wide_msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar
}

/// The bench of one suite scene: `opts` on `spec`, into `<opts.out>/<key>/`, with the scene's lens on
/// the nodes that take one and seen from the scene's own camera.
fn scene_options(
    opts: &BenchOptions,
    spec: &str,
    key: &str,
    cache: &Path,
    bar: Option<ProgressBar>,
) -> Result<BenchOptions, WedgeError> {
    let mut params = opts.params.clone();
    params.extend(lens_params(&opts.registries.nodes, &opts.pipeline, spec)?);
    Ok(BenchOptions {
        scene: Some(spec.to_string()),
        params,
        out: opts.out.join(key),
        cache_dir: Some(cache.to_path_buf()),
        progress: bar,
        // Each suite scene is seen from its own camera, not from the one the pipeline's
        // `camera:` block was written for (its shutter is kept).
        scene_camera: true,
        ..opts.clone()
    })
}

/// Each of `scenes` as its key (its directory under `<opts.out>`) and its bench ([`scene_options`]),
/// the pipeline checked against every one before any renders ([`check_scenes`]); a key given twice
/// is refused.
fn scene_plan(
    opts: &BenchOptions,
    scenes: &[String],
    cache: &Path,
    bar: Option<ProgressBar>,
) -> Result<Vec<(String, BenchOptions)>, WedgeError> {
    let keys: Vec<String> = scenes.iter().map(|s| scene_key(s)).collect();
    for (i, k) in keys.iter().enumerate() {
        if keys[..i].contains(k) {
            return Err(WedgeError::Usage(format!("scene `{k}` appears twice in the suite")));
        }
    }
    let per_scene = scenes
        .iter()
        .zip(&keys)
        .map(|(spec, key)| scene_options(opts, spec, key, cache, bar.clone()))
        .collect::<Result<Vec<_>, _>>()?;
    check_scenes(&per_scene, &keys)?;
    Ok(keys.into_iter().zip(per_scene).collect())
}

/// The pipeline checked against every suite scene before the first renders — a scene it cannot
/// render (a light the scene lacks, a combination its motion refuses) would otherwise stop the suite
/// after the scenes before it, minutes to hours in. Every refusal is reported at once, by scene.
fn check_scenes(per_scene: &[BenchOptions], keys: &[String]) -> Result<(), WedgeError> {
    let refused: Vec<String> = per_scene
        .iter()
        .zip(keys)
        .filter_map(|(o, key)| {
            let session = crate::Session::open_with(&o.registries, Some(&o.pipeline), &super::base_overrides(o));
            session.err().map(|e| format!("scene `{key}`: {e}"))
        })
        .collect();
    if refused.is_empty() {
        return Ok(());
    }
    Err(WedgeError::Usage(format!(
        "the pipeline cannot render {} of the suite's {} scenes, so nothing was run:\n{}\n(choose scenes it can \
         render with --suite-scenes, or bench one scene with --scene)",
        refused.len(),
        keys.len(),
        refused.join("\n")
    )))
}

/// Run `opts`' pipeline over `scenes` (scene specs: `builtin:NAME`, a built-in name or a file; the
/// default suite is [`default_scenes`]), each into `<opts.out>/<key>/`, then write the suite's
/// table, CSV, JSON and chart into `opts.out`. `opts.scene` must be `None` (the suite chooses the
/// scenes).
pub fn run_suite(opts: &BenchOptions, scenes: &[String]) -> Result<SuiteResult, WedgeError> {
    if opts.scene.is_some() {
        return Err(WedgeError::Usage("--suite runs the suite's scenes; it cannot be combined with --scene".into()));
    }
    if scenes.is_empty() {
        return Err(WedgeError::Usage("the scene suite is empty".into()));
    }
    let t0 = Instant::now();
    // Before the scenes run, so a pipeline whose node names no suite fails at once, not after them;
    // the goals read are the family's whose suite the scenes are (else the pipeline's first).
    let family = match family_of_scenes(scenes) {
        Some(f) => f,
        None => family_of(&opts.registries.nodes, &opts.pipeline)?,
    };
    let cache = opts.cache_dir.clone().unwrap_or_else(|| opts.out.join(".cache"));
    let bar = opts.verbose.then(|| scene_bar(scenes.len() as u64));
    let say = |line: String| match &bar {
        Some(b) if !b.is_hidden() => b.println(line),
        Some(_) => eprintln!("{line}"),
        None => {}
    };
    let plan = scene_plan(opts, scenes, &cache, bar.clone())?;
    std::fs::create_dir_all(&opts.out)
        .map_err(|source| WedgeError::Image(ImageError::Write { path: opts.out.clone(), source }))?;
    let mut rows = Vec::new();
    let (mut size, mut reference_spp) = ((0, 0), 0);
    for (key, scene_opts) in &plan {
        if let Some(b) = &bar {
            b.set_message(format!("{key}: starting"));
        }
        say(format!("suite: scene `{key}` ({}/{})", rows.len() + 1, scenes.len()));
        let r = super::run(scene_opts)?;
        let description = wedge_scene::builtin::describe(key).unwrap_or("");
        let row = SuiteRow::from_result(key, description, &r);
        say(format!(
            "suite: `{key}`: {:.1} rays/px, {}x vs independent, {}x vs stratified, {:.0}% bias, {:.1} s",
            row.rays_per_pixel,
            ratio(row.speedup_vs_independent),
            ratio(row.speedup_vs_stratified),
            100.0 * row.bias_fraction,
            row.seconds
        ));
        size = (r.width, r.height);
        reference_spp = r.reference.spp;
        rows.push(row);
        if let Some(b) = &bar {
            b.inc(1);
        }
    }
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let pipeline_name = opts.pipeline.file_stem().map_or("pipeline".into(), |s| s.to_string_lossy().into_owned());
    let median = column_medians(&rows);
    let worst = worst_row(&rows);
    let out = opts.out.clone();
    let mut result = SuiteResult {
        pipeline_name,
        family,
        width: size.0,
        height: size.1,
        quick: opts.quick,
        reference_spp,
        rows,
        median,
        worst,
        table: out.join("suite.md"),
        csv: out.join("suite.csv"),
        json: out.join("suite.json"),
        plot: out.join("suite_speedup.png"),
        out,
        seconds: 0.0,
    };
    result.seconds = t0.elapsed().as_secs_f64();
    write_files(&result)?;
    Ok(result)
}

/// Write `suite.md`, `suite.csv`, `suite.json` and `suite_speedup.png` as one set ([`Staging`]).
fn write_files(r: &SuiteResult) -> Result<(), WedgeError> {
    let mut set = Staging::new(&r.out)?;
    let text = |set: &mut Staging, path: &Path, body: String| -> Result<(), WedgeError> {
        let name = path.file_name().map(PathBuf::from).unwrap_or_default();
        std::fs::write(set.file(name)?, body)
            .map_err(|source| WedgeError::Image(ImageError::Write { path: path.to_path_buf(), source }))
    };
    text(&mut set, &r.csv, csv(&r.rows))?;
    let json = serde_json::to_string_pretty(r).map_err(|e| WedgeError::Usage(format!("suite.json: {e}")))?;
    text(&mut set, &r.json, json + "\n")?;
    write_bar_chart(&set.file("suite_speedup.png")?, &chart(r))?;
    text(&mut set, &r.table, markdown(r))?;
    set.commit()?;
    Ok(())
}

fn num(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else {
        String::new()
    }
}

/// The CSV text: a header ([`SUITE_COLUMNS`]) and one row per scene.
pub fn csv(rows: &[SuiteRow]) -> String {
    let mut s = SUITE_COLUMNS.join(",");
    s.push('\n');
    for r in rows {
        let fields = [
            r.scene.clone(),
            r.mu.map_or(String::new(), |m| m.to_string()),
            num(r.rays_per_pixel),
            num(r.rmse),
            num(r.speedup_vs_independent),
            r.extrapolated_vs_independent.to_string(),
            num(r.speedup_vs_stratified),
            r.extrapolated_vs_stratified.to_string(),
            num(r.bias2),
            num(r.variance),
            num(r.bias_fraction),
            num(r.mean_offset),
            num(r.filter_overhead),
            num(r.reference_noise_rmse),
            num(r.seconds),
        ];
        s.push_str(&fields.map(|f| super::report::csv_field(&f)).join(","));
        s.push('\n');
    }
    s
}

fn pct(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("{:.*}%", digits, 100.0 * v)
    } else {
        "n/a".into()
    }
}

fn signed_pct(v: f64) -> String {
    if v.is_finite() {
        format!("{:+.1}%", 100.0 * v)
    } else {
        "n/a".into()
    }
}

fn chart(r: &SuiteResult) -> BarChart {
    BarChart {
        title: format!("{}: equal-RMSE speedup in rays per scene (pipeline's mu)", r.pipeline_name),
        x_label: "speedup (baseline rays / ours at equal RMSE), log scale; bars start at 1x".into(),
        categories: r.rows.iter().map(|x| x.scene.clone()).collect(),
        series: vec![
            BarSeries {
                label: "vs stratified MC".into(),
                color: BLUE,
                values: r.rows.iter().map(|x| x.speedup_vs_stratified).collect(),
            },
            BarSeries {
                label: "vs independent MC".into(),
                color: RED,
                values: r.rows.iter().map(|x| x.speedup_vs_independent).collect(),
            },
        ],
        base: 1.0,
        lines: vec![("1.5x".into(), 1.5, GREY), ("2x".into(), 2.0, [0, 0, 0])],
    }
}

/// A terminal summary: median, worst, where the files are.
pub fn summary(r: &SuiteResult) -> String {
    let mut s = String::new();
    let m = &r.median;
    let _ = writeln!(
        s,
        "suite of {} scenes: median {} rays/px, {}x vs independent, {}x vs stratified, {} bias, filter overhead {}",
        r.rows.len(),
        ratio(m.rays_per_pixel),
        ratio(m.speedup_vs_independent),
        ratio(m.speedup_vs_stratified),
        pct(m.bias_fraction, 0),
        pct(m.filter_overhead, 1)
    );
    if let Some(w) = r.worst_row() {
        let _ = writeln!(
            s,
            "worst: `{}` {}x vs stratified ({}x vs independent, {} bias)",
            w.scene,
            ratio(w.speedup_vs_stratified),
            ratio(w.speedup_vs_independent),
            pct(w.bias_fraction, 0)
        );
    }
    let _ = write!(
        s,
        "{:.1} s; wrote {}, {}, {}, {}",
        r.seconds,
        r.table.display(),
        r.csv.display(),
        r.json.display(),
        r.plot.display()
    );
    s
}

fn flag(extrapolated: bool) -> &'static str {
    if extrapolated {
        " ⚠"
    } else {
        ""
    }
}

/// `suite.md`.
pub fn markdown(r: &SuiteResult) -> String {
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(w, "# wedge bench --suite: `{}`\n", r.pipeline_name);
    let _ = writeln!(
        w,
        "{} scenes at {}×{}{}, reference {} spp per scene; {:.0} s in all. Each row is the pipeline's own μ \
         (the file's); each scene's full report (μ sweep, baselines, crops, heatmaps) is linked.\n",
        r.rows.len(),
        r.width,
        r.height,
        if r.quick { " (**quick mode**: smoke numbers, not the method's quality)" } else { "" },
        r.reference_spp,
        r.seconds
    );
    let _ = writeln!(
        w,
        "| scene | μ | rays/px | RMSE | vs independent | vs stratified | bias² | variance | bias share | mean offset | filter overhead | where the error lives |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    let row_cells = |x: &SuiteRow| {
        format!(
            "{} | {} | {} | {}x{} | {}x{} | {} | {} | {} | {} | {} | {}",
            x.mu.map_or("-".into(), |m| m.to_string()),
            ratio(x.rays_per_pixel),
            sci(x.rmse, 2),
            ratio(x.speedup_vs_independent),
            flag(x.extrapolated_vs_independent),
            ratio(x.speedup_vs_stratified),
            flag(x.extrapolated_vs_stratified),
            sci(x.bias2, 2),
            sci(x.variance, 2),
            pct(x.bias_fraction, 0),
            signed_pct(x.mean_offset),
            pct(x.filter_overhead, 1),
            x.error_home
        )
    };
    for x in &r.rows {
        let _ = writeln!(w, "| [{}]({}/report.md) | {} |", x.scene, x.scene, row_cells(x));
    }
    let m = &r.median;
    let _ = writeln!(
        w,
        "| **median** | | {} | {} | **{}x** | **{}x** | {} | {} | {} | {} | {} | |",
        ratio(m.rays_per_pixel),
        sci(m.rmse, 2),
        ratio(m.speedup_vs_independent),
        ratio(m.speedup_vs_stratified),
        sci(m.bias2, 2),
        sci(m.variance, 2),
        pct(m.bias_fraction, 0),
        signed_pct(m.mean_offset),
        pct(m.filter_overhead, 1)
    );
    if let Some(x) = r.worst_row() {
        let _ = writeln!(w, "| **worst: {}** | {} |", x.scene, row_cells(x));
    }
    let _ = writeln!(
        w,
        "\nThe median is per column (over the scenes with a value); the worst row is the scene with the lowest speedup \
         against stratified MC. ⚠ = the baseline's rays were extrapolated beyond its measured curve (see that scene's report).\n"
    );
    let below =
        |t: f64| r.rows.iter().filter(|x| x.speedup_vs_stratified.is_finite() && x.speedup_vs_stratified < t).count();
    let goals = match r.family {
        SuiteFamily::Shadows => {
            "Issue 16's goals against stratified MC (SoftShadows: median ≥ 2×, worst ≥ 1.5×, ≥ 10× against independent; \
             Indirect: median ≥ 1.5×; AO: mean within 2%)"
        }
        SuiteFamily::Defocus => {
            "Issue 35's goals against stratified MC over lens and light (Defocus pipelines at 640×480: median ≥ 3×, worst ≥ \
             1.5×, ≥ 8× against independent everywhere; mean within 1%)"
        }
        SuiteFamily::Motion => {
            "Issue 35's goals against stratified MC over time and light (Motion pipelines at 640×480: median ≥ 3×, worst ≥ \
             1.5×; mean within 1%)"
        }
        SuiteFamily::Environment => {
            "Issue 35's goals against stratified MC over the map (Environment pipelines at 640×480: median ≥ 4×, worst ≥ \
             2×; mean within 1%)"
        }
    };
    let _ = writeln!(
        w,
        "{goals}: median **{}x**, worst **{}x**; {} of {} scenes below 1.5×, {} below 2×; \
         median against independent {}x; median |mean offset| {}.\n",
        ratio(m.speedup_vs_stratified),
        r.worst_row().map_or("n/a".into(), |x| ratio(x.speedup_vs_stratified)),
        below(1.5),
        r.rows.len(),
        below(2.0),
        ratio(m.speedup_vs_independent),
        pct(median(r.rows.iter().map(|x| x.mean_offset.abs())), 1)
    );
    let _ = writeln!(w, "![speedup per scene](suite_speedup.png)\n");
    let _ = writeln!(w, "## Scenes\n");
    for x in &r.rows {
        let _ = writeln!(
            w,
            "- **{}**: {}[report]({}/report.md), [error vs rays]({}/error_vs_rays.png), [error vs time]({}/error_vs_time.png), \
             [filter width]({}/pipeline/filter_width.png), [rays per pixel]({}/pipeline/rays_per_pixel.png).",
            x.scene,
            if x.description.is_empty() { String::new() } else { format!("{} — ", x.description) },
            x.scene,
            x.scene,
            x.scene,
            x.scene,
            x.scene
        );
    }
    let _ = writeln!(
        w,
        "\n## Definitions\n\n\
         - **rays/px**: total rays per pixel (primary + shadow + secondary) of the pipeline's run.\n\
         - **vs independent / vs stratified**: equal-RMSE speedup in rays, the baseline's rays for ours' RMSE (read off its \
         measured log-log curve) over ours'.\n\
         - **bias², variance**: the MSE split from two seeds with the reference's noise removed; **bias share** = bias² / \
         (bias² + variance).\n\
         - **mean offset**: mean(ours) / mean(reference) − 1 over all pixels and channels (issue 16's AO goal: within ±2%).\n\
         - **where the error lives**: per pixel partition (focus with a lens, texture), the class with the largest share of \
         the squared error and whether bias² or variance dominates it (each scene's report has the whole table and the \
         bias² / variance maps).\n\
         - **filter overhead**: (bandwidth + filter time) / sampling time."
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(scene: &str, strat: f64, indep: f64) -> SuiteRow {
        SuiteRow {
            scene: scene.into(),
            description: String::new(),
            mu: Some(2.0),
            rays_per_pixel: 10.0,
            rmse: 0.01,
            speedup_vs_independent: indep,
            extrapolated_vs_independent: false,
            speedup_vs_stratified: strat,
            extrapolated_vs_stratified: false,
            bias2: 1e-5,
            variance: 1e-5,
            bias_fraction: 0.5,
            mean_offset: 0.0,
            filter_overhead: 0.01,
            reference_noise_rmse: 1e-4,
            seconds: 1.0,
            error_home: "out of focus 80% (variance)".into(),
        }
    }

    #[test]
    fn median_of_odd_even_and_non_finite() {
        assert_eq!(median([3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median([4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median([f64::NAN, 5.0, f64::INFINITY, 1.0]), 3.0);
        assert!(median([f64::NAN]).is_nan());
        assert!(median(std::iter::empty()).is_nan());
    }

    #[test]
    fn worst_is_the_lowest_finite_speedup_vs_stratified() {
        let rows = [row("a", 2.5, 20.0), row("b", 1.2, 30.0), row("c", f64::NAN, 1.0), row("d", 1.9, 5.0)];
        assert_eq!(worst_row(&rows), Some(1));
        assert_eq!(worst_row(&rows[2..3]), None);
        let m = column_medians(&rows);
        assert_eq!(m.speedup_vs_stratified, 1.9, "median of 1.2, 1.9, 2.5 (NaN left out)");
        assert_eq!(m.speedup_vs_independent, 12.5, "median of 1, 5, 20, 30");
        assert_eq!(m.rays_per_pixel, 10.0);
    }

    #[test]
    fn scene_keys_and_the_default_suite() {
        assert_eq!(scene_key("builtin:suite_grate"), "suite_grate");
        assert_eq!(scene_key("cornell"), "cornell");
        assert_eq!(scene_key("scenes/my room.gltf"), "my room");
        let d = default_scenes();
        assert!(d.len() >= 8 && d.iter().all(|s| s.starts_with("builtin:")));
    }

    #[test]
    fn csv_and_markdown_have_every_row_median_and_worst() {
        let rows = vec![row("a", 2.5, 20.0), row("b", 1.2, 30.0)];
        let r = SuiteResult {
            pipeline_name: "shadows".into(),
            family: SuiteFamily::Shadows,
            width: 8,
            height: 6,
            quick: true,
            reference_spp: 64,
            median: column_medians(&rows),
            worst: worst_row(&rows),
            rows,
            out: PathBuf::from("o"),
            table: PathBuf::from("o/suite.md"),
            csv: PathBuf::from("o/suite.csv"),
            json: PathBuf::from("o/suite.json"),
            plot: PathBuf::from("o/suite_speedup.png"),
            seconds: 1.0,
        };
        let c = csv(&r.rows);
        assert_eq!(c.lines().count(), 3);
        assert_eq!(c.lines().next().unwrap().split(',').count(), SUITE_COLUMNS.len());
        let md = markdown(&r);
        assert!(md.contains("| **median** |") && md.contains("**1.85x**"), "{md}");
        assert!(md.contains("| **worst: b** |"), "{md}");
        assert!(md.contains("[a](a/report.md)") && md.contains("suite_speedup.png"));
    }
}
