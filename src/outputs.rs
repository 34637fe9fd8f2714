//! Turning a run into files and a summary: the final image (EXR linear + PNG sRGB), the unfiltered
//! image, heatmaps of filter width and rays per pixel (thesis Fig. 3.7), and per-pass timings.
//! A run's files are written as one all-or-nothing set ([`crate::staging::Staging`]), and images
//! with NaN/inf pixels are counted and warned about ([`WrittenRun::warnings`]).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use wedge_backends::{BufferData, KernelClass, RunResult};
use wedge_effects::heatmap;

use crate::heatmap::{write_heatmap_png, HeatmapSpec, Scale};
use crate::image::{write_exr, write_exr_rgba, write_png_srgb, GifStream, Image, ImageError};
use crate::staging::Staging;

/// A vec3/vec4 buffer as an image (first three components).
pub fn buffer_to_image(b: &BufferData, width: u32, height: u32) -> Image {
    Image::from_fn(width, height, |x, y| {
        let i = (y * width + x) as usize;
        [b.component(i, 0), b.component(i, 1), b.component(i, 2)]
    })
}

/// Pixels of `img` with a NaN or infinite channel.
pub fn non_finite_pixels(img: &Image) -> usize {
    img.pixels.iter().filter(|p| p.iter().any(|c| !c.is_finite())).count()
}

/// What [`write_run`] put on disk.
#[derive(Clone, Debug, Default)]
pub struct WrittenRun {
    pub files: Vec<PathBuf>,
    /// `(file stem, pixels)` of every written image with NaN/inf pixels (EXR keeps them, the PNG
    /// shows them magenta): never written silently, see [`WrittenRun::warnings`].
    pub non_finite: Vec<(String, usize)>,
}

impl WrittenRun {
    /// One warning line per image with non-finite pixels (empty when there are none).
    pub fn warnings(&self) -> String {
        let mut s = String::new();
        for (stem, n) in &self.non_finite {
            let _ = writeln!(
                s,
                "warning: {n} pixel(s) of {stem}.exr/{stem}.png are NaN or infinite (stored as-is in the EXR, magenta in \
                 the PNG); check the scene's emission and material values"
            );
        }
        s
    }
}

/// A float image written beside a run's outputs as `<stem>.exr` in the same all-or-nothing set, e.g.
/// the `--aov` maps ([`crate::aov`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ExtraExr {
    pub stem: String,
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first.
    pub pixels: Vec<[f32; 4]>,
    /// RGBA (A holds data, e.g. coverage) or RGB (A ignored).
    pub alpha: bool,
}

/// Write everything a run produced into `dir` (created if missing), all-or-nothing (see
/// [`crate::staging`]); `stem` names the final image. Besides `Output`'s image, unfiltered image and
/// two heatmaps, every `Heatmap` sink (`wedge_effects::heatmap`) becomes `<node name>.png`, drawn as
/// its parameters say (the run carries each sink's kind and parameters, [`RunResult::sinks`]).
pub fn write_run(dir: &Path, stem: &str, run: &RunResult, width: u32, height: u32) -> Result<WrittenRun, ImageError> {
    write_run_with(dir, stem, run, &[], width, height)
}

/// [`write_run_with`] for one snapshot of a progressive render (`render --progressive`): the run's
/// outputs, `extra` EXRs and `<name>.exr` / `<name>.png` of `image` (e.g. `progressive_0016`), all in
/// one all-or-nothing set, so an interrupted render keeps the last complete snapshot.
pub fn write_snapshot(
    dir: &Path,
    stem: &str,
    run: &RunResult,
    (name, image): (&str, &Image),
    extra: &[ExtraExr],
    width: u32,
    height: u32,
) -> Result<WrittenRun, ImageError> {
    let mut set = OutputSet::new(dir)?;
    set.image(name, image, &format!("the image `{name}`"))?;
    set.run(stem, run, extra, width, height)?;
    set.commit()
}

/// [`write_run`] with `extra` EXRs in the same all-or-nothing set; a stem clashing with another
/// output is an error, as for heatmaps.
pub fn write_run_with(
    dir: &Path,
    stem: &str,
    run: &RunResult,
    extra: &[ExtraExr],
    width: u32,
    height: u32,
) -> Result<WrittenRun, ImageError> {
    let mut set = OutputSet::new(dir)?;
    set.run(stem, run, extra, width, height)?;
    set.commit()
}

/// An already drawn 8-bit sRGB picture (`width * height * 3` bytes, top row first), written as
/// `<name>.png` beside a run's outputs: what `wedge view` shows when its screenshot key is pressed.
pub struct Picture<'a> {
    pub name: &'a str,
    pub width: u32,
    pub height: u32,
    pub rgb: &'a [u8],
}

/// [`write_run`] and `picture` in one all-or-nothing set (`wedge view`'s screenshot).
pub fn write_run_with_picture(
    dir: &Path,
    stem: &str,
    run: &RunResult,
    picture: &Picture,
    width: u32,
    height: u32,
) -> Result<WrittenRun, ImageError> {
    let mut set = OutputSet::new(dir)?;
    set.run(stem, run, &[], width, height)?;
    let path = set.file(&format!("{}.png", picture.name), "the viewer's picture")?;
    crate::image::write_png_rgb8(&path, picture.width, picture.height, picture.rgb)?;
    set.commit()
}

/// The files of `render --frames`, written as the frames come so that a sequence of any length holds
/// one frame in memory: `frame_NNNN.exr` / `.png` and `extra` EXRs of each frame are staged on disk
/// at once, `preview.gif` (sRGB, 8 bits, 24 frames per second, looping) is encoded frame by frame
/// ([`GifStream`]), and [`SequenceWriter::finish`] adds the last frame's full outputs and commits
/// everything as one all-or-nothing set (an interrupted sequence leaves no files).
pub struct SequenceWriter {
    set: OutputSet,
    /// The preview, started with the first frame (a run without an image writes none).
    gif: Option<GifStream>,
    /// A shard of a sequence (`render --shard`): only the frames' files, no preview and no
    /// last-frame outputs, which belong to the whole sequence.
    frames_only: bool,
}

/// Frames per second of a sequence's `preview.gif`.
const PREVIEW_FPS: u32 = 24;

impl SequenceWriter {
    /// Start a sequence in `dir` (created if missing).
    pub fn new(dir: &Path) -> Result<SequenceWriter, ImageError> {
        Ok(SequenceWriter { set: OutputSet::new(dir)?, gif: None, frames_only: false })
    }

    /// Start a shard of a sequence in `dir`: [`SequenceWriter::frame`] and
    /// [`SequenceWriter::extra`] stage the frames' files as for a whole sequence, and
    /// [`SequenceWriter::finish`] commits them alone.
    pub fn frames_only(dir: &Path) -> Result<SequenceWriter, ImageError> {
        Ok(SequenceWriter { frames_only: true, ..SequenceWriter::new(dir)? })
    }

    /// Stage frame `frame`'s image and append it to the preview.
    pub fn frame(&mut self, frame: u32, image: &Image) -> Result<(), ImageError> {
        self.set.image(&format!("frame_{frame:04}"), image, &format!("frame {frame}"))?;
        if self.gif.is_none() && !self.frames_only {
            let path = self.set.file("preview.gif", "the animated preview")?;
            self.gif = Some(GifStream::create(&path, image.width, image.height, PREVIEW_FPS)?);
        }
        match self.gif.as_mut() {
            Some(gif) => gif.push(image),
            None => Ok(()),
        }
    }

    /// Stage EXRs that belong to one frame (its `--aov` maps).
    pub fn extra(&mut self, extra: &[ExtraExr]) -> Result<(), ImageError> {
        extra.iter().try_for_each(|e| self.set.extra(e))
    }

    /// Finish the preview, stage the last frame's outputs (`run`, `extra`) and commit the set.
    pub fn finish(
        mut self,
        stem: &str,
        run: &RunResult,
        extra: &[ExtraExr],
        width: u32,
        height: u32,
    ) -> Result<WrittenRun, ImageError> {
        if let Some(gif) = self.gif.take() {
            gif.finish()?;
        }
        if !self.frames_only {
            self.set.run(stem, run, extra, width, height)?;
        }
        self.set.commit()
    }
}

/// Stage the images of `images` (`(port, image)`) under the names `render` gives them
/// ([`IMAGE_PORTS`]; `color` as `stem`) and commit them as one set: what `wedge merge` writes from
/// tiles, through the same writers, so its files are the bytes `render` writes.
pub fn write_images(dir: &Path, stem: &str, images: &[(String, Image)]) -> Result<WrittenRun, ImageError> {
    let mut set = OutputSet::new(dir)?;
    for (port, default_name) in IMAGE_PORTS {
        let name = if port == "color" { stem } else { default_name };
        if let Some((_, img)) = images.iter().find(|(p, _)| p == port) {
            set.image(name, img, &format!("the `{port}` image"))?;
        }
    }
    set.commit()
}

/// One all-or-nothing set of output files being staged ([`Staging`]), with the name of each file's
/// producer, so that two outputs claiming one file name (a `Heatmap` node named like another
/// output) are an error instead of a silently lost file; and the images with non-finite pixels.
struct OutputSet {
    dir: PathBuf,
    staging: Staging,
    /// File name → which output writes it.
    claimed: Vec<(String, String)>,
    non_finite: Vec<(String, usize)>,
}

impl OutputSet {
    fn new(dir: &Path) -> Result<OutputSet, ImageError> {
        Ok(OutputSet {
            dir: dir.to_path_buf(),
            staging: Staging::new(dir)?,
            claimed: Vec::new(),
            non_finite: Vec::new(),
        })
    }

    /// Where to write `file` (claimed for `what`), or the clash with its first claimant.
    fn file(&mut self, file: &str, what: &str) -> Result<PathBuf, ImageError> {
        if let Some((_, first)) = self.claimed.iter().find(|(f, _)| f == file) {
            return Err(ImageError::Clash {
                path: self.dir.join(file),
                first: first.clone(),
                second: what.to_string(),
            });
        }
        self.claimed.push((file.to_string(), what.to_string()));
        self.staging.file(file)
    }

    /// Stage `name.exr` and `name.png` of `img`, counting its non-finite pixels.
    fn image(&mut self, name: &str, img: &Image, what: &str) -> Result<(), ImageError> {
        write_exr(&self.file(&format!("{name}.exr"), what)?, img)?;
        write_png_srgb(&self.file(&format!("{name}.png"), what)?, img, 1.0)?;
        let bad = non_finite_pixels(img);
        if bad > 0 {
            self.non_finite.push((name.to_string(), bad));
        }
        Ok(())
    }

    /// Stage `<stem>.exr` of an extra image.
    fn extra(&mut self, e: &ExtraExr) -> Result<(), ImageError> {
        let path = self.file(&format!("{}.exr", e.stem), &format!("the extra image `{}`", e.stem))?;
        if e.alpha {
            write_exr_rgba(&path, e.width, e.height, &e.pixels)?;
        } else {
            let img = Image {
                width: e.width,
                height: e.height,
                pixels: e.pixels.iter().map(|p| [p[0], p[1], p[2]]).collect(),
            };
            write_exr(&path, &img)?;
        }
        Ok(())
    }

    /// Stage everything `run` produced (see [`write_run`]) and `extra`.
    fn run(
        &mut self,
        stem: &str,
        run: &RunResult,
        extra: &[ExtraExr],
        width: u32,
        height: u32,
    ) -> Result<(), ImageError> {
        for (port, default_name) in IMAGE_PORTS {
            let name = if port == "color" { stem } else { default_name };
            if let Some(b) = run.output(port) {
                self.image(name, &buffer_to_image(b, width, height), &format!("the `{port}` image"))?;
            }
        }
        for map in heatmap_views(run) {
            let path = self.file(&format!("{}.png", map.name), &map.what)?;
            map.write(&path, width, height)?;
        }
        extra.iter().try_for_each(|e| self.extra(e))
    }

    /// Move every staged file into place, or none.
    fn commit(self) -> Result<WrittenRun, ImageError> {
        Ok(WrittenRun { files: self.staging.commit()?, non_finite: self.non_finite })
    }
}

/// The `(port, file stem)` of `Output`'s images, written as EXR + PNG (tone-mapped).
pub const IMAGE_PORTS: [(&str, &str); 2] = [("color", "render"), ("unfiltered", "unfiltered")];

/// One heatmap a run produced (an `Output` map or a `Heatmap` sink): its values and how to draw
/// them. `wedge render` writes each as `<name>.png`; `wedge view` shows the same picture.
#[derive(Clone, Debug)]
pub struct HeatmapView {
    /// File stem: the `Output` port or the `Heatmap` node's name.
    pub name: String,
    /// Which output writes it, for a clash message.
    pub what: String,
    pub title: String,
    pub unit: String,
    pub scale: Scale,
    /// Draw values ≤ 0 black (e.g. "not filtered").
    pub mask_zero: bool,
    pub values: Vec<f32>,
    /// Per-pixel velocity strokes (a `motion` input).
    pub arrows: Option<Vec<[f32; 2]>>,
}

impl HeatmapView {
    /// The picture with title and colour bar: `(width, height, rgb8)`.
    pub fn render(&self, width: u32, height: u32) -> (u32, u32, Vec<u8>) {
        let mask = self.mask();
        crate::heatmap::render_heatmap(width, height, &self.values, mask.as_deref(), &self.spec())
    }

    fn write(&self, path: &Path, width: u32, height: u32) -> Result<(), ImageError> {
        let mask = self.mask();
        write_heatmap_png(path, width, height, &self.values, mask.as_deref(), &self.spec())
    }

    fn mask(&self) -> Option<Vec<bool>> {
        self.mask_zero.then(|| self.values.iter().map(|v| *v <= 0.0).collect())
    }

    fn spec(&self) -> HeatmapSpec<'_> {
        HeatmapSpec {
            title: &self.title,
            unit: &self.unit,
            scale: self.scale,
            range: None,
            arrows: self.arrows.as_deref(),
        }
    }
}

/// Every heatmap of `run`, in the order `wedge render` writes them: `Output`'s filter width and rays
/// per pixel, then every `Heatmap` sink drawn as its parameters say (the run carries each sink's kind
/// and parameters, [`RunResult::sinks`]).
pub fn heatmap_views(run: &RunResult) -> Vec<HeatmapView> {
    let mut views = Vec::new();
    let output_maps =
        [("filter_width", "filter width (beta)", "px", true), ("rays_per_pixel", "rays per pixel", "rays", false)];
    for (port, title, unit, mask_zero) in output_maps {
        if let Some(b) = run.output(port) {
            views.push(HeatmapView {
                name: port.to_string(),
                what: format!("the `{port}` heatmap"),
                title: title.to_string(),
                unit: unit.to_string(),
                scale: Scale::Log,
                mask_zero,
                values: b.to_scalar(),
                arrows: None,
            });
        }
    }
    for ((node, port), b) in &run.outputs {
        let Some(sink) = run.sinks.get(node).filter(|s| s.kind == heatmap::KIND) else { continue };
        let Some(d) = heatmap::describe(node, &sink.params, port) else { continue };
        // A `motion` input (v_x, v_y, Ω, σ): σ with strokes along v.
        let arrows = d.velocity.then(|| (0..b.len()).map(|i| [b.component(i, 0), b.component(i, 1)]).collect());
        let values = if d.velocity { (0..b.len()).map(|i| b.component(i, 3)).collect() } else { b.to_scalar() };
        views.push(HeatmapView {
            name: node.clone(),
            what: format!("Heatmap node `{node}`"),
            title: d.title.clone(),
            unit: d.unit.clone(),
            scale: if d.log { Scale::Log } else { Scale::Linear },
            mask_zero: d.mask_zero,
            values,
            arrows,
        });
    }
    views
}

/// Average rays per pixel of each kind, and the per-pass time table.
pub fn summary(run: &RunResult, width: u32, height: u32) -> String {
    let px = (width as f64 * height as f64).max(1.0);
    let r = run.rays;
    let mut s = String::new();
    let _ = writeln!(
        s,
        // As the thesis counts rays (Ch. 5: a sample is 1 primary + 1 shadow + 1 indirect ray + the
        // next-event shadow ray at the indirect hit, which is counted with the shadow rays here).
        "rays per pixel: {:.2} primary + {:.2} shadow + {:.2} indirect = {:.2} total",
        r.primary_rays as f64 / px,
        r.shadow_rays as f64 / px,
        r.secondary_rays as f64 / px,
        r.total_rays() as f64 / px
    );
    if r.non_finite_samples > 0 {
        let by_pass: Vec<String> = run
            .timings
            .iter()
            .filter(|t| t.counts.non_finite_samples > 0)
            .map(|t| format!("{} {}", t.pass, t.counts.non_finite_samples))
            .collect();
        let _ = writeln!(
            s,
            "warning: {} non-finite (NaN or infinite) samples were excluded from the image ({}); check the scene's \
             emission and material values",
            r.non_finite_samples,
            by_pass.join(", ")
        );
    }
    if r.cut_loops > 0 {
        let _ = writeln!(
            s,
            "warning: the GPU driver stopped {} shader loops before they finished (lavapipe ends a loop after 65,535 \
             iterations), so some rays and samples are missing from this image; lower mu / bounces / max_rays, or use \
             --backend cpu",
            r.cut_loops
        );
    }
    let _ = writeln!(s, "{:<32} {:<22} {:>10}", "pass", "kernel", "ms");
    for t in &run.timings {
        let _ = writeln!(s, "{:<32} {:<22} {:>10.2}", t.pass, t.kernel, t.seconds * 1e3);
    }
    let sampling = run.seconds(KernelClass::Sampling);
    let overhead = run.seconds(KernelClass::Bandwidth) + run.seconds(KernelClass::Filter);
    let _ = writeln!(
        s,
        "total {:.1} ms: sampling {:.1} ms, bandwidth+filter {:.1} ms ({:.1}% of sampling), compose {:.1} ms; {} buffers allocated (0: the pool of an earlier run reused)",
        run.total_seconds() * 1e3,
        sampling * 1e3,
        overhead * 1e3,
        if sampling > 0.0 { 100.0 * overhead / sampling } else { 0.0 },
        run.seconds(KernelClass::Compose) * 1e3,
        run.allocations
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;
    use wedge_backends::RayCounts;

    fn run_with_color(color: Vec<[f32; 3]>) -> RunResult {
        let mut outputs = BTreeMap::new();
        outputs.insert(("out".to_string(), "color".to_string()), BufferData::Vec3(color));
        RunResult {
            outputs,
            sinks: BTreeMap::new(),
            timings: Vec::new(),
            rays: RayCounts::default(),
            allocations: 0,
            history: BTreeMap::new(),
        }
    }

    #[test]
    fn non_finite_output_pixels_are_counted_and_warned_about() {
        let dir = tempfile::tempdir().unwrap();
        let mut color = vec![[0.5f32; 3]; 6];
        color[1] = [f32::NAN, 0.0, 0.0];
        color[4] = [0.0, f32::INFINITY, 0.0];
        let w = write_run(dir.path(), "render", &run_with_color(color), 3, 2).unwrap();
        assert_eq!(w.non_finite, vec![("render".to_string(), 2)]);
        let text = w.warnings();
        assert!(text.contains("warning: 2 pixel(s) of render.exr/render.png are NaN or infinite"), "{text}");
        assert_eq!(w.files, vec![dir.path().join("render.exr"), dir.path().join("render.png")]);
        let back = crate::image::read_exr(&dir.path().join("render.exr")).unwrap();
        assert!(back.pixels[1][0].is_nan(), "the EXR keeps the value as it is");
        let clean = write_run(dir.path(), "render", &run_with_color(vec![[0.5; 3]; 6]), 3, 2).unwrap();
        assert!(clean.non_finite.is_empty() && clean.warnings().is_empty());
    }

    /// `--aov`'s maps go into the run's set: RGBA kept bit for bit (coverage in A), RGB as RGB, and a
    /// stem that clashes with another output is refused with nothing written.
    #[test]
    fn extra_exrs_join_the_set_alpha_kept_and_clashes_refused() {
        let dir = tempfile::tempdir().unwrap();
        let pixels: Vec<[f32; 4]> = (0..6).map(|i| [i as f32, -1.5, 1e-20, (i % 2) as f32]).collect();
        let position =
            ExtraExr { stem: "aov_position".into(), width: 3, height: 2, pixels: pixels.clone(), alpha: true };
        let normal = ExtraExr { stem: "aov_normal".into(), alpha: false, ..position.clone() };
        let run = run_with_color(vec![[0.5; 3]; 6]);
        let w = write_run_with(dir.path(), "render", &run, &[position.clone(), normal], 3, 2).unwrap();
        assert!(
            w.files.contains(&dir.path().join("aov_position.exr"))
                && w.files.contains(&dir.path().join("aov_normal.exr"))
        );
        let back = exr::prelude::read_first_rgba_layer_from_file(
            dir.path().join("aov_position.exr"),
            |res, _| vec![[0.0f32; 4]; res.width() * res.height()],
            |v: &mut Vec<[f32; 4]>, pos, (r, g, b, a): (f32, f32, f32, f32)| v[pos.y() * 3 + pos.x()] = [r, g, b, a],
        )
        .unwrap();
        assert_eq!(back.layer_data.channel_data.pixels, pixels);
        let rgb = crate::image::read_exr(&dir.path().join("aov_normal.exr")).unwrap();
        assert_eq!(rgb.pixels[5], [5.0, -1.5, 1e-20]);
        let other = tempfile::tempdir().unwrap();
        let clash = ExtraExr { stem: "render".into(), ..position };
        let err = write_run_with(other.path(), "render", &run, &[clash], 3, 2).unwrap_err().to_string();
        assert!(err.contains("render.exr"), "{err}");
        assert_eq!(std::fs::read_dir(other.path()).unwrap().count(), 0, "nothing written: {err}");
    }

    #[test]
    fn a_failed_write_leaves_the_previous_set_and_no_temporaries() {
        let dir = tempfile::tempdir().unwrap();
        write_run(dir.path(), "render", &run_with_color(vec![[0.5; 3]; 6]), 3, 2).unwrap();
        let before = std::fs::read(dir.path().join("render.exr")).unwrap();
        // The filter-width heatmap is one pixel short: it fails after render.exr/.png were staged.
        let mut run = run_with_color(vec![[0.9; 3]; 6]);
        run.outputs.insert(("out".into(), "filter_width".into()), BufferData::F32(vec![1.0; 5]));
        let err = write_run(dir.path(), "render", &run, 3, 2).unwrap_err().to_string();
        assert!(err.contains("filter_width.png"), "{err}");
        assert_eq!(std::fs::read(dir.path().join("render.exr")).unwrap(), before);
        let mut names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["render.exr", "render.png"]);
    }

    /// `--frames` streams: each frame is on disk (staged, not in memory) as soon as it is pushed, a
    /// sequence dropped before `finish` leaves nothing behind, and a finished one has every frame and a
    /// GIF with one image per frame.
    #[test]
    fn a_sequence_is_staged_frame_by_frame_and_committed_whole() {
        let dir = tempfile::tempdir().unwrap();
        let frame = |v: f32| Image { width: 3, height: 2, pixels: vec![[v; 3]; 6] };
        let staged_files = |d: &Path| -> usize {
            std::fs::read_dir(d)
                .unwrap()
                .map(|e| e.unwrap().path())
                .filter(|p| p.is_dir())
                .map(|p| std::fs::read_dir(p).unwrap().count())
                .sum()
        };
        let mut dropped = SequenceWriter::new(dir.path()).unwrap();
        dropped.frame(0, &frame(0.1)).unwrap();
        dropped.frame(1, &frame(0.2)).unwrap();
        assert_eq!(staged_files(dir.path()), 5, "two frames' EXR+PNG and the GIF are staged on disk");
        drop(dropped);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "an unfinished sequence leaves nothing");

        let mut seq = SequenceWriter::new(dir.path()).unwrap();
        for f in 0..3 {
            seq.frame(f, &frame(0.1 * (f + 1) as f32)).unwrap();
        }
        let written = seq.finish("render", &run_with_color(vec![[0.3; 3]; 6]), &[], 3, 2).unwrap();
        for name in ["frame_0000.exr", "frame_0002.png", "render.exr", "preview.gif"] {
            assert!(written.files.contains(&dir.path().join(name)), "{name}: {:?}", written.files);
        }
        let mut decoder =
            gif::DecodeOptions::new().read_info(std::fs::File::open(dir.path().join("preview.gif")).unwrap()).unwrap();
        let mut frames = 0;
        while decoder.read_next_frame().unwrap().is_some() {
            frames += 1;
        }
        assert_eq!(frames, 3);
        let back = crate::image::read_exr(&dir.path().join("frame_0001.exr")).unwrap();
        assert_eq!(back.pixels[0], [0.2; 3]);
    }
}
