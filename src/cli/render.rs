//! `render` and what it shares with the other rendering commands: one image, a frame sequence, a
//! progressive run, on the CPU or wgpu backend; the scene's notes; the memory check.

use super::args::Common;
use crate::backends::cpu::CpuBackend;
use crate::graph::ParamValue;
use crate::outputs::summary;
use crate::progress::{Bars, TaskProgress};
use crate::session::{open_gpu, RunMode};
use crate::{Session, WedgeError};

/// What `render` and `reference` do before anything else: refuse an `--out` that cannot be a
/// directory (before rendering, not after) and warn about flags the backend ignores.
///
/// `--gpu-limits` with `--backend cpu` is a warning rather than a refusal: the image does not
/// depend on it, and a script that passes the same flags to both backends keeps working, while
/// the line tells someone who forgot `--backend wgpu` that no limit was checked.
pub(super) fn start_rendering_command(common: &Common) -> Result<(), WedgeError> {
    crate::staging::check_output_dir(&common.out)?;
    warn_unused_flags(common);
    Ok(())
}

/// Flags that the chosen backend does not use: a warning, not a refusal ([`start_rendering_command`]).
pub(super) fn warn_unused_flags(common: &Common) {
    if let (Some(limits), "cpu") = (&common.gpu_limits, common.backend.as_str()) {
        eprintln!(
            "warning: --gpu-limits {limits} has no effect with --backend cpu (device limits apply to the wgpu backend \
             only); add --backend wgpu to run under them"
        );
    }
}

/// Refuse `session` in `mode` before anything large is allocated when it will not fit the budget.
pub(super) fn check_memory(session: &Session, mode: RunMode, flag: Option<u64>) -> Result<(), WedgeError> {
    match crate::session::memory_budget(flag) {
        Some((limit, source)) => session.memory_estimate(mode).check(limit, &source),
        None => Ok(()),
    }
}

/// The scene's warnings, its environment map (with the `B_e` the Environment node's filters use
/// unless its `b_e` is set), and a warning where nothing lights it.
pub(super) fn scene_notes(session: &Session) {
    for w in &session.scene.warnings {
        eprintln!("warning: {w}");
    }
    for w in session.pipeline.light_warnings(Some(&crate::session::scene_facts(&session.scene))) {
        eprintln!("warning: {w}");
    }
    if let Some(env) = &session.scene.environment {
        eprintln!(
            "environment: {} ({}x{}, scale {}, rotation {}°), B_e = {:.2} cycles/rad (99% of the spectrum's energy; \
             an Environment node's `b_e` overrides it)",
            env.name(),
            env.width(),
            env.height(),
            env.scale(),
            env.rotation_deg(),
            env.bandwidth()
        );
    }
    if session.scene.lights.is_empty() && session.scene.environment.is_none() {
        // Not an error: an AO pipeline needs no light. But direct and indirect light will be black.
        eprintln!(
            "warning: scene `{}` has no area light (no emissive triangles) and no environment map: light sampling adds \
             nothing, so only emission and ambient occlusion show; add an emissive material or use a scene with a light",
            session.scene.name
        );
    }
}

/// `--aov`'s maps for `scene` at the session's size (none when `names` is empty), and a line saying
/// what they took.
pub(super) fn aov_images(
    scene: &crate::scene::Scene,
    session: &Session,
    names: &[String],
) -> Result<(Vec<crate::outputs::ExtraExr>, String), WedgeError> {
    if names.is_empty() {
        return Ok((Vec::new(), String::new()));
    }
    let start = std::time::Instant::now();
    let aovs = crate::aov::Aovs::render(scene, session.width, session.height)?;
    let images = aovs.images(names);
    let stems: Vec<&str> = images.iter().map(|e| e.stem.as_str()).collect();
    let line = format!(
        "AOVs {} in {:.1} ms (primary.gbuffer on the CPU)\n",
        stems.join(", "),
        start.elapsed().as_secs_f64() * 1e3
    );
    Ok((images, line))
}

pub(super) fn render(session: &Session, common: &Common, stem: &str, aov: &[String]) -> Result<String, WedgeError> {
    eprintln!(
        "{} on scene `{}` ({} triangles, {} lights), {}x{}, seed {}",
        session.pipeline.path.display(),
        session.scene.name,
        session.scene.triangle_count(),
        session.scene.lights.len(),
        session.width,
        session.height,
        session.seed
    );
    scene_notes(session);
    let mode = common.run_mode();
    if let Err(too_big) = check_memory(session, mode, common.memory_limit) {
        return render_in_tiles(session, common, stem, aov, too_big);
    }
    let bars = Bars::default();
    let pixels = u64::from(session.width) * u64::from(session.height);
    let progress = TaskProgress::new(
        &bars,
        common.progress_format(),
        "render",
        TaskProgress::work(session.schedule.passes.len(), pixels),
    );
    progress.at(None, None, pixels);
    let (run, note) = match common.backend.as_str() {
        "wgpu" => run_wgpu(session, &progress, common.gpu_limits.as_deref())?,
        _ => (session.run(&mut CpuBackend::new(), &progress)?, None),
    };
    let (extra, aov_line) = aov_images(&session.scene, session, aov)?;
    let written = crate::outputs::write_run_with(&common.out, stem, &run, &extra, session.width, session.height)?;
    let mut text = summary(&run, session.width, session.height);
    text.push_str(&written.warnings());
    if let Some(note) = note {
        text.push_str(&note);
    }
    text.push_str(&aov_line);
    for f in &written.files {
        text.push_str(&format!("wrote {}\n", f.display()));
    }
    Ok(text)
}

/// `render` of an image whose whole run does not fit the memory limit (`too_big` says so): the
/// fewest tiles that fit, rendered in sequence in this process and assembled into the images a whole
/// render writes (the same bytes; heatmaps and AOVs are not assembled). Refused with `too_big` and
/// the reason when no grid fits or the pipeline cannot be tiled.
fn render_in_tiles(
    session: &Session,
    common: &Common,
    stem: &str,
    aov: &[String],
    too_big: WedgeError,
) -> Result<String, WedgeError> {
    let mode = common.run_mode();
    let Some((limit, _)) = crate::session::memory_budget(common.memory_limit) else { return Err(too_big) };
    let refuse = |why: String| WedgeError::Usage(format!("{too_big}; rendering it in tiles does not help: {why}"));
    if !aov.is_empty() {
        return Err(refuse("--aov maps are not assembled from tiles; render them separately".into()));
    }
    let (grid, bytes) = match crate::tiles::grid_within(session, mode, limit) {
        Ok(Some(found)) => found,
        Ok(None) => {
            let apron = crate::tiles::apron(session).unwrap_or(0);
            return Err(refuse(format!(
                "no grid of up to {} tiles fits: each tile computes its rectangle plus an apron of {apron} px (how far \
                 the passes read around a pixel), and the scene and the full images stay in memory",
                crate::tiles::MAX_AUTO_TILES
            )));
        }
        Err(e) => return Err(refuse(e.to_string())),
    };
    eprintln!(
        "the whole image does not fit the memory limit of {}: rendering it as {} tiles ({}x{}) in sequence, estimated peak {}",
        crate::session::format_bytes(limit),
        grid.count(),
        grid.cols,
        grid.rows,
        crate::session::format_bytes(bytes)
    );
    let start = std::time::Instant::now();
    let bars = Bars::default();
    let progress = TaskProgress::new(&bars, common.progress_format(), "tiles", crate::tiles::work(session, grid)?);
    let images = match common.backend.as_str() {
        "wgpu" => crate::tiles::render_all(session, &mut open_gpu(common.gpu_limits.as_deref())?, &progress, grid)?,
        _ => crate::tiles::render_all(session, &mut CpuBackend::new(), &progress, grid)?,
    };
    let written = crate::outputs::write_images(&common.out, stem, &images)?;
    let mut text = format!(
        "rendered as {} tiles ({}x{} grid) in {:.1} s; heatmaps are not written for a tiled render\n",
        grid.count(),
        grid.cols,
        grid.rows,
        start.elapsed().as_secs_f64()
    );
    text.push_str(&written.warnings());
    for f in &written.files {
        text.push_str(&format!("wrote {}\n", f.display()));
    }
    Ok(text)
}

/// The one backend a run of several frames (`--frames`, `--progressive`) keeps: announces the run
/// (`what`: which frames), prints the scene notes and checks the memory estimate first.
pub(super) fn sequence_backend(
    session: &Session,
    common: &Common,
    what: &str,
) -> Result<Box<dyn crate::backends::Backend + Send>, WedgeError> {
    eprintln!(
        "{} on scene `{}`, {}x{}, {what}, seed {} (+ frame)",
        session.pipeline.path.display(),
        session.scene.name,
        session.width,
        session.height,
        session.seed
    );
    scene_notes(session);
    let mode = common.run_mode();
    if let Some((limit, source)) = crate::session::memory_budget(common.memory_limit) {
        session.sequence_memory_estimate(mode).check(limit, &source)?;
    }
    Ok(match common.backend.as_str() {
        "wgpu" => Box::new(open_gpu(common.gpu_limits.as_deref())?),
        _ => Box::new(CpuBackend::new()),
    })
}

/// `render --frames A..B` (the frames of `plan`: all of them, or one `--shard`'s): every frame in
/// order on one backend, each with the previous frame's history. Each frame's image (and AOVs) is
/// written as soon as it is rendered, into one all-or-nothing set committed with the last frame's
/// full outputs ([`crate::outputs::SequenceWriter`]): the memory held is one frame's, however many
/// frames the range has. A shard (`sharded`) writes its frames' files only: the preview and the
/// last frame's outputs belong to the whole sequence, and shards may share --out.
pub(super) fn render_frames(
    session: &mut Session,
    common: &Common,
    plan: &crate::shard::FramePlan,
    sharded: bool,
    aov: &[String],
) -> Result<String, WedgeError> {
    let (first, last) = (plan.first, plan.frames.last().copied().unwrap_or(plan.first));
    let what = match (sharded, plan.frames.as_slice()) {
        (true, [a, .., b]) => format!("frames {a}..{b} of a shard of {first}.. ({} frames)", plan.frames.len()),
        (true, [a]) => format!("frame {a} of a shard of {first}.."),
        _ => format!("frames {first}..{last}"),
    };
    let mut backend = sequence_backend(session, common, &what)?;
    for w in session.pipeline.sequence_warnings(first, last) {
        eprintln!("warning: {w}");
    }
    if let (Some(a), Some(b)) = (plan.warm_up.first(), plan.warm_up.last()) {
        eprintln!(
            "warming up the frame history on frames {a}..{b} ({} frame(s) rendered and not written) before frame {}: the \
             pipeline's history is a recurrence over every frame since {first}",
            plan.warm_up.len(),
            plan.frames.first().copied().unwrap_or(first)
        );
    }
    let bars = Bars::default();
    let pixels = u64::from(session.width) * u64::from(session.height);
    let runs = (plan.warm_up.len() + plan.frames.len()) as u64;
    let progress = TaskProgress::new(
        &bars,
        common.progress_format(),
        if sharded { "shard" } else { "frames" },
        runs.saturating_mul(TaskProgress::work(session.schedule.passes.len(), pixels)),
    );
    let mut out = if sharded {
        crate::outputs::SequenceWriter::frames_only(&common.out)?
    } else {
        crate::outputs::SequenceWriter::new(&common.out)?
    };
    let (mut previous, mut seconds) = (None, 0.0f64);
    let (mut last_aovs, mut aov_line) = (Vec::new(), String::new());
    for frame in plan.runs() {
        progress.at(None, Some(frame), pixels);
        // Without history no frame reads the one before, so a stride shard's frames need none.
        let history = if plan.history { previous.as_ref() } else { None };
        let run = session.run_frame(backend.as_mut(), &progress, frame, first, history)?;
        seconds += run.total_seconds();
        let warming = plan.warm_up.contains(&frame);
        if !warming {
            if let Some(b) = run.output("color") {
                out.frame(frame, &crate::outputs::buffer_to_image(b, session.width, session.height))?;
            }
        }
        previous = Some(run);
        // The AOVs of every frame's camera, `aov_NAME_NNNN.exr` beside `frame_NNNN.exr` (the inputs of
        // a mixed-reality sequence, `{frame:04}` in its file names); the last frame's also unnumbered,
        // like the full outputs.
        if !aov.is_empty() && !warming {
            let base = session.scene.camera;
            session.scene.camera = session.camera_at(frame);
            let aovs = aov_images(&session.scene, session, aov);
            session.scene.camera = base;
            let (maps, line) = aovs?;
            let numbered: Vec<_> = maps
                .iter()
                .map(|m| crate::outputs::ExtraExr { stem: format!("{}_{frame:04}", m.stem), ..m.clone() })
                .collect();
            out.extra(&numbered)?;
            if frame == last {
                (last_aovs, aov_line) = (maps, line);
            }
        }
    }
    let run = previous.expect("a frame plan holds at least one frame");
    let written = out.finish("render", &run, &last_aovs, session.width, session.height)?;
    let n = plan.frames.len() as u32;
    let mut text = summary(&run, session.width, session.height);
    text.push_str(&format!(
        "{n} frames in {seconds:.2} s of passes: {:.2} frames per second ({})\n",
        f64::from(n) / seconds.max(1e-9),
        backend.name()
    ));
    if !plan.warm_up.is_empty() {
        text.push_str(&format!(
            "of which {} warm-up frame(s) before the shard's chunk (not written)\n",
            plan.warm_up.len()
        ));
    }
    text.push_str(&aov_line);
    text.push_str(&written.warnings());
    for f in &written.files {
        text.push_str(&format!("wrote {}\n", f.display()));
    }
    Ok(text)
}

/// `render --progressive N`: frames 0..N−1 with a still camera, each continuing the previous frame's
/// history (`Session::run_progressive_frame`); after 1, 2, 4, 8, … frames and the last, one
/// all-or-nothing set of files: `progressive_NNNN.exr/png` (NNNN = frames so far) and that frame's
/// full outputs. Shows a bar over the frames and prints the time per frame and per pass class.
pub(super) fn render_progressive(
    session: &Session,
    common: &Common,
    frames: u32,
    aov: &[String],
) -> Result<String, WedgeError> {
    use crate::backends::KernelClass;
    if session.schedule.history.is_empty() {
        return Err(WedgeError::Usage(format!(
            "--progressive: {} has no node that accumulates over frames, so every frame would be a new image, not a \
             better one; use a PixelFilter or RadianceFilter pipeline (e.g. pipelines/progressive_pixel.ron or \
             progressive_radiance.ron), or --frames for a sequence",
            session.pipeline.path.display()
        )));
    }
    let mut backend = sequence_backend(session, common, &format!("progressive: {frames} frames"))?;
    let (extra, aov_line) = aov_images(&session.scene, session, aov)?;
    // Which frames run a scheduled filter (a pass with the PixelFilter schedule's parameters).
    let schedule = session.schedule.passes.iter().find_map(|p| {
        match (p.params.get("first_filter"), p.params.get("filter_first_frame")) {
            (Some(ParamValue::Int(first)), Some(ParamValue::Bool(ff))) => Some((*first as u32, *ff)),
            _ => None,
        }
    });
    let filters = |frame: u32| {
        schedule.is_some_and(|(first, ff)| crate::effects::pixel_filter::formulas::is_filter_frame(frame, first, ff))
    };
    let bar = indicatif::ProgressBar::new(u64::from(frames));
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{prefix:>12} [{bar:40}] {pos}/{len} frames {elapsed_precise} eta {eta} {msg}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar.set_prefix("progressive");
    let classes = [KernelClass::Sampling, KernelClass::Bandwidth, KernelClass::Filter, KernelClass::Compose];
    // Lines only: the bar over the frames is drawn here, not per pass.
    let pixels = u64::from(session.width) * u64::from(session.height);
    let progress = TaskProgress::lines_only(
        common.progress_format(),
        "progressive",
        u64::from(frames).saturating_mul(TaskProgress::work(session.schedule.passes.len(), pixels)),
    );
    // One closure, so that the bar is cleared before an error returns.
    let looped = (|| -> Result<_, WedgeError> {
        let mut previous: Option<crate::backends::RunResult> = None;
        let mut files: Vec<std::path::PathBuf> = Vec::new();
        let mut warnings = String::new();
        let (mut per_class, mut total, mut filter_frames, mut filter_seconds) = ([0.0f64; 4], 0.0f64, 0u32, 0.0f64);
        let mut frame_seconds: Vec<f64> = Vec::with_capacity(frames as usize);
        for frame in 0..frames {
            progress.at(None, Some(frame), pixels);
            let run = session.run_progressive_frame(backend.as_mut(), &progress, frame, previous.as_ref())?;
            let seconds = run.total_seconds();
            total += seconds;
            frame_seconds.push(seconds);
            for (k, c) in classes.iter().enumerate() {
                per_class[k] += run.seconds(*c);
            }
            if filters(frame) {
                filter_frames += 1;
                filter_seconds += run.seconds(KernelClass::Filter);
            }
            let n = frame + 1;
            if n.is_power_of_two() || n == frames {
                if let Some(color) = run.output("color") {
                    let image = crate::outputs::buffer_to_image(color, session.width, session.height);
                    let name = format!("progressive_{n:04}");
                    let written = crate::outputs::write_snapshot(
                        &common.out,
                        "render",
                        &run,
                        (&name, &image),
                        &extra,
                        session.width,
                        session.height,
                    )?;
                    if n == frames {
                        // The last set in full, after the earlier snapshots' own images.
                        files.extend(written.files.iter().cloned());
                        warnings = written.warnings();
                    } else {
                        files.extend(
                            written
                                .files
                                .iter()
                                .filter(|f| f.file_name().is_some_and(|s| s.to_string_lossy().starts_with(&name)))
                                .cloned(),
                        );
                    }
                }
            }
            bar.set_message(format!("{n} paths/px, {:.1} ms", seconds * 1e3));
            bar.inc(1);
            previous = Some(run);
        }
        Ok((previous, files, warnings, per_class, total, filter_frames, filter_seconds, frame_seconds))
    })();
    bar.finish_and_clear();
    let (last, files, warnings, per_class, total, filter_frames, filter_seconds, frame_seconds) = looped?;
    let run = last.expect("at least one frame");
    let n = f64::from(frames);
    let mut text = summary(&run, session.width, session.height);
    text.push_str(&format!(
        "progressive: {frames} frames in {total:.2} s of passes ({}): {:.2} ms per frame (first {:.2}, last {:.2}), {:.2} frames per second\n",
        backend.name(),
        total / n * 1e3,
        frame_seconds.first().copied().unwrap_or(0.0) * 1e3,
        frame_seconds.last().copied().unwrap_or(0.0) * 1e3,
        n / total.max(1e-9)
    ));
    let names = ["sampling", "bandwidth", "filter", "compose"];
    let parts: Vec<String> = names
        .iter()
        .zip(per_class)
        .map(|(name, s)| format!("{name} {:.2} ms ({:.1}%)", s / n * 1e3, 100.0 * s / total.max(1e-12)))
        .collect();
    text.push_str(&format!("per frame by pass class: {}\n", parts.join(", ")));
    if schedule.is_some() {
        text.push_str(&format!(
            "filter frames: {filter_frames} of {frames}, {:.2} ms per filter frame's filter passes; filtering took {:.1}% of all pass time\n",
            if filter_frames > 0 { filter_seconds / f64::from(filter_frames) * 1e3 } else { 0.0 },
            100.0 * per_class[2] / total.max(1e-12)
        ));
    }
    text.push_str(&aov_line);
    text.push_str(&warnings);
    for f in &files {
        text.push_str(&format!("wrote {}\n", f.display()));
    }
    Ok(text)
}

pub(super) fn run_wgpu(
    session: &Session,
    progress: &dyn crate::backends::Progress,
    limits: Option<&str>,
) -> Result<(crate::backends::RunResult, Option<String>), WedgeError> {
    let mut gpu = open_gpu(limits)?;
    eprintln!("wgpu adapter: {}", gpu.adapter_description());
    let run = session.run(&mut gpu, progress)?;
    let mut note = format!(
        "backend wgpu on {}; pass times are {}\n",
        gpu.adapter_description(),
        if gpu.has_timestamps() {
            "device timestamps (timestamp queries)"
        } else {
            "wall clock (no timestamp queries)"
        }
    );
    let split: Vec<String> = gpu.last_bands.iter().filter(|(_, n)| *n > 1).map(|(p, n)| format!("{p} ×{n}")).collect();
    if !split.is_empty() {
        note.push_str(&format!(
            "passes split into bands of rows (buffers over the device's storage-binding limit of {} bytes): {}\n",
            gpu.limits().max_storage_buffer_binding_size,
            split.join(", ")
        ));
    }
    let packed: Vec<&str> = gpu
        .last_plans
        .iter()
        .filter(|(_, plan)| *plan == crate::backends::gpu::shaders::BindingPlan::Packed)
        .map(|(p, _)| p.as_str())
        .collect();
    if !packed.is_empty() {
        note.push_str(&format!(
            "passes bound packed (more buffers than the device's {} storage buffers per stage): {}\n",
            gpu.limits().max_storage_buffers_per_shader_stage,
            packed.join(", ")
        ));
    }
    if gpu.is_software() {
        note.push_str("note: this adapter is a CPU emulation (lavapipe/llvmpipe); its times say nothing about a GPU\n");
    }
    Ok((run, Some(note)))
}
