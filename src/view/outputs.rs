//! The output picker's entries: every buffer of a run that can be shown, drawn as `wedge render`
//! draws it — `Output`'s images tone-mapped like its PNGs (`crate::image::to_srgb8`), heatmaps with
//! their title and colour bar (`crate::outputs::heatmap_views`).

use wedge_backends::RunResult;

use crate::outputs::{buffer_to_image, heatmap_views, IMAGE_PORTS};

/// An 8-bit sRGB picture, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Picture {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

/// The names of the outputs of `run` that can be shown, images first, in `wedge render`'s order.
pub fn names(run: &RunResult) -> Vec<String> {
    let images = IMAGE_PORTS.iter().filter(|(port, _)| run.output(port).is_some()).map(|(port, _)| port.to_string());
    images.chain(heatmap_views(run).into_iter().map(|h| h.name)).collect()
}

/// Output `name` of `run` (an image is `width` × `height`, a heatmap larger by its colour bar), with
/// images scaled by `exposure` before the sRGB curve (1 = as `render`'s PNG). `None`: no such output.
pub fn picture(run: &RunResult, name: &str, width: u32, height: u32, exposure: f32) -> Option<Picture> {
    if IMAGE_PORTS.iter().any(|(port, _)| *port == name) {
        let image = buffer_to_image(run.output(name)?, width, height);
        return Some(Picture { width, height, rgb: crate::image::to_srgb8(&image, exposure) });
    }
    let view = heatmap_views(run).into_iter().find(|h| h.name == name)?;
    let (width, height, rgb) = view.render(width, height);
    Some(Picture { width, height, rgb })
}
