//! Frame shards (`render --frames A..B --shard I/N [--shard-mode stride|chunks]`): which frames of a
//! sequence one task renders, so that N tasks (on N machines, or a farm's array) render the whole
//! range between them, each frame byte-identical to the same frame of an unsharded `--frames A..B`.
//!
//! Every frame of a sequence is set up from the range's first frame A (its seed `seed + frame`, its
//! camera and the previous frame's camera, its index `frame − A`: `Session::run_frame`), so a
//! shard opens its session at A and runs its frames as `--frames A..B` runs them. What a frame
//! cannot get from A alone is the *history*: the buffers a temporal filter or a progressive
//! accumulation keeps from the frame before (`Schedule::history`). So:
//!
//! - `stride` (default): shard I renders frames A+I, A+I+N, A+2N+I, … — an even split of any
//!   sequence, for pipelines without history; a pipeline with history is refused (each frame would
//!   need every frame before it).
//! - `chunks`: shard I renders the I-th of N contiguous chunks. With history, the shard first
//!   *warms up*: it renders the frames from A to its chunk's start without writing them, so its
//!   first frame sees the same history as in the unsharded run. The history is a recurrence over every
//!   frame since A, so the warm-up is exact only from A: shard I renders all frames before its chunk
//!   again, the last shard as many frames as the whole sequence — chunks with history split the
//!   writing and the memory of a long sequence, not its time to the last frame.

use crate::session::WedgeError;

/// How `--shard` splits the frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShardMode {
    /// Every N-th frame starting at A+I.
    Stride,
    /// The I-th of N contiguous chunks.
    Chunks,
}

impl ShardMode {
    /// The flag's value (`stride`, `chunks`; clap has checked it).
    pub fn parse(s: &str) -> ShardMode {
        if s == "chunks" {
            ShardMode::Chunks
        } else {
            ShardMode::Stride
        }
    }
}

/// `--shard I/N`: shard I (from 0) of N.
pub fn parse_shard(s: &str) -> Result<(u32, u32), String> {
    let usage = || format!("`{s}`: expected I/N, shard I (0..N-1) of N, e.g. 0/2");
    let (i, n) = s.split_once('/').ok_or_else(usage)?;
    let (i, n) = (i.trim().parse::<u32>().map_err(|_| usage())?, n.trim().parse::<u32>().map_err(|_| usage())?);
    if n == 0 {
        return Err(format!("`{s}`: the number of shards must be at least 1"));
    }
    if i >= n {
        return Err(format!("`{s}`: shards are numbered from 0, so shard {i} of {n} does not exist; use 0..{}", n - 1));
    }
    Ok((i, n))
}

/// The frames one task runs, in order: `warm_up` (rendered for their history, not written), then
/// `frames` (rendered and written). Every frame is set up from the range's first frame `first`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FramePlan {
    pub first: u32,
    pub warm_up: Vec<u32>,
    pub frames: Vec<u32>,
    /// Whether each frame's history comes from the frame before (the pipeline keeps some).
    pub history: bool,
}

impl FramePlan {
    /// Every frame the task runs, warm-up first.
    pub fn runs(&self) -> impl Iterator<Item = u32> + '_ {
        self.warm_up.iter().chain(&self.frames).copied()
    }
}

/// Plan frames `first..=last` for shard `shard` (none: all of them). `history`: the pipeline keeps
/// frame history (`pipeline` names it in a refusal).
pub fn plan(
    (first, last): (u32, u32),
    shard: Option<((u32, u32), ShardMode)>,
    history: bool,
    pipeline: &str,
) -> Result<FramePlan, WedgeError> {
    let all: Vec<u32> = (first..=last).collect();
    let Some(((index, count), mode)) = shard else {
        return Ok(FramePlan { first, warm_up: Vec::new(), frames: all, history });
    };
    let n = all.len() as u64;
    if u64::from(count) > n {
        return Err(WedgeError::Usage(format!(
            "--shard {index}/{count}: frames {first}..{last} are {n} frame(s), fewer than {count} shards, so some shards \
             would render nothing; use at most {n} shards"
        )));
    }
    match mode {
        ShardMode::Stride if history => Err(WedgeError::Usage(format!(
            "--shard {index}/{count}: {pipeline} keeps frame history (a temporal filter or progressive accumulation reads \
             the frame before), so every N-th frame would need all the frames before it; use --shard-mode chunks \
             (each shard renders the frames before its chunk again to warm up the history)"
        ))),
        ShardMode::Stride => Ok(FramePlan { first, warm_up: Vec::new(), frames: all.into_iter().skip(index as usize).step_by(count as usize).collect(), history }),
        ShardMode::Chunks => {
            // Chunk i is [i·n/N, (i+1)·n/N): sizes differ by at most one frame.
            let bound = |i: u32| (u64::from(i) * n / u64::from(count)) as usize;
            let (start, end) = (bound(index), bound(index + 1));
            let warm_up = if history { all[..start].to_vec() } else { Vec::new() };
            Ok(FramePlan { first, warm_up, frames: all[start..end].to_vec(), history })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_cover_the_range_once() {
        for mode in [ShardMode::Stride, ShardMode::Chunks] {
            let mut seen: Vec<u32> =
                (0..3).flat_map(|i| plan((5, 14), Some(((i, 3), mode)), false, "p").unwrap().frames).collect();
            seen.sort_unstable();
            assert_eq!(seen, (5..=14).collect::<Vec<_>>());
        }
        assert_eq!(plan((5, 14), Some(((1, 3), ShardMode::Stride)), false, "p").unwrap().frames, vec![6, 9, 12]);
        let chunk = plan((5, 14), Some(((1, 3), ShardMode::Chunks)), true, "p").unwrap();
        assert_eq!((chunk.warm_up, chunk.frames), (vec![5, 6, 7], vec![8, 9, 10]));
        assert!(plan((5, 14), Some(((1, 3), ShardMode::Stride)), true, "p").is_err());
        assert!(plan((0, 1), Some(((0, 3), ShardMode::Chunks)), false, "p").is_err());
        assert!(parse_shard("2/2").is_err() && parse_shard("0/0").is_err() && parse_shard("x").is_err());
    }
}
