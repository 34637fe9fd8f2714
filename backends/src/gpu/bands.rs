//! Splitting one pass into bands of rows when its per-pixel buffers exceed the device's storage
//! binding limit (a `vec4` buffer at 7680×4320 is 531 MB; lavapipe and wgpu's defaults bind at most
//! 128 MiB = 134 MB, which a `vec4` buffer passes from 4096×2160 on). Each band is one dispatch over rows `[row0, row_end)` whose bindings hold only the
//! pixels `[first, end)`: its own rows plus the rows the kernel reads around them ([`Reach`]),
//! starting at a pixel whose byte offset meets the device's offset alignment in every format.
//!
//! The buffers themselves stay whole (one `wgpu::Buffer` per pool slot, under `max_buffer_size`);
//! only what one dispatch binds is limited. A kernel that reads anywhere ([`Reach::Image`]) is
//! never split: over the limit it is an error naming the kernel.

use crate::kernel::Reach;

/// One dispatch of a split pass. Pixel indices are absolute (`y · width + x`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Band {
    /// Rows this dispatch computes.
    pub row0: u32,
    pub row_end: u32,
    /// Pixels its bindings hold: element 0 of every bound buffer is pixel `first`.
    pub first: u64,
    pub end: u64,
}

/// What the device allows one dispatch to bind.
#[derive(Clone, Copy, Debug)]
pub struct BindLimits {
    /// Largest storage binding in bytes (`max_storage_buffer_binding_size`).
    pub max_binding: u64,
    /// Required alignment of a binding's byte offset (`min_storage_buffer_offset_alignment`).
    pub offset_alignment: u64,
    /// Most rows one dispatch may cover (`max_compute_workgroups_per_dimension` × 8).
    pub max_rows: u32,
}

/// Split `width × height` pixels for a kernel reading `reach` whose widest binding has
/// `bytes_per_pixel` bytes per pixel. One band covering everything when it fits.
pub fn plan(
    width: u32,
    height: u32,
    bytes_per_pixel: u64,
    reach: Reach,
    limits: &BindLimits,
) -> Result<Vec<Band>, String> {
    let pixels = width as u64 * height as u64;
    let fits = pixels * bytes_per_pixel <= limits.max_binding;
    if fits && height <= limits.max_rows {
        return Ok(vec![Band { row0: 0, row_end: height, first: 0, end: pixels }]);
    }
    let halo = match reach.rows() {
        Some(n) => n as u64,
        None => {
            return Err(format!(
                "its buffers need {} bytes per binding, over this device's limit of {} bytes, and the kernel reads anywhere \
                 in the image (Reach::Image), so it cannot be split into bands of rows; render smaller (--width/--height) or \
                 use --backend cpu (a kernel that reads only nearby rows can say so with WgslSource::with_reach)",
                pixels * bytes_per_pixel,
                limits.max_binding
            ))
        }
    };
    // Every format is a whole number of 4-byte words per pixel, so a first pixel that is a multiple
    // of alignment/4 gives an aligned byte offset in every binding.
    let granule = (limits.offset_alignment / 4).max(1);
    let w = width as u64;
    let h = height as u64;
    let max_pixels = limits.max_binding / bytes_per_pixel.max(1);
    // Greedy from the top: each band takes as many rows as its window (own rows + halo, clipped to
    // the image, first pixel aligned down) can hold.
    let mut bands = Vec::new();
    let mut row0 = 0u64;
    while row0 < h {
        let first = row0.saturating_sub(halo) * w / granule * granule;
        // The window may reach up to (not including) row `reach_end`.
        let reach_end = (first + max_pixels) / w;
        let row_end = if reach_end >= h { h } else { reach_end.saturating_sub(halo) };
        let row_end = row_end.min(row0 + limits.max_rows as u64);
        if row_end <= row0 {
            return Err(format!(
                "one band of rows is too large for this device: the kernel reads {halo} rows above and below each pixel, so \
                 even one row of {width} pixels needs {} bytes per binding, over the limit of {} bytes; render narrower \
                 (--width), lower the node's radius, or use --backend cpu",
                (2 * halo + 1) * w * bytes_per_pixel,
                limits.max_binding
            ));
        }
        bands.push(Band { row0: row0 as u32, row_end: row_end as u32, first, end: (row_end + halo).min(h) * w });
        row0 = row_end;
    }
    Ok(bands)
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: BindLimits = BindLimits { max_binding: 128 << 20, offset_alignment: 256, max_rows: 65535 * 8 };

    #[test]
    fn one_band_when_everything_fits() {
        let b = plan(1920, 1080, 16, Reach::Image, &LIMITS).unwrap();
        assert_eq!(b, vec![Band { row0: 0, row_end: 1080, first: 0, end: 1920 * 1080 }]);
    }

    #[test]
    fn bands_cover_every_row_once_and_respect_the_limits() {
        for (w, h, bpp, reach) in [
            (4096u32, 2160u32, 16u64, Reach::Pixel),
            (4096, 2160, 16, Reach::Rows(64)),
            (7680, 4320, 12, Reach::Rows(5)),
            (1001, 70000, 16, Reach::Rows(3)),
        ] {
            let bands = plan(w, h, bpp, reach, &LIMITS).unwrap();
            assert!(bands.len() > 1, "{w}x{h} should be split");
            let halo = match reach {
                Reach::Rows(n) => n,
                _ => 0,
            };
            let mut next = 0;
            for b in &bands {
                assert_eq!(b.row0, next, "bands are contiguous");
                assert!(b.row_end > b.row0);
                next = b.row_end;
                // Holds its rows and `halo` rows around them (clipped to the image).
                assert!(b.first <= b.row0.saturating_sub(halo) as u64 * w as u64);
                assert!(b.end >= (b.row_end + halo).min(h) as u64 * w as u64);
                assert!(b.end <= w as u64 * h as u64);
                // Offset aligned in every format (4, 8, 12, 16 bytes per pixel), size under the limit.
                for bytes in [4u64, 8, 12, 16] {
                    assert_eq!(b.first * bytes % LIMITS.offset_alignment, 0);
                }
                assert!((b.end - b.first) * bpp <= LIMITS.max_binding);
            }
            assert_eq!(next, h, "the last band ends at the last row");
        }
    }

    #[test]
    fn tall_images_are_split_by_the_workgroup_limit_too() {
        let limits = BindLimits { max_rows: 64, ..LIMITS };
        let bands = plan(16, 1000, 4, Reach::Pixel, &limits).unwrap();
        assert_eq!(bands.len(), 16);
        assert!(bands.iter().all(|b| b.row_end - b.row0 <= 64));
    }

    #[test]
    fn kernels_that_read_anywhere_or_too_far_are_errors() {
        let e = plan(4096, 2160, 16, Reach::Image, &LIMITS).unwrap_err();
        assert!(e.contains("Reach::Image") && e.contains("--backend cpu"), "{e}");
        let e = plan(1 << 20, 100, 16, Reach::Rows(8), &LIMITS).unwrap_err();
        assert!(e.contains("8 rows above and below"), "{e}");
    }
}
