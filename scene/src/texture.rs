//! Linear-RGB textures with bilinear, repeating lookup.

use std::path::Path;

use glam::Vec2;
use glam::Vec3;

use crate::limits::{MAX_TEXTURE_PIXELS, MAX_TEXTURE_SIDE};
use crate::SceneError;

/// A texture in linear RGB (sRGB-encoded images are decoded on load). Row 0 is the top row of the
/// image and `v = 0` addresses it, as in glTF. OBJ's `vt` has `v = 0` at the bottom, so the OBJ loader
/// stores `1 - v`.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 3]>,
}

impl Texture {
    /// A `size`×`size` checkerboard of `checks`×`checks` squares alternating between `a` and `b`.
    pub fn checker(size: u32, checks: u32, a: f32, b: f32) -> Texture {
        let cell = (size / checks.max(1)).max(1);
        let texels = (0..size * size)
            .map(|i| {
                let (x, y) = (i % size, i / size);
                let v = if ((x / cell) + (y / cell)) & 1 == 0 { a } else { b };
                [v; 3]
            })
            .collect();
        Texture { width: size, height: size, texels }
    }

    /// Texel at integer coordinates with wrap-around (repeat).
    fn texel(&self, x: i64, y: i64) -> Vec3 {
        let x = x.rem_euclid(self.width as i64) as usize;
        let y = y.rem_euclid(self.height as i64) as usize;
        Vec3::from(self.texels[y * self.width as usize + x])
    }

    /// Bilinear lookup with repeat wrapping. Texel (i, j) has its centre at uv = ((i+0.5)/w, (j+0.5)/h),
    /// where it returns exactly that texel's value. Non-finite uv (degenerate input) reads texel (0,0).
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        if self.width == 0 || self.height == 0 || self.texels.is_empty() {
            return Vec3::ONE;
        }
        let uv = if uv.is_finite() { uv } else { Vec2::splat(0.5) / Vec2::new(self.width as f32, self.height as f32) };
        // Keep the coordinate small before converting so huge repeats do not lose the fraction.
        let x = uv.x.rem_euclid(1.0) * self.width as f32 - 0.5;
        let y = uv.y.rem_euclid(1.0) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (xi, yi) = (x0 as i64, y0 as i64);
        let top = self.texel(xi, yi).lerp(self.texel(xi + 1, yi), fx);
        let bottom = self.texel(xi, yi + 1).lerp(self.texel(xi + 1, yi + 1), fx);
        top.lerp(bottom, fy)
    }

    /// Build from 8-bit sRGB pixels (`channels` = 1..4; alpha ignored, grey replicated).
    pub fn from_srgb8(width: u32, height: u32, channels: usize, pixels: &[u8]) -> Option<Texture> {
        let n = width as usize * height as usize;
        if channels == 0 || pixels.len() < n * channels || n == 0 {
            return None;
        }
        let lut: Vec<f32> = (0..256).map(|i| srgb_to_linear(i as f32 / 255.0)).collect();
        let texels = pixels
            .chunks_exact(channels)
            .take(n)
            .map(|p| {
                if channels >= 3 {
                    [lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]]
                } else {
                    [lut[p[0] as usize]; 3]
                }
            })
            .collect();
        Some(Texture { width, height, texels })
    }

    /// Build from a decoded `image` crate image (assumed sRGB, as base-colour textures are).
    pub fn from_image(img: &image::DynamicImage) -> Option<Texture> {
        let rgb = img.to_rgb8();
        Texture::from_srgb8(rgb.width(), rgb.height(), 3, rgb.as_raw())
    }
}

/// Decode an encoded image (PNG/JPEG) as an sRGB base-colour texture. The size is read from the
/// header and checked against [`MAX_TEXTURE_SIDE`]/[`MAX_TEXTURE_PIXELS`] before any pixel is decoded, so
/// a 100000 × 100000 PNG of a few bytes is refused instead of allocating gigabytes. `file` is the file
/// the error is reported against, `what` says which image it is (e.g. `images[0]` or `map_Kd wood.png`).
pub(crate) fn decode_texture(bytes: &[u8], file: &Path, what: &str) -> Result<Texture, SceneError> {
    let unreadable = |e: &dyn std::fmt::Display| {
        SceneError::invalid(
            file,
            format!("{what} is not a readable PNG or JPEG image ({e})"),
            "re-export the texture as 8-bit PNG or JPEG",
        )
    };
    let reader =
        || image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| unreadable(&e));
    let (w, h) = reader()?.into_dimensions().map_err(|e| unreadable(&e))?;
    if w > MAX_TEXTURE_SIDE || h > MAX_TEXTURE_SIDE || w as u64 * h as u64 > MAX_TEXTURE_PIXELS {
        return Err(SceneError::invalid(
            file,
            format!(
                "{what} is {w}x{h} pixels, more than the limit ({MAX_TEXTURE_SIDE} per side, \
                 {MAX_TEXTURE_PIXELS} pixels in all)"
            ),
            "downscale the texture (8192x8192 at most)",
        ));
    }
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIDE);
    limits.max_image_height = Some(MAX_TEXTURE_SIDE);
    // RGBA16 at the largest allowed size, plus decoder scratch.
    limits.max_alloc = Some(MAX_TEXTURE_PIXELS * 8 + (64 << 20));
    let mut decoder = reader()?;
    decoder.limits(limits);
    let img = decoder.decode().map_err(|e| unreadable(&e))?;
    Texture::from_image(&img)
        .ok_or_else(|| SceneError::invalid(file, format!("{what} is empty"), "use a non-empty image"))
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}
