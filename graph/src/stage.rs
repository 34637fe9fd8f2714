//! What a pass is, beyond its kernel and bindings: the stage of the frame it belongs to, whether it
//! draws random numbers, and its role in a reference render.
//!
//! - [`Stage`]: the fixed order of the sample-and-filter frame (thesis Ch. 5, Sec. 5.3–5.6): first
//!   paths → per-effect bandwidths and rates → combined counts → adaptive paths → factoring →
//!   irradiance filters → compose → image-space filters → output. The scheduler runs stages in this
//!   order and, inside a stage, topologically; a pass reading a buffer written by a later stage is a
//!   graph error (see [`crate::schedule()`]).
//! - Streams: a pass that draws random numbers (`PassBuilder::random`) gets its `stream`
//!   parameter from the graph, [`stream_id`] of its full name, so no effect file picks a number and
//!   two passes never share one by accident (collisions are an error). Kernels derive sub-streams
//!   (per light, per component) by hashing `(stream, index)`, never by packing integers.
//! - [`Reference`]: how [`crate::reference()`] treats the pass when it turns a pipeline's own
//!   expansion into its plain Monte Carlo reference.

use std::fmt;

/// The stage of the frame a pass runs in; the declaration order is the run order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Stage {
    /// First paths: G-buffer and first-pass samples (thesis Sec. 5.3's first pass).
    Sample,
    /// Per-effect statistics, bandwidths and sampling rates (eqs. 3.13/3.21, 4.15–4.21, 5.24–5.29).
    Bandwidth,
    /// Counts combined over effects (per-pixel max, 3×3 max; thesis Sec. 5.4).
    Counts,
    /// Adaptive second-pass paths at the combined counts.
    Adaptive,
    /// Factoring of texture and irradiance (thesis eqs. 5.9–5.14).
    Factor,
    /// Irradiance (world-space) filters (eqs. 3.12, 4.16, 5.31).
    Filter,
    /// Composition: textures multiplied back, components added (eq. 5.32).
    Compose,
    /// Image-space filters: defocus (eq. 5.33), motion, tone mapping.
    ImageFilter,
    /// Output conversions.
    Output,
}

impl Stage {
    pub const ALL: [Stage; 9] = [
        Stage::Sample,
        Stage::Bandwidth,
        Stage::Counts,
        Stage::Adaptive,
        Stage::Factor,
        Stage::Filter,
        Stage::Compose,
        Stage::ImageFilter,
        Stage::Output,
    ];
    pub fn name(self) -> &'static str {
        match self {
            Stage::Sample => "sample",
            Stage::Bandwidth => "bandwidth",
            Stage::Counts => "counts",
            Stage::Adaptive => "adaptive",
            Stage::Factor => "factor",
            Stage::Filter => "filter",
            Stage::Compose => "compose",
            Stage::ImageFilter => "image_filter",
            Stage::Output => "output",
        }
    }
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A pass's role in the plain Monte Carlo reference of its pipeline ([`crate::reference()`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reference {
    /// Runs unchanged (G-buffer, compose, sums, exposure). The default.
    Keep,
    /// A filter: in a reference every buffer it writes is replaced by the buffer it reads at binding
    /// `input` (same format), and the pass does no work.
    Bypass { input: &'static str },
    /// Writes per-pixel sample counts (`u32` buffers): replaced by the shared kernel `fill.constant`
    /// writing the reference count to each of them.
    Count,
    /// Writes per-pixel secondary samples per primary path (`u32` buffers, e.g. shadow rays per
    /// path): replaced by `fill.constant` writing 1, so each of a reference's N paths takes one
    /// secondary sample per estimator — N jointly stratified samples per pixel, not N × the
    /// pipeline's per-primary count.
    CountPerPrimary,
    /// Writes a per-pixel `u32` decision the reference must take one way (e.g. Ch. 5's factoring
    /// flags, eq. 5.30: a reference composes `L`, never the factored `k·E`): replaced by
    /// `fill.constant` writing this value.
    Fill(u32),
    /// Draws samples: in a reference its `count` parameter becomes the reference count and its
    /// `sampling` the reference's (`stratified` or `independent`). A pass with per-pixel counts reads
    /// them from a [`Reference::Count`] pass, which then writes the reference count.
    Sample,
    /// A first pass whose estimate a later [`Reference::Sample`] pass continues (reads as `previous`):
    /// in a reference it takes no samples (`count` 0), so the continuing pass draws all N samples as
    /// one set — N jointly stratified samples, not a first set plus a separately stratified rest.
    Continued,
}

/// The stream of a random pass: 32-bit FNV-1a of its full name `<node>.<pass>`. Stable across
/// versions, platforms and pipelines (renaming a node changes its noise, nothing else does).
pub fn stream_id(full_name: &str) -> u32 {
    let mut h: u32 = 0x811c_9dc5;
    for b in full_name.as_bytes() {
        h ^= u32::from(*b);
        h = h.wrapping_mul(0x0100_0193);
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_matches_the_published_vectors() {
        // FNV-1a 32 test vectors (Fowler/Noll/Vo reference suite).
        assert_eq!(stream_id(""), 0x811c_9dc5);
        assert_eq!(stream_id("a"), 0xe40c_292c);
        assert_eq!(stream_id("foobar"), 0xbf9c_f968);
    }

    #[test]
    fn stages_run_in_declaration_order() {
        let mut sorted = Stage::ALL;
        sorted.sort();
        assert_eq!(sorted, Stage::ALL);
        assert!(Stage::Filter < Stage::Compose && Stage::Compose < Stage::ImageFilter);
    }
}
