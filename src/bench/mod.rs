//! `wedge bench`: the evaluation harness. For one pipeline file it measures, in one run,
//!
//! 1. a **reference**: plain stratified Monte Carlo at a high sample count, rendered as two halves
//!    with different seeds (their mean is the reference, their difference its noise estimate,
//!    [`stats`]), cached on disk by content ([`reference_cache`]);
//! 2. the **pipeline** at several `mu` values, each with a second seed for the bias/variance split;
//! 3. two **baselines** from [`Session::reference`] at several sample counts: independent
//!    ("standard") and stratified Monte Carlo;
//! 4. per run: rays per pixel, time per kernel class, RMSE, relMSE, PSNR, SMAPE, FLIP; per pipeline
//!    run the **equal-error speedup** against each baseline — the rays (time) the baseline needs for
//!    the pipeline's RMSE, interpolated on its measured log-log curve ([`curves`]), over the
//!    pipeline's — and the filter overhead;
//! 5. files: `bench.csv`, `error_vs_rays.png`, `error_vs_time.png`, `report.md`, image crops and
//!    the pipeline run's own outputs (heatmaps) under `pipeline/` ([`report`]).
//!
//! `--compare OTHER.ron` ([`BenchOptions::compare`]) adds another pipeline's sweep ([`Method::Compared`])
//! on the same scene, size, seeds and reference, with its own speedups, in the same tables and plots.
//!
//! Everything comes from the pipeline file through [`Session`], so any effect pipeline whose
//! scene the `MonteCarlo` node can render is benchmarked unchanged.
//!
//! **Rays** are total rays per pixel (primary + shadow + secondary) — the whole ray cost of each
//! method, so the ratio is the same kind of number for every effect; the CSV also has each kind.
//! **Time** is the sum of the passes' measured times (wall-clock per pass).

pub mod classes;
pub mod curves;
pub mod flip;
pub mod format;
pub mod mono_text;
pub mod plots;
pub mod reference_cache;
pub mod report;
pub mod stats;
pub mod suite;

use std::path::{Path, PathBuf};
use std::time::Instant;

use wedge_backends::cpu::CpuBackend;
use wedge_backends::{KernelClass, RunResult, Silent};
use wedge_scene::SceneSource;

use crate::image::Image;
use crate::metrics::{compare, Metrics};
use crate::outputs::buffer_to_image;
use crate::{Overrides, Session, WedgeError};
use curves::{CostEstimate, Curve, Point};
use reference_cache::ReferenceSpec;
use stats::{split_bias_variance, BiasVariance};

/// The targets the report checks (issue #3's, for the soft-shadow pipeline).
#[derive(Clone, Copy, Debug)]
pub struct Goals {
    /// Equal-RMSE speedup in rays against independent Monte Carlo, at least.
    pub speedup_vs_independent: f64,
    /// Equal-RMSE speedup in rays against stratified Monte Carlo, at least.
    pub speedup_vs_stratified: f64,
    /// (bandwidth + filter time) / sampling time, at most.
    pub max_filter_overhead: f64,
}

impl Default for Goals {
    fn default() -> Self {
        Goals { speedup_vs_independent: 6.0, speedup_vs_stratified: 1.5, max_filter_overhead: 0.05 }
    }
}

/// What to benchmark and how hard.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    pub pipeline: PathBuf,
    pub out: PathBuf,
    /// The node kinds and kernels the pipeline (and `--compare`'s) may use: a user's binary
    /// ([`crate::cli::main`]) benches its own nodes.
    pub registries: crate::session::Registries,
    /// Small and fast (CI smoke test): 128×96 unless a size is given, reference 512 spp,
    /// mu 1 and 2, baselines at 4, 16 and 64 spp.
    pub quick: bool,
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub seed: Option<u32>,
    /// Scene override (as `--scene`).
    pub scene: Option<String>,
    /// Node parameters set on every run and on the reference (as `--set NODE.PARAM=VALUE`): the
    /// suite sets each scene's lens so ([`suite::lens_params`]).
    pub params: Vec<(String, String, crate::graph::ParamValue)>,
    /// `mu` values of the sweep (default 0.5, 1, 2, 4; quick 1, 2). Ignored when no node declares `mu`.
    pub mu_values: Option<Vec<f64>>,
    /// Other pipelines to measure beside it (`--compare`): each on the bench's scene, size and
    /// reference, with its own `mu` sweep where a node declares `mu`, in the same tables and plots.
    pub compare: Vec<PathBuf>,
    /// Fixed baseline sample counts; default: quick 4, 16, 64; full: 1, 2, 4, … until the baseline
    /// is below the pipeline's smallest RMSE (at least 4 counts, at most reference spp / 4).
    pub baseline_spp: Option<Vec<u32>>,
    /// Reference samples per pixel (default: quick 512, full 4096), split over two seeds.
    pub reference_spp: Option<u32>,
    /// Refuse a bench whose estimated peak memory exceeds this many bytes (default: 3/4 of the
    /// available memory, see [`crate::session::memory_budget`]).
    pub memory_limit: Option<u64>,
    /// Where references are cached (default `<out>/.cache`).
    pub cache_dir: Option<PathBuf>,
    pub goals: Goals,
    /// Progress lines on stderr.
    pub verbose: bool,
    /// With `verbose`: a progress bar (the suite's) that the progress lines go above and whose
    /// message shows the current step; `None`: plain lines on stderr.
    pub progress: Option<indicatif::ProgressBar>,
    /// Frame the scene with its own camera, not the pipeline's `camera:` block (the block's
    /// shutter is kept, and its lens for a scene without one; [`Overrides::scene_camera`]):
    /// `--suite` sets it for each of its scenes.
    pub scene_camera: bool,
}

impl BenchOptions {
    pub fn new(pipeline: impl Into<PathBuf>, out: impl Into<PathBuf>) -> Self {
        BenchOptions {
            pipeline: pipeline.into(),
            out: out.into(),
            registries: crate::session::Registries::builtin(),
            quick: false,
            width: None,
            height: None,
            seed: None,
            scene: None,
            params: Vec::new(),
            mu_values: None,
            compare: Vec::new(),
            baseline_spp: None,
            reference_spp: None,
            memory_limit: None,
            cache_dir: None,
            goals: Goals::default(),
            verbose: false,
            progress: None,
            scene_camera: false,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Method {
    /// The pipeline under test ("ours").
    Pipeline,
    /// Another pipeline measured beside it (`--compare`), on the same scene and reference: a second
    /// method for the same effect (e.g. `LightField` beside `Indirect`). Its runs carry the
    /// pipeline's name in [`RunRecord::compared`].
    Compared,
    /// Independent ("standard") Monte Carlo.
    Independent,
    /// Stratified Monte Carlo.
    Stratified,
}

impl Method {
    /// Name used in the report and plots.
    pub fn name(self) -> &'static str {
        match self {
            Method::Pipeline => "ours",
            Method::Compared => "compared",
            Method::Independent => "independent MC",
            Method::Stratified => "stratified MC",
        }
    }
    /// Name used in the CSV.
    pub fn key(self) -> &'static str {
        match self {
            Method::Pipeline => "pipeline",
            Method::Compared => "compared",
            Method::Independent => "independent",
            Method::Stratified => "stratified",
        }
    }
    pub fn sampling(self) -> Option<&'static str> {
        match self {
            Method::Pipeline | Method::Compared => None,
            Method::Independent => Some("independent"),
            Method::Stratified => Some("stratified"),
        }
    }
    pub const BASELINES: [Method; 2] = [Method::Independent, Method::Stratified];
}

/// Why a run was made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// A pipeline run of the `mu` sweep (seed 1); carries the speedups and bias/variance split.
    Sweep,
    /// The same configuration with the second seed (for the variance).
    SecondSeed,
    /// A point of a baseline's error curve.
    Curve,
    /// Stratified Monte Carlo at the pipeline's time (for the image comparison); not on the curve.
    EqualTime,
}

impl Role {
    pub fn key(self) -> &'static str {
        match self {
            Role::Sweep => "sweep",
            Role::SecondSeed => "seed2",
            Role::Curve => "curve",
            Role::EqualTime => "equal-time",
        }
    }
}

/// Average rays per pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RaysPerPixel {
    pub total: f64,
    pub primary: f64,
    pub shadow: f64,
    pub secondary: f64,
}

/// Seconds per kernel class.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TimeSplit {
    pub sampling: f64,
    pub bandwidth: f64,
    pub filter: f64,
    pub compose: f64,
    pub total: f64,
}

impl TimeSplit {
    pub fn of(run: &RunResult) -> TimeSplit {
        TimeSplit {
            sampling: run.seconds(KernelClass::Sampling).max(0.0),
            bandwidth: run.seconds(KernelClass::Bandwidth).max(0.0),
            filter: run.seconds(KernelClass::Filter).max(0.0),
            compose: run.seconds(KernelClass::Compose).max(0.0),
            total: run.total_seconds().max(0.0),
        }
    }
    /// (bandwidth + filter) / sampling; NaN without sampling time.
    pub fn filter_overhead(&self) -> f64 {
        if self.sampling > 0.0 {
            (self.bandwidth + self.filter) / self.sampling
        } else {
            f64::NAN
        }
    }
}

/// The equal-error speedup of one pipeline run against one baseline.
#[derive(Clone, Copy, Debug)]
pub struct Speedup {
    pub baseline: Method,
    /// The pipeline run's RMSE, the error the baseline must reach.
    pub target_rmse: f64,
    /// Rays per pixel the baseline needs (`None`: its curve cannot be extrapolated there).
    pub rays_needed: Option<CostEstimate>,
    /// `rays_needed / pipeline rays` (NaN when unknown).
    pub rays: f64,
    /// Seconds the baseline needs.
    pub time_needed: Option<CostEstimate>,
    /// `time_needed / pipeline time`.
    pub time: f64,
}

impl Speedup {
    /// The rays estimate lies outside the measured curve.
    pub fn extrapolated(&self) -> bool {
        self.rays_needed.is_none_or(|e| e.extrapolation.is_extrapolated())
    }
    pub fn flag(&self) -> &'static str {
        match self.rays_needed {
            None => "no-estimate",
            Some(e) => e.extrapolation.tag(),
        }
    }
}

/// One render and what was measured on it.
#[derive(Clone, Debug)]
pub struct RunRecord {
    pub method: Method,
    pub role: Role,
    pub label: String,
    pub mu: Option<f64>,
    pub spp: Option<u32>,
    pub seed: u32,
    pub rays: RaysPerPixel,
    pub time: TimeSplit,
    pub metrics: Metrics,
    /// Mean LDR-FLIP against the reference.
    pub flip: f64,
    /// Pipeline sweep runs: the split of the MSE into bias² and variance.
    pub bias_variance: Option<BiasVariance>,
    /// Pipeline sweep runs: against each baseline.
    pub speedups: Vec<Speedup>,
    /// The pipeline's own configuration (its file's `mu`): the run the goals are checked on.
    pub primary: bool,
    /// [`Method::Compared`] runs: the compared pipeline's file name.
    pub compared: Option<String>,
}

impl RunRecord {
    pub fn speedup(&self, baseline: Method) -> Option<&Speedup> {
        self.speedups.iter().find(|s| s.baseline == baseline)
    }
}

/// The reference used.
#[derive(Clone, Debug)]
pub struct ReferenceInfo {
    pub spp: u32,
    pub seeds: [u32; 2],
    /// Loaded from the cache instead of rendered.
    pub from_cache: bool,
    /// Estimated RMSE of the reference itself.
    pub noise_rmse: f64,
    /// Seconds the render took (when it was made).
    pub render_seconds: f64,
    /// Seconds this run spent obtaining it (render or load).
    pub obtain_seconds: f64,
    pub exr: PathBuf,
    pub key: String,
}

/// One checked goal.
#[derive(Clone, Debug)]
pub struct GoalOutcome {
    pub name: String,
    pub target: String,
    pub measured: f64,
    pub pass: bool,
    /// For a miss: its cause; for an extrapolated value: a warning.
    pub note: String,
}

/// Everything a bench run measured and wrote.
#[derive(Clone, Debug)]
pub struct BenchResult {
    pub pipeline_name: String,
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    pub quick: bool,
    pub out: PathBuf,
    pub csv: PathBuf,
    pub report: PathBuf,
    pub plots: Vec<PathBuf>,
    pub images: Vec<PathBuf>,
    pub reference: ReferenceInfo,
    pub runs: Vec<RunRecord>,
    pub goals: Vec<GoalOutcome>,
    /// Least-squares log-log fits of the baselines' RMSE against rays per pixel.
    pub fits: Vec<(Method, Option<curves::LogLogFit>)>,
    /// The primary run's mean over the reference's mean, minus 1 (all pixels and channels): the
    /// image-wide bias in brightness (issue 16's AO goal: within ±2%).
    pub mean_offset: f64,
    /// The primary run's error split by pixel class ([`classes`]: focus, texture).
    pub error_by_class: Vec<classes::ClassError>,
    pub seconds: f64,
}

impl BenchResult {
    pub fn primary(&self) -> Option<&RunRecord> {
        self.runs.iter().find(|r| r.primary)
    }
    pub fn curve_runs(&self, m: Method) -> impl Iterator<Item = &RunRecord> {
        self.runs.iter().filter(move |r| r.method == m && r.role == Role::Curve)
    }
}

/// Seeds of the reference halves: far from the bench's own seeds (`seed`, `seed + 1`), so the
/// counter-based sampler never correlates a reference with a measured run.
pub fn reference_seeds(seed: u32) -> [u32; 2] {
    [seed.wrapping_add(0x5eed_0101), seed.wrapping_add(0x5eed_0202)]
}

struct Ctx<'a> {
    opts: &'a BenchOptions,
    base: Overrides,
    reference: Image,
}

impl Ctx<'_> {
    fn log(&self, msg: impl AsRef<str>) {
        if self.opts.verbose {
            let line = format!("bench: {}", msg.as_ref());
            match &self.opts.progress {
                Some(bar) if !bar.is_hidden() => {
                    bar.set_message(msg.as_ref().to_string());
                    bar.println(line);
                }
                _ => eprintln!("{line}"),
            }
        }
    }

    fn ov(&self, seed: u32, mu: Option<f64>) -> Overrides {
        Overrides { seed: Some(seed), mu, ..self.base.clone() }
    }

    /// Run `session` and measure it against the reference.
    fn measure(&self, session: &Session) -> Result<(RunResult, Image, RunRecordParts), WedgeError> {
        let run = session.run(&mut CpuBackend::new(), &Silent)?;
        let color = run.output("color").ok_or_else(|| {
            WedgeError::Usage(format!("{}: the sink has no `color` input to measure", session.pipeline.path.display()))
        })?;
        let img = buffer_to_image(color, session.width, session.height);
        let metrics = compare(&img, &self.reference)?;
        let flip = flip::mean_flip(&img, &self.reference);
        let px = (session.width as f64 * session.height as f64).max(1.0);
        let r = run.rays;
        let rays = RaysPerPixel {
            total: r.total_rays() as f64 / px,
            primary: r.primary_rays as f64 / px,
            shadow: r.shadow_rays as f64 / px,
            secondary: r.secondary_rays as f64 / px,
        };
        let time = TimeSplit::of(&run);
        Ok((run, img, RunRecordParts { rays, time, metrics, flip }))
    }
}

/// The overrides every session of a bench of `opts` starts from (its runs add a seed and μ).
pub(crate) fn base_overrides(opts: &BenchOptions) -> Overrides {
    let (dw, dh) = if opts.quick { (Some(128), Some(96)) } else { (None, None) };
    Overrides {
        scene: opts.scene.clone(),
        width: opts.width.or(dw),
        height: opts.height.or(dh),
        seed: opts.seed,
        mu: None,
        params: opts.params.clone(),
        scene_camera: opts.scene_camera,
        ..Overrides::default()
    }
}

struct RunRecordParts {
    rays: RaysPerPixel,
    time: TimeSplit,
    metrics: Metrics,
    flip: f64,
}

impl RunRecordParts {
    fn record(
        self,
        method: Method,
        role: Role,
        label: String,
        mu: Option<f64>,
        spp: Option<u32>,
        seed: u32,
    ) -> RunRecord {
        RunRecord {
            method,
            role,
            label,
            mu,
            spp,
            seed,
            rays: self.rays,
            time: self.time,
            metrics: self.metrics,
            flip: self.flip,
            bias_variance: None,
            speedups: Vec::new(),
            primary: false,
            compared: None,
        }
    }
}

/// Images kept for the report.
pub(crate) struct KeptImages {
    pub reference: Image,
    pub ours: Image,
    pub unfiltered: Option<Image>,
    pub equal_time: Option<(Image, u32)>,
    /// The primary run's per-pixel (squared error, variance) ([`classes::pixel_errors`]).
    pub pixel_errors: Vec<(f64, f64)>,
}

fn fmt_mu(mu: f64) -> String {
    format!("{mu}")
}

/// The pipeline's μ: its factoring node's where it has one (the component nodes read the factoring
/// node's settings, so that μ is the one that acts), else the first node that states one.
fn own_mu(session: &Session) -> Option<f64> {
    session.pipeline.factoring.as_ref().and_then(|f| f.float("mu")).or_else(|| {
        session
            .pipeline
            .nodes
            .iter()
            .filter(|n| n.kind.params().iter().any(|d| d.name == "mu"))
            .find_map(|n| n.params.get("mu").and_then(crate::graph::ParamValue::as_f64))
    })
}

/// The μ values a pipeline with its own μ `own` is measured at (`--mu-values`, else 0.5–4); one run
/// at the file's settings where it has none.
fn mu_sweep(opts: &BenchOptions, own: Option<f64>) -> Vec<Option<f64>> {
    match own {
        None => vec![None],
        Some(_) => opts
            .mu_values
            .clone()
            .unwrap_or_else(|| if opts.quick { vec![1.0, 2.0] } else { vec![0.5, 1.0, 2.0, 4.0] })
            .into_iter()
            .map(Some)
            .collect(),
    }
}

/// What the bench learns from opening the pipeline once: the size and seed every run takes, its
/// names, its own μ and the scene to hand the reference cache.
struct Setup {
    base: Overrides,
    width: u32,
    height: u32,
    seed: u32,
    pipeline_name: String,
    scene_spec: String,
    scene_name: String,
    default_mu: Option<f64>,
    scene_bytes: Option<Vec<u8>>,
}

impl Setup {
    /// Open the pipeline with the bench's overrides and refuse a run over `--memory-limit` (one run
    /// at a time, plus the full-size images the report keeps).
    fn open(opts: &BenchOptions) -> Result<Setup, WedgeError> {
        let base = base_overrides(opts);
        let path = opts.pipeline.as_path();
        let session = Session::open_with(&opts.registries, Some(path), &base)?;
        let (width, height, seed) = (session.width, session.height, session.seed);
        if let Some((limit, source)) = crate::session::memory_budget(opts.memory_limit) {
            // The reference, its two halves, ours at two seeds, unfiltered, the equal-time
            // baseline: 7 × [f32; 3] per pixel.
            let mut estimate = session.memory_estimate(crate::session::RunMode::Cpu);
            let pixels = u64::from(width) * u64::from(height);
            estimate.images = estimate.images.saturating_add(pixels.saturating_mul(7 * 12));
            estimate.check(limit, &source)?;
        }
        let scene_bytes = match crate::session::scene_source(&session.pipeline, opts.scene.as_deref()) {
            SceneSource::File(p) => std::fs::read(p).ok(),
            _ => None,
        };
        Ok(Setup {
            base: Overrides { seed: Some(seed), width: Some(width), height: Some(height), ..base },
            width,
            height,
            seed,
            pipeline_name: path.file_stem().map_or("pipeline".into(), |s| s.to_string_lossy().into_owned()),
            scene_spec: opts.scene.clone().unwrap_or_else(|| session.pipeline.pipeline.scene.clone()),
            scene_name: session.scene.name.clone(),
            default_mu: own_mu(&session),
            scene_bytes,
        })
    }
}

/// A pipeline's run at one μ, measured at two seeds: the first seed's run, image and record (with
/// the bias/variance split from the two seeds) and the second seed's image and record.
struct SeedPair {
    run: RunResult,
    image: Image,
    second_image: Image,
    record: RunRecord,
    second: RunRecord,
}

/// The primary run's images: seed 1's image, its unfiltered input, seed 2's image, its pixel classes.
type KeptOurs = (Image, Option<Image>, Image, Vec<classes::Partition>);

/// Run the whole benchmark (see the module docs) and write its files into `opts.out`.
pub fn run(opts: &BenchOptions) -> Result<BenchResult, WedgeError> {
    let t0 = Instant::now();
    let mut setup = Setup::open(opts)?;
    let (width, height, seed) = (setup.width, setup.height, setup.seed);
    std::fs::create_dir_all(&opts.out).map_err(|e| io_err(&opts.out, e))?;

    // 1. The reference (the scene file's bytes go to its cache key).
    let scene_bytes = setup.scene_bytes.take();
    let (reference_img, reference) =
        obtain_reference(opts, &setup.base, &setup.scene_spec, scene_bytes, (width, height, seed))?;
    let ctx = Ctx { opts, base: setup.base.clone(), reference: reference_img };
    ctx.log(format!(
        "reference {} spp {} ({:.1} s), estimated noise RMSE {:.3e}",
        reference.spp,
        if reference.from_cache { "from cache" } else { "rendered" },
        reference.obtain_seconds,
        reference.noise_rmse
    ));
    let noise2 = reference.noise_rmse * reference.noise_rmse;

    // 2. The pipeline's μ sweep, two seeds each; 2b. the compared pipelines alike.
    let pipeline_dir = opts.out.join("pipeline");
    let (mut runs, kept_ours) = ctx.pipeline_sweep(&setup, &pipeline_dir, noise2)?;
    for other in &opts.compare {
        ctx.compared_sweep(other, &setup, noise2, &mut runs)?;
    }
    // 3. Baseline curves; 4. speedups; 5. equal-time stratified Monte Carlo.
    ctx.baseline_curves(seed, reference.spp, &mut runs)?;
    let fits = speedups(&mut runs);
    let equal_time = ctx.equal_time(seed, &mut runs)?;

    let goals = report::check_goals(&runs, &opts.goals);
    let (ours, unfiltered, ours_seed2, partitions) =
        kept_ours.ok_or_else(|| WedgeError::Usage("no primary pipeline run".into()))?;
    let mean_offset = mean_of(&ours) / mean_of(&ctx.reference) - 1.0;
    let pixel_errors = classes::pixel_errors(&ours, &ours_seed2, &ctx.reference);
    let error_by_class = classes::class_errors(&partitions, &pixel_errors, noise2);
    let kept = KeptImages { reference: ctx.reference, ours, unfiltered, equal_time, pixel_errors };
    let mut result = BenchResult {
        pipeline_name: setup.pipeline_name,
        scene: setup.scene_name,
        width,
        height,
        seed,
        quick: opts.quick,
        out: opts.out.clone(),
        csv: opts.out.join("bench.csv"),
        report: opts.out.join("report.md"),
        plots: Vec::new(),
        images: Vec::new(),
        reference,
        runs,
        goals,
        fits,
        mean_offset,
        error_by_class,
        seconds: 0.0,
    };
    report::write_all(&mut result, &kept, &pipeline_dir, t0)?;
    Ok(result)
}

impl Ctx<'_> {
    /// Measure `path` at `mu` and two seeds (the second `seed + 1`), labelled `label`.
    fn seed_pair(
        &self,
        (path, ov): (&Path, &dyn Fn(u32) -> Overrides),
        (method, label, shown_mu): (Method, String, Option<f64>),
        seed: u32,
        noise2: f64,
    ) -> Result<(SeedPair, Session), WedgeError> {
        let reg = &self.opts.registries;
        let s1 = Session::open_with(reg, Some(path), &ov(seed))?;
        let (run, image, parts1) = self.measure(&s1)?;
        let seed2 = seed.wrapping_add(1);
        let (_, second_image, parts2) = self.measure(&Session::open_with(reg, Some(path), &ov(seed2))?)?;
        let mut record = parts1.record(method, Role::Sweep, label.clone(), shown_mu, None, seed);
        let msd = stats::mean_squared_difference(&image, &second_image)?;
        let mse = record.metrics.rmse * record.metrics.rmse;
        record.bias_variance = Some(split_bias_variance(mse, msd, noise2));
        self.log(format!(
            "{label}: {:.1} rays/px, {:.2} s, RMSE {:.3e}",
            record.rays.total, record.time.total, record.metrics.rmse
        ));
        let second = parts2.record(method, Role::SecondSeed, format!("{label} seed {seed2}"), shown_mu, None, seed2);
        Ok((SeedPair { run, image, second_image, record, second }, s1))
    }

    /// Step 2: the pipeline at each μ of its sweep (and at its own μ, the primary run, whose render
    /// is written to `pipeline_dir` and whose images and pixel classes the report keeps).
    fn pipeline_sweep(
        &self,
        setup: &Setup,
        pipeline_dir: &Path,
        noise2: f64,
    ) -> Result<(Vec<RunRecord>, Option<KeptOurs>), WedgeError> {
        let path = self.opts.pipeline.as_path();
        let default_mu = setup.default_mu;
        let is_default = |m: Option<f64>| match (m, default_mu) {
            (Some(a), Some(b)) => (a - b).abs() <= 1e-9 * b.abs().max(1.0),
            (None, _) => true,
            _ => false,
        };
        let mut mus = mu_sweep(self.opts, default_mu);
        if !mus.iter().any(|m| is_default(*m)) {
            mus.push(None);
        }
        let mut runs: Vec<RunRecord> = Vec::new();
        let mut kept: Option<KeptOurs> = None;
        for &mu in &mus {
            let shown_mu = mu.or(default_mu);
            let label = match shown_mu {
                Some(m) => format!("{} (mu={})", Method::Pipeline.name(), fmt_mu(m)),
                None => Method::Pipeline.name().to_string(),
            };
            let ov = |seed: u32| self.ov(seed, mu);
            let (mut pair, s1) =
                self.seed_pair((path, &ov), (Method::Pipeline, label, shown_mu), setup.seed, noise2)?;
            pair.record.primary = is_default(mu) && !runs.iter().any(|r: &RunRecord| r.primary);
            if pair.record.primary {
                let (w, h) = (setup.width, setup.height);
                crate::outputs::write_run(pipeline_dir, "render", &pair.run, w, h)?;
                let unfiltered = pair.run.output("unfiltered").map(|b| buffer_to_image(b, w, h));
                let partitions = pixel_classes(&s1, w, h)?;
                kept = Some((pair.image, unfiltered, pair.second_image, partitions));
            }
            runs.push(pair.record);
            runs.push(pair.second);
        }
        Ok((runs, kept))
    }

    /// Step 2b: a compared pipeline's sweep at its own μ values, on this bench's scene, size, seeds
    /// and reference.
    fn compared_sweep(
        &self,
        other: &Path,
        setup: &Setup,
        noise2: f64,
        runs: &mut Vec<RunRecord>,
    ) -> Result<(), WedgeError> {
        let name = other.file_stem().map_or("compared".into(), |s| s.to_string_lossy().into_owned());
        let on_scene =
            |seed: u32, mu: Option<f64>| Overrides { scene: Some(setup.scene_spec.clone()), ..self.ov(seed, mu) };
        let own = own_mu(&Session::open_with(&self.opts.registries, Some(other), &on_scene(setup.seed, None))?);
        for mu in mu_sweep(self.opts, own) {
            let shown = mu.or(own);
            let label = match shown {
                Some(m) => format!("{name} (mu={})", fmt_mu(m)),
                None => name.clone(),
            };
            let ov = |seed: u32| on_scene(seed, mu);
            let (mut pair, _) = self.seed_pair((other, &ov), (Method::Compared, label, shown), setup.seed, noise2)?;
            pair.record.compared = Some(name.clone());
            pair.second.compared = Some(name.clone());
            runs.push(pair.record);
            runs.push(pair.second);
        }
        Ok(())
    }

    /// Step 3: each baseline's error curve — doubling spp from 1 until four points lie below the
    /// pipeline's best error or the spp passes a quarter of the reference's (`--baseline-spp`, or
    /// `--quick`'s 4, 16, 64, instead).
    fn baseline_curves(&self, seed: u32, reference_spp: u32, runs: &mut Vec<RunRecord>) -> Result<(), WedgeError> {
        let (opts, path) = (self.opts, self.opts.pipeline.as_path());
        let min_pipeline_rmse = runs
            .iter()
            .filter(|r| r.role == Role::Sweep)
            .map(|r| r.metrics.rmse)
            .filter(|e| e.is_finite())
            .fold(f64::INFINITY, f64::min);
        let max_spp = (reference_spp / 4).max(16);
        for method in Method::BASELINES {
            let sampling = method.sampling().unwrap_or("stratified");
            let fixed = opts.baseline_spp.clone().or_else(|| opts.quick.then(|| vec![4, 16, 64]));
            let mut spp = 1u32;
            let mut i = 0usize;
            loop {
                let n = match &fixed {
                    Some(list) => match list.get(i) {
                        Some(n) => *n,
                        None => break,
                    },
                    None => spp,
                };
                let s = Session::reference_with(&opts.registries, Some(path), n, sampling, &self.ov(seed, None))?;
                let (_, _, parts) = self.measure(&s)?;
                let rec = parts.record(method, Role::Curve, format!("{} {n} spp", method.name()), None, Some(n), seed);
                self.log(format!(
                    "{}: {:.1} rays/px, {:.2} s, RMSE {:.3e}",
                    rec.label, rec.rays.total, rec.time.total, rec.metrics.rmse
                ));
                let below = rec.metrics.rmse < min_pipeline_rmse;
                runs.push(rec);
                i += 1;
                if fixed.is_none() {
                    if (below && i >= 4) || spp.saturating_mul(2) > max_spp {
                        break;
                    }
                    spp *= 2;
                }
            }
        }
        Ok(())
    }

    /// Step 5: stratified Monte Carlo at the spp whose time matches the primary run's, for the
    /// image comparison; its image and spp.
    fn equal_time(&self, seed: u32, runs: &mut Vec<RunRecord>) -> Result<Option<(Image, u32)>, WedgeError> {
        let primary_time = runs.iter().find(|r| r.primary).map(|r| r.time.total).unwrap_or(f64::NAN);
        let curve = runs.iter().filter(|r| r.method == Method::Stratified && r.role == Role::Curve);
        let Some(n) = equal_time_spp(curve, primary_time) else { return Ok(None) };
        let path = self.opts.pipeline.as_path();
        let s = Session::reference_with(&self.opts.registries, Some(path), n, "stratified", &self.ov(seed, None))?;
        let (_, img, parts) = self.measure(&s)?;
        let rec = parts.record(
            Method::Stratified,
            Role::EqualTime,
            format!("{} {n} spp (equal time)", Method::Stratified.name()),
            None,
            Some(n),
            seed,
        );
        self.log(format!(
            "{}: {:.2} s vs ours {:.2} s, RMSE {:.3e}",
            rec.label, rec.time.total, primary_time, rec.metrics.rmse
        ));
        runs.push(rec);
        Ok(Some((img, n)))
    }
}

/// Step 4: every sweep run's equal-error speedup against each baseline's curve, by rays and by time;
/// the baselines' fitted rays curves.
fn speedups(runs: &mut [RunRecord]) -> Vec<(Method, Option<curves::LogLogFit>)> {
    let mut fits = Vec::new();
    for method in Method::BASELINES {
        let pts: Vec<&RunRecord> = runs.iter().filter(|r| r.method == method && r.role == Role::Curve).collect();
        let rays_curve = Curve::new(&pts.iter().map(|r| Point::new(r.rays.total, r.metrics.rmse)).collect::<Vec<_>>());
        let time_curve = Curve::new(&pts.iter().map(|r| Point::new(r.time.total, r.metrics.rmse)).collect::<Vec<_>>());
        fits.push((method, rays_curve.fit()));
        for r in runs.iter_mut().filter(|r| r.role == Role::Sweep) {
            let target = r.metrics.rmse;
            let rays_needed = rays_curve.cost_for_error(target);
            let time_needed = time_curve.cost_for_error(target);
            r.speedups.push(Speedup {
                baseline: method,
                target_rmse: target,
                rays_needed,
                rays: rays_needed.map_or(f64::NAN, |e| stats::speedup(e.cost, r.rays.total)),
                time_needed,
                time: time_needed.map_or(f64::NAN, |e| stats::speedup(e.cost, r.time.total)),
            });
        }
    }
    fits
}

/// The pixel classes of `session`'s image ([`classes::partitions`]): its scene's G-buffer at the
/// bench's size, the lens of its factoring node where it has one, and the scene's motion where that
/// node samples the shutter.
fn pixel_classes(session: &Session, width: u32, height: u32) -> Result<Vec<classes::Partition>, WedgeError> {
    let aovs = crate::aov::Aovs::render(&session.scene, width, height)?;
    let lens = session.pipeline.factoring.as_ref().and_then(|f| {
        let [aperture, focus] = suite::LENS_PARAMS.map(|n| f.float(n));
        Some((aperture? as f32, focus? as f32))
    });
    let shutter =
        session.pipeline.factoring.as_ref().and_then(|f| f.bool(crate::graph::factoring::CameraSettings::TIME))
            == Some(true);
    Ok(classes::partitions(&aovs, &session.camera_at(0), lens, shutter.then_some(&session.scene)))
}

/// Mean of every finite channel value of `img` (NaN when there is none).
fn mean_of(img: &Image) -> f64 {
    let (sum, n) = img
        .pixels
        .iter()
        .flatten()
        .filter(|c| c.is_finite())
        .fold((0.0f64, 0u64), |(s, n), &c| (s + f64::from(c), n + 1));
    if n > 0 {
        sum / n as f64
    } else {
        f64::NAN
    }
}

fn io_err(path: &Path, source: std::io::Error) -> WedgeError {
    WedgeError::Image(crate::image::ImageError::Write { path: path.to_path_buf(), source })
}

/// Samples per pixel at which stratified Monte Carlo takes `target_seconds`: least-squares line
/// `time = a + b · spp` through the measured runs. `None` without two distinct counts or a time.
fn equal_time_spp<'a>(runs: impl Iterator<Item = &'a RunRecord>, target_seconds: f64) -> Option<u32> {
    let pts: Vec<(f64, f64)> = runs.filter_map(|r| Some((r.spp? as f64, r.time.total))).collect();
    if pts.len() < 2 || !(target_seconds.is_finite() && target_seconds > 0.0) {
        return None;
    }
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx <= 0.0 || sxy <= 0.0 {
        return None;
    }
    let b = sxy / sxx;
    let a = my - b * mx;
    Some(((target_seconds - a) / b).round().clamp(1.0, 1e6) as u32)
}

/// Load the reference from the cache, or render it as two halves and store it.
fn obtain_reference(
    opts: &BenchOptions,
    base: &Overrides,
    scene_spec: &str,
    scene_bytes: Option<Vec<u8>>,
    (width, height, seed): (u32, u32, u32),
) -> Result<(Image, ReferenceInfo), WedgeError> {
    let t = Instant::now();
    let path = opts.pipeline.as_path();
    let spp = opts.reference_spp.unwrap_or(if opts.quick { 512 } else { 4096 }).max(2);
    let pipeline_text = std::fs::read_to_string(path)
        .map_err(|source| WedgeError::Image(crate::image::ImageError::Read { path: path.to_path_buf(), source }))?;
    let spec = ReferenceSpec {
        pipeline_text,
        scene: scene_spec.to_string(),
        scene_bytes,
        seed,
        width,
        height,
        spp,
        sampling: "stratified".into(),
        params: opts.params.iter().map(|(n, k, v)| format!("{n}.{k}={v:?}")).collect::<Vec<_>>().join(" "),
        scene_camera: opts.scene_camera,
    };
    let dir = opts.cache_dir.clone().unwrap_or_else(|| opts.out.join(".cache"));
    let seeds = reference_seeds(seed);
    if let Some(stored) = reference_cache::load(&dir, &spec) {
        let info = ReferenceInfo {
            spp,
            seeds,
            from_cache: true,
            noise_rmse: stored.noise_rmse,
            render_seconds: stored.render_seconds,
            obtain_seconds: t.elapsed().as_secs_f64(),
            exr: stored.exr,
            key: spec.key(),
        };
        return Ok((stored.image, info));
    }
    let half = spp / 2;
    let mut halves = Vec::new();
    for s in seeds {
        let session = Session::reference_with(
            &opts.registries,
            Some(path),
            half,
            "stratified",
            &Overrides { seed: Some(s), ..base.clone() },
        )?;
        let run = session.run(&mut CpuBackend::new(), &Silent)?;
        let c = run.output("color").ok_or_else(|| WedgeError::Usage("reference has no color output".into()))?;
        halves.push(buffer_to_image(c, width, height));
    }
    let noise_rmse = stats::reference_noise_rmse(&halves[0], &halves[1])?;
    let image = stats::average(&halves[0], &halves[1]);
    let render_seconds = t.elapsed().as_secs_f64();
    let exr = reference_cache::store(&dir, &spec, &image, noise_rmse, render_seconds)?;
    let info = ReferenceInfo {
        spp: half * 2,
        seeds,
        from_cache: false,
        noise_rmse,
        render_seconds,
        obtain_seconds: render_seconds,
        exr,
        key: spec.key(),
    };
    Ok((image, info))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(spp: u32, t: f64) -> RunRecord {
        RunRecord {
            method: Method::Stratified,
            role: Role::Curve,
            label: String::new(),
            mu: None,
            spp: Some(spp),
            seed: 1,
            rays: RaysPerPixel::default(),
            time: TimeSplit { total: t, ..Default::default() },
            metrics: Metrics { rmse: 0.1, rel_mse: 0.0, psnr: 0.0, smape: 0.0, max_abs: 0.0, non_finite: 0, pixels: 1 },
            flip: 0.0,
            bias_variance: None,
            speedups: Vec::new(),
            primary: false,
            compared: None,
        }
    }

    #[test]
    fn equal_time_from_linear_fit() {
        // time = 0.1 + 0.01 · spp: 1.1 s ↔ 100 spp.
        let runs = [rec(10, 0.2), rec(40, 0.5), rec(160, 1.7)];
        assert_eq!(equal_time_spp(runs.iter(), 1.1), Some(100));
        // Below the fixed cost: at least one sample.
        assert_eq!(equal_time_spp(runs.iter(), 0.01), Some(1));
        assert_eq!(equal_time_spp(runs[..1].iter(), 1.0), None);
    }

    #[test]
    fn filter_overhead_and_seeds() {
        let t = TimeSplit { sampling: 2.0, bandwidth: 0.02, filter: 0.08, compose: 0.0, total: 2.1 };
        assert!((t.filter_overhead() - 0.05).abs() < 1e-12);
        assert!(TimeSplit::default().filter_overhead().is_nan());
        let [a, b] = reference_seeds(1);
        assert!(a != b && a != 1 && a != 2 && b != 1 && b != 2);
    }
}
