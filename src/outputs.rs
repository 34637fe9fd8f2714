//! Turning a run into files and a summary: the final image (EXR linear + PNG sRGB), the unfiltered
//! image, heatmaps of filter width and rays per pixel (thesis Fig. 3.7), and per-pass timings.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use wedge_backends::{BufferData, KernelClass, RunResult};

use crate::heatmap::{write_heatmap_png, HeatmapSpec, Scale};
use crate::image::{write_exr, write_png_srgb, Image, ImageError};

/// A vec3/vec4 buffer as an image (first three components).
pub fn buffer_to_image(b: &BufferData, width: u32, height: u32) -> Image {
    Image::from_fn(width, height, |x, y| {
        let i = (y * width + x) as usize;
        [b.component(i, 0), b.component(i, 1), b.component(i, 2)]
    })
}

/// Write `stem.exr` and `stem.png`; returns the paths.
pub fn write_image_pair(dir: &Path, stem: &str, img: &Image) -> Result<Vec<PathBuf>, ImageError> {
    let exr = dir.join(format!("{stem}.exr"));
    let png = dir.join(format!("{stem}.png"));
    write_exr(&exr, img)?;
    write_png_srgb(&png, img, 1.0)?;
    Ok(vec![exr, png])
}

/// Write everything a run produced into `dir` (created if missing); `stem` names the final image.
pub fn write_run(dir: &Path, stem: &str, run: &RunResult, width: u32, height: u32) -> Result<Vec<PathBuf>, ImageError> {
    std::fs::create_dir_all(dir).map_err(|source| ImageError::Write { path: dir.to_path_buf(), source })?;
    let mut written = Vec::new();
    if let Some(c) = run.output("color") {
        written.extend(write_image_pair(dir, stem, &buffer_to_image(c, width, height))?);
    }
    if let Some(u) = run.output("unfiltered") {
        written.extend(write_image_pair(dir, "unfiltered", &buffer_to_image(u, width, height))?);
    }
    if let Some(f) = run.output("filter_width") {
        let values = f.to_scalar();
        let mask: Vec<bool> = values.iter().map(|v| *v <= 0.0).collect();
        let path = dir.join("filter_width.png");
        let spec = HeatmapSpec { title: "filter width (beta)", unit: "px", scale: Scale::Log, range: None };
        write_heatmap_png(&path, width, height, &values, Some(&mask), &spec)?;
        written.push(path);
    }
    if let Some(r) = run.output("rays_per_pixel") {
        let values = r.to_scalar();
        let path = dir.join("rays_per_pixel.png");
        let spec = HeatmapSpec { title: "rays per pixel", unit: "rays", scale: Scale::Log, range: None };
        write_heatmap_png(&path, width, height, &values, None, &spec)?;
        written.push(path);
    }
    Ok(written)
}

/// Average rays per pixel of each kind, and the per-pass time table.
pub fn summary(run: &RunResult, width: u32, height: u32) -> String {
    let px = (width as f64 * height as f64).max(1.0);
    let r = run.rays;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "rays per pixel: {:.2} shadow + {:.2} secondary + {:.2} primary = {:.2} total",
        r.shadow_rays as f64 / px,
        r.secondary_rays as f64 / px,
        r.primary_rays as f64 / px,
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
        "total {:.1} ms: sampling {:.1} ms, bandwidth+filter {:.1} ms ({:.1}% of sampling), compose {:.1} ms; {} physical buffers",
        run.total_seconds() * 1e3,
        sampling * 1e3,
        overhead * 1e3,
        if sampling > 0.0 { 100.0 * overhead / sampling } else { 0.0 },
        run.seconds(KernelClass::Compose) * 1e3,
        run.allocations
    );
    s
}
