//! `wedge farm slurm P.ron --tiles N`: run a render as a Slurm job array, one task per tile
//! (`render --tile $SLURM_ARRAY_TASK_ID/N`), and a merge job that starts only when every task
//! succeeded (`--dependency=afterok:<array job>`). wedge writes the two sbatch scripts and submits
//! them with `sbatch`; it does not schedule anything itself. `--dry-run` prints them instead.
//!
//! Layout under OUT: `slurm/tiles.sbatch`, `slurm/merge.sbatch`, `slurm/logs/` (one log per task),
//! `tiles/` (the tile files) and the merged outputs in OUT itself. With `--frames A..B` there is one
//! task per tile × frame (task T: frame A + T / N, tile T % N, as `render --frames A..B --shard
//! T/N/M --tile T%N/N` with M the frame count), the tiles of frame F in `tiles/frame_FFFF/`, and the
//! merge job merges each frame into `OUT/frame_FFFF/`. A failed task leaves its tile
//! missing, so the merge job never runs (afterok) and `wedge merge OUT/tiles --out OUT` names it;
//! resubmitting that array index (`sbatch --array=I OUT/slurm/tiles.sbatch`) completes the set.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::session::WedgeError;

/// What one Slurm submission runs.
#[derive(Clone, Debug)]
pub struct SlurmPlan {
    /// The wedge executable the tasks run (this one, by absolute path).
    pub wedge: PathBuf,
    pub pipeline: PathBuf,
    pub tiles: u32,
    /// Frames A..B of a sequence: one task per tile × frame.
    pub frames: Option<(u32, u32)>,
    pub out: PathBuf,
    /// `render` flags every task passes on (size, seed, scene, `--set`, backend …).
    pub render_args: Vec<String>,
    pub partition: Option<String>,
    pub time: Option<String>,
}

/// The shell line of array task `$index` (a shell variable holding the task's number, from 0):
/// `WEDGE render PIPELINE ARGS` for its tile (and frame) into `tiles_dir`. Task T renders tile
/// T % tiles of frame A + T / tiles, as the stride shard T / tiles of the M frames, so each frame
/// is set up from A as an unsharded `--frames A..B` sets it up. Shared by Slurm and Kubernetes.
pub fn task_line(
    wedge: &str,
    pipeline: &str,
    render_args: &[String],
    (tiles, frames): (u32, Option<(u32, u32)>),
    index: &str,
    tiles_dir: &str,
) -> String {
    let args: Vec<String> = render_args.iter().map(|a| quote(a)).collect();
    let which = match frames {
        None => format!("--tile \"${{{index}}}/{tiles}\""),
        Some((a, b)) => format!(
            "--frames {a}..{b} --shard \"$(({index} / {tiles}))/{m}\" --tile \"$(({index} % {tiles}))/{tiles}\"",
            m = b - a + 1
        ),
    };
    format!("exec {} render {} {} {which} --out {}\n", quote(wedge), quote(pipeline), args.join(" "), quote(tiles_dir))
}

/// The shell lines that merge `tiles_dir` into `out_dir`: one merge, or with frames one per frame
/// (`frame_FFFF/` in both), each its own all-or-nothing set; the first that fails stops (set -e).
pub fn merge_lines(wedge: &str, frames: Option<(u32, u32)>, tiles_dir: &str, out_dir: &str) -> String {
    let (wedge, tiles, out) = (quote(wedge), quote(tiles_dir), quote(out_dir));
    match frames {
        None => format!("exec {wedge} merge {tiles} --out {out}\n"),
        Some((a, b)) => format!(
            "for f in $(seq {a} {b}); do\n  d=$(printf 'frame_%04d' \"$f\")\n  {wedge} merge {tiles}/\"$d\" --out {out}/\"$d\"\ndone\n"
        ),
    }
}

/// Array tasks of `tiles` tiles (of each of `frames`).
pub fn task_count(tiles: u32, frames: Option<(u32, u32)>) -> u64 {
    u64::from(tiles) * frames.map_or(1, |(a, b)| u64::from(b - a) + 1)
}

/// `s` quoted for a POSIX shell.
pub fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

fn quote_path(p: &Path) -> String {
    quote(&p.to_string_lossy())
}

/// A value for an `#SBATCH` line: letters, digits and `_-:.,+` only (no spaces or newlines that
/// could end the directive or start another).
pub fn check_sbatch_value(flag: &str, v: &str) -> Result<(), WedgeError> {
    if v.is_empty() || !v.chars().all(|c| c.is_ascii_alphanumeric() || "_-:.,+".contains(c)) {
        return Err(WedgeError::Usage(format!(
            "{flag} `{v}`: use letters, digits and _-:.,+ only (e.g. --time 01:00:00)"
        )));
    }
    Ok(())
}

impl SlurmPlan {
    /// `slurm/` under OUT, where the scripts and logs go.
    pub fn dir(&self) -> PathBuf {
        self.out.join("slurm")
    }

    fn directives(&self, name: &str) -> String {
        let mut s = format!("#!/bin/bash\n#SBATCH --job-name=wedge-{name}\n");
        if let Some(p) = &self.partition {
            s.push_str(&format!("#SBATCH --partition={p}\n"));
        }
        if let Some(t) = &self.time {
            s.push_str(&format!("#SBATCH --time={t}\n"));
        }
        s
    }

    /// Array tasks: one per tile, or per tile × frame.
    pub fn tasks(&self) -> u64 {
        task_count(self.tiles, self.frames)
    }

    /// The array script: task `$SLURM_ARRAY_TASK_ID` renders its tile (of its frame) into OUT/tiles.
    pub fn tiles_script(&self) -> String {
        let mut s = self.directives("tiles");
        s.push_str(&format!("#SBATCH --array=0-{}\n", self.tasks() - 1));
        s.push_str(&format!("#SBATCH --output={}/logs/tile_%a.log\n", self.dir().display()));
        s.push_str("set -euo pipefail\n");
        let lossy = |p: &Path| p.to_string_lossy().into_owned();
        s.push_str(&task_line(
            &lossy(&self.wedge),
            &lossy(&self.pipeline),
            &self.render_args,
            (self.tiles, self.frames),
            "SLURM_ARRAY_TASK_ID",
            &lossy(&self.out.join("tiles")),
        ));
        s
    }

    /// The merge script, run after every task succeeded.
    pub fn merge_script(&self) -> String {
        let mut s = self.directives("merge");
        s.push_str(&format!("#SBATCH --output={}/logs/merge.log\n", self.dir().display()));
        s.push_str("set -euo pipefail\n");
        let lossy = |p: &Path| p.to_string_lossy().into_owned();
        s.push_str(&merge_lines(&lossy(&self.wedge), self.frames, &lossy(&self.out.join("tiles")), &lossy(&self.out)));
        s
    }

    /// Write both scripts (and the logs directory); their paths.
    pub fn write_scripts(&self) -> Result<(PathBuf, PathBuf), WedgeError> {
        let dir = self.dir();
        let io = |e: std::io::Error| WedgeError::Usage(format!("{}: {e}", dir.display()));
        std::fs::create_dir_all(dir.join("logs")).map_err(io)?;
        std::fs::create_dir_all(self.out.join("tiles")).map_err(io)?;
        let (tiles, merge) = (dir.join("tiles.sbatch"), dir.join("merge.sbatch"));
        std::fs::write(&tiles, self.tiles_script()).map_err(io)?;
        std::fs::write(&merge, self.merge_script()).map_err(io)?;
        Ok((tiles, merge))
    }

    /// What `--dry-run` prints: both scripts and the commands that would submit them.
    pub fn dry_run(&self) -> String {
        let dir = self.dir();
        format!(
            "# {tiles}\n{}\n# {merge}\n{}\n# submit:\njobid=$(sbatch --parsable {tiles})\nsbatch --parsable --dependency=afterok:${{jobid%%;*}} {merge}\n",
            self.tiles_script(),
            self.merge_script(),
            tiles = quote_path(&dir.join("tiles.sbatch")),
            merge = quote_path(&dir.join("merge.sbatch")),
        )
    }

    /// Write the scripts and submit them: the array, then the merge after it (afterok).
    pub fn submit(&self) -> Result<String, WedgeError> {
        let (tiles, merge) = self.write_scripts()?;
        let array = sbatch(&[tiles.as_os_str().to_string_lossy().as_ref()])?;
        let dependency = format!("--dependency=afterok:{array}");
        let merge_id = sbatch(&[&dependency, merge.as_os_str().to_string_lossy().as_ref()])?;
        Ok(format!(
            "submitted tile array job {array} ({} tasks) and merge job {merge_id} (after {array} succeeds)\nlogs: {}\noutputs: {}\n",
            self.tasks(),
            self.dir().join("logs").display(),
            self.out.display()
        ))
    }
}

/// Run `sbatch --parsable ARGS`; the job id it prints (`ID` or `ID;CLUSTER`).
fn sbatch(args: &[&str]) -> Result<String, WedgeError> {
    let out = Command::new("sbatch").arg("--parsable").args(args).output().map_err(|e| {
        WedgeError::Usage(format!(
            "cannot run sbatch ({e}); is Slurm installed here? --dry-run prints the scripts instead"
        ))
    })?;
    let text = String::from_utf8_lossy(&out.stdout);
    let id = text.trim().split(';').next().unwrap_or("").to_string();
    if !out.status.success() || id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        return Err(WedgeError::Usage(format!(
            "sbatch {} failed: {}{}",
            args.join(" "),
            text.trim(),
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    Ok(id)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quotes_for_the_shell() {
        assert_eq!(quote("a b"), "'a b'");
        assert_eq!(quote("it's"), r"'it'\''s'");
        assert!(check_sbatch_value("--time", "01:00:00").is_ok());
        assert!(check_sbatch_value("--partition", "a\n#SBATCH --x").is_err());
    }
}
