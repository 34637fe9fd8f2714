//! `render --tile`, `farm slurm` and `farm k8s`: one tile of an image (of each frame) for `wedge
//! merge`, a Slurm job array of tiles with its merge job, and the Kubernetes manifests of the same
//! (the machinery is `crate::tiles`, `crate::farm` and `crate::k8s`).

use std::path::Path;

use super::args::{overrides, Common, FarmTasks, K8sArgs};
use super::render::scene_notes;
use crate::backends::cpu::CpuBackend;
use crate::progress::{Bars, TaskProgress};
use crate::session::{open_gpu, Registries};
use crate::{Session, WedgeError};

/// `render --tile I/N`: one tile file into --out ([`crate::tiles`]); with --frames, tile I of each
/// frame the plan holds, into --out/frame_FFFF/ (one directory per frame for `wedge merge`).
pub(super) fn render_tile(
    session: &mut Session,
    common: &Common,
    (index, n): (u32, u32),
    grid: Option<crate::tiles::Grid>,
    frames: Option<&crate::shard::FramePlan>,
) -> Result<String, WedgeError> {
    let grid = crate::tiles::grid_of(n, grid, (session.width, session.height))?;
    scene_notes(session);
    let plan = crate::tiles::plan(session, index, grid)?;
    if frames.is_some() {
        crate::tiles::check_frames(session)?;
    }
    // The memory of the tile with its apron, not of the whole image.
    let mode = common.run_mode();
    if let Some((limit, source)) = crate::session::memory_budget(common.memory_limit) {
        session.memory_estimate_at(mode, (plan.grown.2, plan.grown.3)).check(limit, &source)?;
    }
    let mut backend: Box<dyn crate::backends::Backend> = match common.backend.as_str() {
        "wgpu" => Box::new(open_gpu(common.gpu_limits.as_deref())?),
        _ => Box::new(CpuBackend::new()),
    };
    let bars = Bars::default();
    let runs = frames.map_or(1, |f| f.frames.len() as u64);
    let progress = TaskProgress::new(
        &bars,
        common.progress_format(),
        "tile",
        runs.saturating_mul(TaskProgress::work(session.schedule.passes.len(), plan.pixels())),
    );
    let mut text = String::new();
    let Some(frames) = frames else {
        progress.at(Some((index, n)), None, plan.pixels());
        let tile = crate::tiles::render_planned(session, backend.as_mut(), &progress, &plan)?;
        return Ok(tile_line(&tile, n, None, &crate::tiles::write_tile(&common.out, &tile)?));
    };
    for &frame in &frames.frames {
        progress.at(Some((index, n)), Some(frame), plan.pixels());
        let tile =
            crate::tiles::render_planned_frame(session, backend.as_mut(), &progress, &plan, (frame, frames.first))?;
        let dir = common.out.join(format!("frame_{frame:04}"));
        text.push_str(&tile_line(&tile, n, Some(frame), &crate::tiles::write_tile(&dir, &tile)?));
    }
    Ok(text)
}

/// What `render --tile` prints for one tile file (of frame `frame` of a sequence) written to `path`.
fn tile_line(tile: &crate::tiles::Tile, n: u32, frame: Option<u32>, path: &Path) -> String {
    let (h, r) = (&tile.header, tile.header.rect);
    let of_frame = frame.map_or(String::new(), |f| format!(" of frame {f}"));
    format!(
        "tile {}/{n}{of_frame} of a {}x{} grid: {}x{} at ({}, {}) of {}x{}, apron {} px\nwrote {}\n",
        h.index,
        h.grid.cols,
        h.grid.rows,
        r.w,
        r.h,
        r.x,
        r.y,
        h.full.0,
        h.full.1,
        h.apron,
        path.display()
    )
}

/// The `render` flags of `c` that a farm task passes on (not --out: the farm places the tiles).
fn forwarded_args(c: &Common) -> Vec<String> {
    let mut a: Vec<String> = Vec::new();
    let values = [
        ("--scene", c.scene.clone()),
        ("--seed", c.seed.map(|v| v.to_string())),
        ("--width", c.width.map(|v| v.to_string())),
        ("--height", c.height.map(|v| v.to_string())),
        ("--threads", c.threads.map(|v| v.to_string())),
        ("--memory-limit", c.memory_limit.map(|v| v.to_string())),
        ("--backend", Some(c.backend.clone())),
        ("--gpu-limits", c.gpu_limits.clone()),
        ("--progress", Some(c.progress.clone())),
    ];
    for (flag, v) in values {
        if let Some(v) = v {
            a.extend([flag.to_string(), v]);
        }
    }
    for s in &c.set {
        a.extend(["--set".to_string(), s.clone()]);
    }
    if c.allow_outside_dir {
        a.push("--allow-outside-dir".into());
    }
    a
}

/// The session of a farm submission, opened as its tasks open it (at the range's first frame), with
/// what would make a task fail refused first: a pipeline that cannot be tiled, tiles of a pipeline
/// with frame history.
fn farm_session(registries: &Registries, t: &FarmTasks, common: &Common) -> Result<Session, WedgeError> {
    let ov = crate::Overrides { frame: t.frames.map(|(first, _)| first), ..overrides(common, None)? };
    let session = Session::open_with(registries, Some(&t.pipeline), &ov)?;
    crate::tiles::check(&session, crate::tiles::Grid::near_square(t.tiles, (session.width, session.height)))?;
    if t.frames.is_some() {
        crate::tiles::check_frames(&session)?;
    }
    Ok(session)
}

/// `wedge farm k8s`: the manifests into OUT/k8s/ ([`crate::k8s`]).
pub(super) fn farm_k8s(
    registries: &Registries,
    tasks: &FarmTasks,
    k8s: &K8sArgs,
    common: &Common,
) -> Result<String, WedgeError> {
    crate::staging::check_output_dir(&common.out)?;
    let session = farm_session(registries, tasks, common)?;
    let (pipeline, tiles, frames) = (tasks.pipeline.as_path(), tasks.tiles, tasks.frames);
    let text =
        std::fs::read_to_string(pipeline).map_err(|e| WedgeError::Usage(format!("{}: {e}", pipeline.display())))?;
    let stem = pipeline.file_stem().map_or("pipeline".into(), |s| s.to_string_lossy().to_lowercase());
    let default_name: String =
        format!("wedge-{stem}").chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '-' }).take(40).collect();
    let plan = crate::k8s::K8sPlan {
        name: k8s.name.clone().unwrap_or_else(|| default_name.trim_end_matches('-').to_string()),
        image: k8s.image.clone(),
        wedge: k8s.wedge.clone(),
        pipeline_file: crate::k8s::config_key(
            &pipeline.file_name().map_or("pipeline.ron".into(), |s| s.to_string_lossy().into_owned()),
        ),
        pipeline_text: text,
        tiles,
        frames,
        // The pods' tiles go to the claim, not to this --out.
        render_args: forwarded_args(common),
        parallelism: k8s.parallelism,
        storage: k8s.storage.clone(),
        storage_class: k8s.storage_class.clone(),
        namespace: k8s.namespace.clone(),
    };
    plan.check()?;
    let files = plan.write(&common.out.join("k8s"))?;
    let range = frames.map_or(String::new(), |(a, b)| format!(" × frames {a}..{b}"));
    let mut out = format!("{} task(s) ({tiles} tile(s){range}) of {}\n", plan.tasks(), pipeline.display());
    let scene = common.scene.as_deref().unwrap_or(&session.pipeline.pipeline.scene);
    if !scene.starts_with("builtin:") && !crate::scene::builtin_names().contains(&scene) {
        out.push_str(&format!(
            "note: the scene `{scene}` is a file: the pods read it at that path (relative to {}) inside the image; only \
             the pipeline file travels in the ConfigMap\n",
            crate::k8s::PIPELINE_DIR
        ));
    }
    for f in &files {
        out.push_str(&format!("wrote {}\n", f.display()));
    }
    out.push_str(&format!(
        "run: sh {}/k8s/submit.sh (kubectl apply -f tiles.yaml; wait for job/{name}-tiles to complete; kubectl apply -f merge.yaml)\n",
        common.out.display(),
        name = plan.name
    ));
    Ok(out)
}

/// What `wedge farm slurm` was asked for.
pub(super) struct SlurmRequest<'a> {
    pub tasks: &'a FarmTasks,
    pub common: &'a Common,
    pub partition: Option<String>,
    pub time: Option<String>,
    pub dry_run: bool,
}

/// `wedge farm slurm`: refuse a pipeline that cannot be tiled before anything is submitted. The
/// tasks run this same binary (a user's, with its nodes, too).
pub(super) fn farm_slurm(registries: &Registries, r: SlurmRequest<'_>) -> Result<String, WedgeError> {
    for (flag, v) in [("--partition", &r.partition), ("--time", &r.time)] {
        if let Some(v) = v {
            crate::farm::check_sbatch_value(flag, v)?;
        }
    }
    farm_session(registries, r.tasks, r.common)?;
    let absolute = |p: &Path| std::path::absolute(p).map_err(|e| WedgeError::Usage(format!("{}: {e}", p.display())));
    let plan = crate::farm::SlurmPlan {
        wedge: std::env::current_exe()
            .map_err(|e| WedgeError::Usage(format!("cannot find the wedge executable: {e}")))?,
        pipeline: absolute(&r.tasks.pipeline)?,
        tiles: r.tasks.tiles,
        frames: r.tasks.frames,
        out: absolute(&r.common.out)?,
        render_args: forwarded_args(r.common),
        partition: r.partition,
        time: r.time,
    };
    if r.dry_run {
        return Ok(plan.dry_run());
    }
    plan.submit()
}
