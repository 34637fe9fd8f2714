//! Regression tests of issue 10 for the command line: values blamed on their flag, `--threads` and
//! `--memory-limit` limits, stdout to a full device, outputs that are never corrupt or mixed (two
//! writers at once, symbolic links, SIGINT/SIGTERM while rendering or writing). Issue 33: outputs
//! never replace a device node, a FIFO, a directory or an input of the command; `--out` naming a
//! file or a device; a negative `--memory-limit`; `--set` naming a missing node or an integer out of
//! range; `--gpu-limits` with the CPU backend; `--threads` during a mixed-reality capture.
//!
//! Each test spawns the `wedge` binary and asserts the exit code and a fragment of the message.

use std::fs;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

fn wedge(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wedge")).args(args).current_dir(cwd).output().expect("wedge runs")
}

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Assert exit `code` and that stderr has every fragment of `needles`; returns stderr.
fn fails_with(o: &Output, code: i32, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(code), "exit code; stderr: {err}");
    assert!(!err.contains("panicked"), "must not panic: {err}");
    for n in needles {
        assert!(err.contains(n), "stderr should mention {n:?}: {err}");
    }
    err
}

/// Names in `dir` that start with a dot: temporary files or staging directories left behind.
fn hidden_entries(dir: &Path) -> Vec<String> {
    fs::read_dir(dir)
        .map(|rd| {
            rd.map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).filter(|n| n.starts_with('.')).collect()
        })
        .unwrap_or_default()
}

#[test]
fn size_and_parameter_flags_are_blamed_on_the_flag_with_the_range() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // clap's range checks: exit 2, the flag and the allowed range named.
    for (args, needles) in [
        (&["render", "--width", "0"][..], &["'--width <WIDTH>'", "1..=16384"][..]),
        (&["render", "--height", "0"], &["'--height <HEIGHT>'", "1..=16384"]),
        (&["render", "--width", "100000", "--height", "100000"], &["'--width <WIDTH>'", "1..=16384"]),
        (&["parity", "--width", "0"], &["'--width <WIDTH>'", "1..=16384"]),
        (&["bench", "pipelines/shadows.ron", "--height", "0"], &["'--height <HEIGHT>'", "1..=16384"]),
        (&["reference", "--spp", "0"], &["'--spp <SPP>'", "1..=1048576"]),
        (&["reference", "--sampling", "halton"], &["'--sampling <SAMPLING>'", "stratified", "independent"]),
        (&["render", "--mu", "0"], &["'--mu <MU>'", "finite number > 0"]),
        (&["render", "--mu", "NaN"], &["'--mu <MU>'", "finite number > 0"]),
        (&["render", "--mu", "inf"], &["'--mu <MU>'", "finite number > 0"]),
        (&["render", "--seed", "abc"], &["'--seed <SEED>'"]),
        (&["render", "--seed", "4294967296"], &["'--seed <SEED>'"]),
    ] {
        let err = fails_with(&wedge(args, d), 2, needles);
        assert!(!err.contains(".ron:"), "{args:?} must not blame a pipeline line: {err}");
    }
    // Both sides in range, too many pixels: checked where the pipeline's other side is known.
    let err = fails_with(
        &wedge(&["render", "--width", "16384", "--height", "16384"], d),
        1,
        &["--width 16384 × --height 16384", "67108864 (2^26)", "lower --width/--height"],
    );
    assert!(!err.contains("shadows.ron:"), "{err}");
    assert!(!d.join("out").exists(), "nothing written by refused runs");
}

/// `bench --suite` and `--scene` exclude each other, `--suite-scenes` needs `--suite` and names
/// built-ins only: usage errors before anything runs or is written.
#[test]
fn bench_suite_and_scene_flags_are_checked_before_running() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shadows = repo().join("pipelines/shadows.ron");
    let p = shadows.to_str().unwrap();
    let out = d.join("suite");
    let o = out.to_str().unwrap();
    fails_with(
        &wedge(&["bench", p, "--suite", "--scene", "builtin:grids", "--out", o], d),
        2,
        &["--scene", "--suite", "cannot be used"],
    );
    fails_with(&wedge(&["bench", p, "--suite-scenes", "grids", "--out", o], d), 2, &["--suite"]);
    fails_with(
        &wedge(&["bench", p, "--suite", "--suite-scenes", "grids,nope", "--out", o], d),
        1,
        &["`nope` is not a built-in scene", "suite_grate"],
    );
    fails_with(
        &wedge(&["bench", p, "--scene", "no_such_file.gltf", "--quick", "--out", o], d),
        1,
        &["no_such_file.gltf"],
    );
    assert!(!out.join("suite.md").exists(), "nothing written by refused runs");
}

/// An unknown `--aov` name is a usage error (exit 2) listing the valid ones, before anything renders.
#[test]
fn unknown_aov_names_list_the_valid_ones() {
    let dir = tempfile::tempdir().unwrap();
    let o = wedge(
        &["render", "--width", "8", "--height", "8", "--out", dir.path().to_str().unwrap(), "--aov", "position,depth"],
        repo(),
    );
    fails_with(&o, 2, &["invalid value 'depth' for '--aov <NAMES>'", "position, normal, albedo"]);
    assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0, "nothing written");
}

#[test]
fn threads_are_capped_at_four_times_the_cores() {
    let dir = tempfile::tempdir().unwrap();
    let cores = std::thread::available_parallelism().unwrap().get();
    let cap = format!("1..={}", 4 * cores);
    let too_many = (4 * cores + 1).to_string();
    for n in ["0", too_many.as_str(), "100000"] {
        fails_with(&wedge(&["render", "--threads", n], dir.path()), 2, &["'--threads <THREADS>'", &cap, "4 ×"]);
    }
    let out = dir.path().join("out");
    let o = wedge(
        &["render", "--threads", "1", "--width", "16", "--height", "12", "--out", out.to_str().unwrap()],
        dir.path(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn memory_limit_refuses_before_allocating_and_graph_prints_the_estimate() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let err = fails_with(
        &wedge(&["render", "--memory-limit", "1M", "--width", "32", "--height", "24", "--out", "o"], d),
        1,
        &["more than the memory limit of 1.0 MiB (--memory-limit)", "estimated", "--memory-limit SIZE"],
    );
    assert!(err.contains("buffers +"), "{err}");
    assert!(!d.join("o").exists(), "a refused run writes nothing");
    fails_with(&wedge(&["render", "--memory-limit", "8X"], d), 2, &["'--memory-limit <SIZE>'", "unknown unit"]);
    fails_with(&wedge(&["render", "--memory-limit", "0"], d), 2, &["'--memory-limit <SIZE>'"]);
    fails_with(
        &wedge(
            &[
                "bench",
                repo().join("pipelines/shadows.ron").to_str().unwrap(),
                "--quick",
                "--memory-limit",
                "1M",
                "--out",
                "b",
            ],
            d,
        ),
        1,
        &["more than the memory limit of 1.0 MiB (--memory-limit)"],
    );
    assert!(!d.join("b").exists(), "a refused bench writes nothing");
    // Parity at the largest allowed size (2^26 pixels) is refused at once, before the GPU is even
    // opened (this machine may have none: the message must be the memory one).
    let t = Instant::now();
    let err = fails_with(
        &wedge(&["parity", "--width", "16384", "--height", "4096", "--memory-limit", "8G"], d),
        1,
        &["more than the memory limit of 8.0 GiB (--memory-limit)"],
    );
    assert!(err.contains("GiB buffers"), "{err}");
    assert!(t.elapsed() < Duration::from_secs(20), "refused before allocating: took {:?}", t.elapsed());
    // `wedge graph` prints the buffer estimate at the pipeline's size (640x480: 1492 B/px, two of
    // them the shared sampler's PathRecords of 109 words).
    let o = wedge(&["graph", "pipelines/shadows.ron"], repo());
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success());
    assert!(out.contains("memory at 640x480: estimated peak 437.1 MiB of buffers"), "{out}");
}

#[test]
fn stdout_to_a_full_device_fails_but_a_closed_pipe_does_not() {
    if let Ok(full) = fs::OpenOptions::new().write(true).open("/dev/full") {
        let o = Command::new(env!("CARGO_BIN_EXE_wedge"))
            .args(["graph", "pipelines/shadows.ron"])
            .current_dir(repo())
            .stdout(full)
            .output()
            .unwrap();
        fails_with(&o, 1, &["cannot write to standard output", "No space left on device"]);
    }
    let mut child = Command::new(env!("CARGO_BIN_EXE_wedge"))
        .args(["graph", "pipelines/shadows.ron"])
        .current_dir(repo())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader goes away before reading anything
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Decode every image in `dir` in full: a file interleaved from two writers fails here.
fn decode_all(dir: &Path) -> usize {
    let mut n = 0;
    for e in fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        match p.extension().and_then(|x| x.to_str()) {
            Some("exr") => {
                let img = wedge::image::read_exr(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
                assert_eq!((img.width, img.height), (32, 24), "{}", p.display());
            }
            Some("png") => {
                image::open(&p).unwrap_or_else(|e| panic!("{} is corrupt: {e}", p.display()));
            }
            _ => continue,
        }
        n += 1;
    }
    n
}

#[test]
fn two_concurrent_writers_never_produce_a_corrupt_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out_s = out.to_str().unwrap();
    for round in 0..3 {
        let spawn = |seed: &str| {
            Command::new(env!("CARGO_BIN_EXE_wedge"))
                .args(["render", "--width", "32", "--height", "24", "--seed", seed, "--out", out_s])
                .current_dir(dir.path())
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        };
        let (a, b) = (spawn("1"), spawn("2"));
        for child in [a, b] {
            let o = child.wait_with_output().unwrap();
            assert!(o.status.success(), "round {round}: {}", String::from_utf8_lossy(&o.stderr));
        }
        assert_eq!(decode_all(&out), 6, "render, unfiltered (exr+png), two heatmaps");
        assert_eq!(hidden_entries(&out), Vec::<String>::new(), "no temporaries left");
    }
}

#[cfg(unix)]
#[test]
fn symlinked_outputs_are_refused_and_their_targets_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let precious = d.join("precious.png");
    fs::write(&precious, "keep me").unwrap();
    // compare --heatmap onto a link.
    let out = d.join("out");
    let o = wedge(&["render", "--width", "16", "--height", "12", "--out", "out"], d);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let exr = out.join("render.exr");
    let before_exr = fs::read(&exr).unwrap();
    std::os::unix::fs::symlink(&precious, d.join("link.png")).unwrap();
    let e = exr.to_str().unwrap();
    fails_with(
        &wedge(&["compare", e, e, "--heatmap", "link.png"], d),
        1,
        &["refusing to write link.png", "symbolic link"],
    );
    assert!(fs::symlink_metadata(d.join("link.png")).unwrap().file_type().is_symlink());
    // A render whose set contains a link: refused as a whole, the rest of the old set stays.
    fs::remove_file(out.join("render.png")).unwrap();
    std::os::unix::fs::symlink(&precious, out.join("render.png")).unwrap();
    fails_with(
        &wedge(&["render", "--width", "16", "--height", "12", "--seed", "9", "--out", "out"], d),
        1,
        &["render.png", "symbolic link"],
    );
    assert_eq!(fs::read(&exr).unwrap(), before_exr, "render.exr not replaced: the set is all-or-nothing");
    assert_eq!(fs::read_to_string(&precious).unwrap(), "keep me");
    assert_eq!(hidden_entries(&out), Vec::<String>::new());
}

/// Spawn `wedge`, wait until `ready` says so (polled every millisecond), send `signal`, and return
/// the output; panics if the run ends before it is ready.
#[cfg(unix)]
fn interrupt_when(args: &[&str], cwd: &Path, signal: i32, mut ready: impl FnMut(&mut Child) -> bool) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_wedge"))
        .args(args)
        .current_dir(cwd)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t = Instant::now();
    while !ready(&mut child) {
        assert!(child.try_wait().unwrap().is_none(), "the run ended before it could be interrupted");
        assert!(t.elapsed() < Duration::from_secs(300), "never became ready");
        std::thread::sleep(Duration::from_millis(1));
    }
    // SAFETY: kill(2) on the pid of a child we spawned and have not reaped.
    assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, signal) }, 0);
    child.wait_with_output().unwrap()
}

#[cfg(unix)]
#[test]
fn sigint_while_rendering_exits_130_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    // Ready once the render has printed its first line (the scene is loaded, passes are running).
    let mut stderr_lines: Option<std::io::Lines<BufReader<std::process::ChildStderr>>> = None;
    let started = std::cell::Cell::new(false);
    let o = interrupt_when(
        &["render", "--width", "512", "--height", "384", "--out", out.to_str().unwrap()],
        dir.path(),
        libc::SIGINT,
        |child| {
            let lines = stderr_lines.get_or_insert_with(|| BufReader::new(child.stderr.take().unwrap()).lines());
            if !started.get() {
                started.set(lines.next().is_some_and(|l| l.unwrap().contains("on scene")));
            }
            started.get()
        },
    );
    assert_eq!(o.status.code(), Some(130));
    let rest: String = stderr_lines.unwrap().map(|l| l.unwrap() + "\n").collect();
    assert!(rest.contains("wedge: stopped by SIGINT"), "{rest}");
    assert_eq!(rest.lines().filter(|l| l.contains("stopped by")).count(), 1, "one line: {rest}");
    let left: Vec<PathBuf> = fs::read_dir(&out).map(|rd| rd.map(|e| e.unwrap().path()).collect()).unwrap_or_default();
    assert!(left.is_empty(), "nothing written: {left:?}");
}

#[cfg(unix)]
#[test]
fn sigterm_while_writing_exits_143_and_removes_the_staging_directory() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    fs::create_dir(&out).unwrap();
    fs::write(out.join("reference.png"), "old").unwrap();
    // A cheap render with large images: ready when the staging directory appears (files are
    // being written).
    let o = interrupt_when(
        &["reference", "--spp", "1", "--width", "2048", "--height", "1536", "--out", out.to_str().unwrap()],
        dir.path(),
        libc::SIGTERM,
        |_| !hidden_entries(&out).is_empty(),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(143), "{err}");
    assert!(err.contains("wedge: stopped by SIGTERM; removed") && err.contains("temporary"), "{err}");
    assert_eq!(hidden_entries(&out), Vec::<String>::new(), "staging directory removed");
    // All or nothing: the signal came while files were written (the usual case: the old file
    // stays and no new one appears) or during the commit, which then finished first.
    if out.join("reference.exr").exists() {
        image::open(out.join("reference.png")).expect("a committed set is complete");
    } else {
        assert_eq!(fs::read_to_string(out.join("reference.png")).unwrap(), "old", "old output untouched");
    }
}

// ---------------------------------------------------------------------------------------------
// Issue 33: destinations that are not regular files, inputs as outputs, misleading messages.
// ---------------------------------------------------------------------------------------------

#[cfg(unix)]
fn c_path(path: &Path) -> std::ffi::CString {
    std::ffi::CString::new(std::os::unix::ffi::OsStrExt::as_bytes(path.as_os_str())).unwrap()
}

/// A character device like /dev/full (1, 7) at `path`, made by `mknod` in the test's own directory;
/// false (with a line saying the case is skipped) where mknod is not permitted (no CAP_MKNOD).
#[cfg(unix)]
fn char_device(path: &Path) -> bool {
    let mode = libc::S_IFCHR | 0o666;
    if unsafe { libc::mknod(c_path(path).as_ptr(), mode, libc::makedev(1, 7)) } == 0 {
        return true;
    }
    eprintln!("skipped: mknod {} is not permitted here ({})", path.display(), std::io::Error::last_os_error());
    false
}

#[cfg(unix)]
fn fifo(path: &Path) {
    assert_eq!(
        unsafe { libc::mkfifo(c_path(path).as_ptr(), 0o644) },
        0,
        "mkfifo {}: {}",
        path.display(),
        std::io::Error::last_os_error()
    );
}

#[cfg(unix)]
fn is_char_device(path: &Path) -> bool {
    fs::symlink_metadata(path).is_ok_and(|m| std::os::unix::fs::FileTypeExt::is_char_device(&m.file_type()))
}

#[cfg(unix)]
fn is_fifo(path: &Path) -> bool {
    fs::symlink_metadata(path).is_ok_and(|m| std::os::unix::fs::FileTypeExt::is_fifo(&m.file_type()))
}

/// Names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

/// Two small EXRs `a.exr`, `b.exr` in `d` (no render needed).
fn two_exrs(d: &Path) -> (PathBuf, PathBuf) {
    let (a, b) = (d.join("a.exr"), d.join("b.exr"));
    let mut img = wedge::image::Image::new(4, 3);
    img.pixels.iter_mut().enumerate().for_each(|(i, p)| *p = [i as f32 * 0.1, 0.5, 1.0]);
    wedge::image::write_exr(&a, &img).unwrap();
    img.pixels[5] = [2.0, 0.0, 0.0];
    wedge::image::write_exr(&b, &img).unwrap();
    (a, b)
}

#[cfg(unix)]
#[test]
fn compare_refuses_a_heatmap_over_a_device_a_fifo_a_directory_or_an_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (a, b) = two_exrs(d);
    let before = (fs::read(&a).unwrap(), fs::read(&b).unwrap());
    let compare = |heatmap: &str| wedge(&["compare", "a.exr", "b.exr", "--heatmap", heatmap], d);
    if char_device(&d.join("full")) {
        let err =
            fails_with(&compare("full"), 1, &["refusing to write full: it is a character device, not a regular file"]);
        assert!(!err.contains("wrote"), "{err}");
        assert!(is_char_device(&d.join("full")), "still a device");
    }
    fifo(&d.join("pipe.png"));
    fails_with(&compare("pipe.png"), 1, &["refusing to write pipe.png: it is a FIFO (named pipe), not a regular file"]);
    assert!(is_fifo(&d.join("pipe.png")));
    fs::create_dir(d.join("dir.png")).unwrap();
    fails_with(&compare("dir.png"), 1, &["refusing to write dir.png: it is a directory"]);
    // An input under its own name, another spelling of it, and a hard link to it.
    fs::hard_link(&b, d.join("same_as_b.png")).unwrap();
    for (heatmap, input) in
        [("a.exr", "a.exr"), ("./a.exr", "a.exr"), (a.to_str().unwrap(), "a.exr"), ("same_as_b.png", "b.exr")]
    {
        let o = compare(heatmap);
        fails_with(&o, 1, &[&format!("refusing to write {heatmap}: it is the input {input} (the same file)")]);
        assert!(o.stdout.is_empty(), "nothing printed: the metrics are not even computed");
    }
    assert_eq!((fs::read(&a).unwrap(), fs::read(&b).unwrap()), before, "inputs unchanged");
    let mut expected = vec!["a.exr", "b.exr", "dir.png", "pipe.png", "same_as_b.png"];
    if d.join("full").exists() {
        expected.insert(3, "full");
    }
    assert_eq!(names(d), expected, "no temporaries, no new file");
    // The control: a regular file is replaced.
    assert!(compare("heat.png").status.success());
}

/// A render's set of six files whose 5th (filter_width.png) is a FIFO or whose 2nd
/// (render.png) is a device: refused with the kind named, and none of the set is written.
#[cfg(unix)]
#[test]
fn a_render_whose_set_meets_a_fifo_or_a_device_writes_none_of_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    fs::create_dir(&out).unwrap();
    let o = out.to_str().unwrap();
    fs::write(out.join("render.exr"), "old render").unwrap();
    fifo(&out.join("filter_width.png"));
    let render = || wedge(&["render", "--width", "16", "--height", "12", "--out", o], dir.path());
    let err = fails_with(&render(), 1, &["filter_width.png: it is a FIFO (named pipe), not a regular file"]);
    assert!(!err.contains("wrote"), "{err}");
    assert!(is_fifo(&out.join("filter_width.png")));
    assert_eq!(fs::read_to_string(out.join("render.exr")).unwrap(), "old render", "the set's 1st file is not replaced");
    assert_eq!(names(&out), ["filter_width.png", "render.exr"], "nothing new, no temporaries");
    fs::remove_file(out.join("filter_width.png")).unwrap();
    if char_device(&out.join("render.png")) {
        fails_with(&render(), 1, &["render.png: it is a character device, not a regular file"]);
        assert!(is_char_device(&out.join("render.png")));
        assert_eq!(fs::read_to_string(out.join("render.exr")).unwrap(), "old render");
        assert_eq!(names(&out), ["render.exr", "render.png"]);
    }
}

#[cfg(unix)]
#[test]
fn export_scene_refuses_a_device_node_in_its_set() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("scene");
    fs::create_dir(&out).unwrap();
    let node = out.join("scene.json");
    let kind = if char_device(&node) {
        "character device"
    } else {
        fifo(&node);
        "FIFO (named pipe)"
    };
    fails_with(
        &wedge(&["export-scene", "--out", out.to_str().unwrap()], repo()),
        1,
        &[&format!("scene.json: it is a {kind}, not a regular file")],
    );
    assert!(is_char_device(&node) || is_fifo(&node), "still a {kind}");
    assert_eq!(names(&out), ["scene.json"], "scene.obj, scene.mtl not written either");
}

/// `--out` names a directory: a regular file, a device, or a path under a file is refused at once
/// (before rendering), naming the path and what it is, for every command that takes `--out`.
#[test]
fn out_naming_a_file_or_a_device_says_it_is_not_a_directory() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fs::write(d.join("taken.png"), "keep").unwrap();
    let shadows = repo().join("pipelines/shadows.ron");
    let p = shadows.to_str().unwrap();
    let file = "cannot write into taken.png: it is a regular file, not a directory; outputs go into a directory (`--out` names one)";
    for out in ["taken.png", "taken.png/sub"] {
        for args in [
            &["render", "--width", "16", "--height", "12", "--out", out][..],
            &["reference", "--spp", "4", "--width", "16", "--height", "12", "--out", out],
            &["bench", p, "--quick", "--out", out],
            &["export-scene", p, "--out", out],
        ] {
            let t = Instant::now();
            let err = fails_with(&wedge(args, d), 1, &[file]);
            assert!(!err.contains("File exists") && !err.contains("os error"), "{args:?}: {err}");
            assert!(t.elapsed() < Duration::from_secs(20), "{args:?}: refused before running, took {:?}", t.elapsed());
        }
    }
    assert_eq!(fs::read_to_string(d.join("taken.png")).unwrap(), "keep");
    assert_eq!(names(d), ["taken.png"]);
    #[cfg(unix)]
    if char_device(&d.join("full")) {
        fails_with(
            &wedge(&["render", "--out", "full"], d),
            1,
            &["cannot write into full: it is a character device, not a directory"],
        );
        assert!(is_char_device(&d.join("full")));
    }
}

#[test]
fn negative_sizes_and_bad_set_targets_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fails_with(&wedge(&["render", "--memory-limit=-5M"], d), 2, &["'--memory-limit <SIZE>'", "`-5M` is negative"]);
    // A node that does not exist: the closest name and the pipeline's nodes.
    let err = fails_with(
        &wedge(&["render", "--set", "shadowz.mu=2"], d),
        1,
        &[
            "--set shadowz.mu: node `shadowz` does not exist in",
            "did you mean `shadows`?",
            "its nodes are: primary, shadows, out",
        ],
    );
    assert!(!err.contains("declares parameter"), "{err}");
    fails_with(
        &wedge(&["parity", "--set", "shadows.muu=2"], d),
        1,
        &[
            "--set shadows.muu: node `shadows` (kind SoftShadows) has no parameter `muu`; did you mean `mu`?",
            "max_rays",
        ],
    );
    // An integer beyond i64 is out of the parameter's range, not of the wrong type.
    let err = fails_with(
        &wedge(&["render", "--set", "shadows.max_rays=99999999999999999999999"], d),
        1,
        &["--set shadows.max_rays: max_rays = 1e23 is out of range; it must satisfy 1 <= max_rays <= 1048576"],
    );
    assert!(!err.contains("wrong type"), "{err}");
    fails_with(
        &wedge(&["render", "--set", "shadows.max_rays=-99999999999999999999999"], d),
        1,
        &["max_rays = -1e23 is out of range"],
    );
    fails_with(
        &wedge(&["render", "--set", "shadows.max_rays=2000000"], d),
        1,
        &["max_rays = 2000000 is out of range; it must satisfy 1 <= max_rays <= 1048576"],
    );
    // The same integer written in a pipeline file (RON reads it as a float too).
    let text = fs::read_to_string(repo().join("pipelines/shadows.ron"))
        .unwrap()
        .replace(r#""max_rays": 16"#, r#""max_rays": 99999999999999999999999"#);
    let big = d.join("big.ron");
    fs::write(&big, text).unwrap();
    let err = fails_with(
        &wedge(&["graph", "big.ron"], d),
        1,
        &["big.ron:14:", "max_rays = 1e23 is out of range; it must satisfy 1 <= max_rays <= 1048576"],
    );
    assert!(!err.contains("wrong type"), "{err}");
    fs::remove_file(big).unwrap();
    assert_eq!(names(d), Vec::<String>::new(), "nothing written");
}

#[test]
fn gpu_limits_with_the_cpu_backend_is_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let o = wedge(&["render", "--gpu-limits", "webgpu", "--width", "16", "--height", "12", "--out", "o"], dir.path());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("warning: --gpu-limits webgpu has no effect with --backend cpu"), "{err}");
}

/// `--threads 1` holds in every phase, the mixed-reality capture (run while the session opens)
/// and the EXR compression included: sampled every millisecond, the process never has more than
/// two threads besides its main thread and the signal thread `wedge-signals` (the one rayon worker
/// and a short-lived one the sampling sees now and then), and never an EXR compressor: EXRs are
/// compressed on the calling thread under `--threads 1` (`image::write_exr`; a pool per file let
/// two compressors overlap while one was still exiting, seen in CI under load). Before, the capture and the passes ran in rayon's global pool, one
/// thread per core, beside the `--threads` pool. On one core the two cannot be told apart.
#[cfg(target_os = "linux")]
#[test]
fn threads_one_holds_while_the_mixed_reality_capture_runs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("mr");
    let pipeline = repo().join("pipelines/mixed_reality.ron");
    let mut child = Command::new(env!("CARGO_BIN_EXE_wedge"))
        .args([
            "render",
            pipeline.to_str().unwrap(),
            "--threads",
            "1",
            "--width",
            "64",
            "--height",
            "48",
            "--out",
            out.to_str().unwrap(),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let tasks = PathBuf::from(format!("/proc/{}/task", child.id()));
    let mut most: Vec<String> = Vec::new();
    while child.try_wait().unwrap().is_none() {
        let others: Vec<String> = fs::read_dir(&tasks)
            .map(|rd| {
                rd.filter_map(|t| t.ok())
                    .filter(|t| t.file_name().to_string_lossy() != child.id().to_string())
                    .filter_map(|t| fs::read_to_string(t.path().join("comm")).ok())
                    .map(|c| c.trim().to_string())
                    .filter(|c| c != "wedge-signals")
                    .collect()
            })
            .unwrap_or_default();
        if others.len() > most.len() {
            most = others;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("capturing the real layer"));
    // With one thread the EXRs are compressed on the calling thread: no compressor pool at all (a
    // pool per file once let two compressors overlap while one was still exiting).
    assert!(most.iter().all(|t| !t.starts_with("OpenEXR")), "an EXR compressor thread ran under --threads 1: {most:?}");
    assert!(most.len() <= 2, "at most two threads expected besides the main thread, saw {most:?}");
}
