//! `wedge farm k8s`: its manifests parse as YAML and pass the batch/v1 Job (and v1 ConfigMap,
//! PersistentVolumeClaim) schemas in schemas/; the Indexed Job's pods map
//! `JOB_COMPLETION_INDEX` to the tile and frame a Slurm array task gets (run through `/bin/sh` with
//! `--wedge echo`); bad flags are refused by name with nothing written. No cluster is needed.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde::Deserialize;
use serde_json::Value;

/// This crate's directory (its schemas) and wedge's repository two levels up.
fn here() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The `wedge` binary the workspace built: `WEDGE_BIN`, else `target/release/wedge` of the repository.
fn wedge_bin() -> PathBuf {
    std::env::var_os("WEDGE_BIN").map(PathBuf::from).unwrap_or_else(|| here().join("../../target/release/wedge"))
}

/// A fresh, empty directory under the system's temporary directory.
fn temp_dir(suite: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("wedge-{suite}-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

/// Run `wedge ARGS` in `cwd`.
fn wedge(args: &[&str], cwd: &Path) -> Output {
    let bin = wedge_bin();
    Command::new(&bin).args(args).current_dir(cwd).output().unwrap_or_else(|e| {
        panic!("{}: {e} (build wedge first: cargo build --release; or set WEDGE_BIN)", bin.display())
    })
}

/// Assert a refusal (a non-zero exit, no panic) whose stderr holds every fragment; returns stderr.
fn refused(o: &Output, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_ne!(o.status.code(), Some(0), "must be refused; stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "stderr should mention {n:?}: {err}");
    }
    err
}

/// The path of shipped pipeline `name`.
fn pipeline(name: &str) -> String {
    here().join("../../pipelines").join(name).to_string_lossy().into_owned()
}

/// Every document of a YAML file, as JSON values.
fn documents(path: &Path) -> Vec<Value> {
    let text = fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_yaml_ng::Deserializer::from_str(&text)
        .map(|d| Value::deserialize(d).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
        .collect()
}

fn validator(file: &str) -> jsonschema::Validator {
    let path = here().join("schemas").join(file);
    let schema: Value = serde_json::from_str(&fs::read_to_string(&path).unwrap()).unwrap();
    jsonschema::validator_for(&schema).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Check `doc` against the schema of its kind; the errors, if any.
fn schema_errors(doc: &Value) -> Vec<String> {
    let v = match doc["kind"].as_str() {
        Some("Job") => validator("job-batch-v1.schema.json"),
        _ => validator("core-v1.schema.json"),
    };
    v.iter_errors(doc).map(|e| format!("{} at {}", e, e.instance_path())).collect()
}

fn ok(o: &std::process::Output) -> String {
    let (out, err) = (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned());
    assert!(o.status.success(), "failed: {out}{err}");
    out
}

/// Run pod `index`'s container command of `job` locally (its `/bin/sh -c` script) with
/// `JOB_COMPLETION_INDEX` set, as the Job controller sets it; its stdout.
fn run_pod(job: &Value, index: u64) -> String {
    let command: Vec<String> = job["spec"]["template"]["spec"]["containers"][0]["command"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect();
    assert_eq!(command[..2], ["/bin/sh", "-c"]);
    let o =
        Command::new(&command[0]).args(&command[1..]).env("JOB_COMPLETION_INDEX", index.to_string()).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn manifests_pass_the_schema_and_index_the_tasks() {
    let d = temp_dir("farm_k8s", "frames");
    let shadows = pipeline("shadows.ron");
    let args = [
        "farm",
        "k8s",
        &shadows,
        "--tiles",
        "4",
        "--frames",
        "5..7",
        "--image",
        "registry.example.com/wedge:0.1",
        "--wedge",
        "echo",
    ];
    let out = ok(&wedge(
        &[&args[..], &["--width", "160", "--height", "120", "--seed", "3", "--parallelism", "5", "--out", "o"]]
            .concat(),
        &d,
    ));
    assert!(out.contains("12 task(s) (4 tile(s) × frames 5..7)"), "{out}");
    let tiles = documents(&d.join("o/k8s/tiles.yaml"));
    let merge = documents(&d.join("o/k8s/merge.yaml"));
    let kinds: Vec<&str> = tiles.iter().chain(&merge).map(|v| v["kind"].as_str().unwrap()).collect();
    assert_eq!(kinds, ["ConfigMap", "PersistentVolumeClaim", "Job", "Job"]);
    for doc in tiles.iter().chain(&merge) {
        let errors = schema_errors(doc);
        assert!(errors.is_empty(), "{}: {errors:?}", doc["metadata"]["name"]);
    }
    let (config, claim, job) = (&tiles[0], &tiles[1], &tiles[2]);
    // The pipeline travels in the ConfigMap, byte for byte.
    assert_eq!(config["data"]["shadows.ron"].as_str().unwrap(), fs::read_to_string(&shadows).unwrap());
    let spec = &job["spec"];
    assert_eq!(
        (spec["completionMode"].as_str(), spec["completions"].as_u64(), spec["parallelism"].as_u64()),
        (Some("Indexed"), Some(12), Some(5))
    );
    let pod = &spec["template"]["spec"];
    assert_eq!(pod["volumes"][0]["configMap"]["name"], config["metadata"]["name"]);
    assert_eq!(pod["volumes"][1]["persistentVolumeClaim"]["claimName"], claim["metadata"]["name"]);
    assert_eq!(claim["spec"]["accessModes"][0], "ReadWriteMany");
    // Task T: tile T % 4 of frame 5 + T / 4, with the render flags.
    for (index, shard, tile) in [(0, "0/3", "0/4"), (6, "1/3", "2/4"), (11, "2/3", "3/4")] {
        let line = run_pod(job, index);
        for want in [
            "render /etc/wedge/pipeline/shadows.ron",
            "--width 160",
            "--seed 3",
            "--frames 5..7",
            &format!("--shard {shard}"),
            &format!("--tile {tile}"),
            "--out /data/tiles",
        ] {
            assert!(line.contains(want), "pod {index}: `{want}` not in {line}");
        }
    }
    // The merge Job merges every frame, after the tiles (submit.sh waits for the tiles Job first).
    let merged = run_pod(&merge[0], 0);
    assert_eq!(
        merged.lines().collect::<Vec<_>>(),
        (5..=7).map(|f| format!("merge /data/tiles/frame_{f:04} --out /data/out/frame_{f:04}")).collect::<Vec<_>>()
    );
    let submit = fs::read_to_string(d.join("o/k8s/submit.sh")).unwrap();
    let (wait, apply_merge) = (
        submit.find("wait --for=condition=complete --timeout=24h job/wedge-shadows-tiles").unwrap(),
        submit.find("apply -f merge.yaml").unwrap(),
    );
    assert!(wait < apply_merge, "{submit}");
    // Without frames: one completion per tile, `--tile $JOB_COMPLETION_INDEX/N`.
    let out = ok(&wedge(
        &[
            "farm",
            "k8s",
            &shadows,
            "--tiles",
            "3",
            "--image",
            "wedge:1",
            "--wedge",
            "echo",
            "--name",
            "film",
            "--namespace",
            "render",
            "--out",
            "p",
        ],
        &d,
    ));
    assert!(out.contains("3 task(s) (3 tile(s)) of"), "{out}");
    let tiles = documents(&d.join("p/k8s/tiles.yaml"));
    for doc in &tiles {
        assert!(schema_errors(doc).is_empty(), "{:?}", schema_errors(doc));
        assert_eq!(doc["metadata"]["namespace"], "render");
    }
    assert_eq!(tiles[2]["metadata"]["name"], "film-tiles");
    assert!(run_pod(&tiles[2], 2).contains("--tile 2/3 --out /data/tiles"));
}

/// The schema is not a rubber stamp: the mistakes it exists for fail it.
#[test]
fn the_schema_catches_broken_jobs() {
    let d = temp_dir("farm_k8s", "broken");
    ok(&wedge(&["farm", "k8s", &pipeline("shadows.ron"), "--tiles", "2", "--image", "wedge:1", "--out", "o"], &d));
    let job = documents(&d.join("o/k8s/tiles.yaml")).remove(2);
    assert!(schema_errors(&job).is_empty());
    let broken = |f: &dyn Fn(&mut Value)| {
        let mut j = job.clone();
        f(&mut j);
        schema_errors(&j)
    };
    assert!(!broken(&|j| j["spec"]["completionMode"] = "Indexd".into()).is_empty());
    assert!(!broken(&|j| j["spec"].as_object_mut().unwrap().remove("completions").map_or((), |_| ())).is_empty());
    assert!(!broken(&|j| j["spec"]["template"]["spec"]["restartPolicy"] = "Always".into()).is_empty());
    assert!(!broken(&|j| j["spec"]["paralelism"] = 2.into()).is_empty());
    assert!(!broken(&|j| j["apiVersion"] = "batch/v2".into()).is_empty());
}

#[test]
fn bad_k8s_flags_are_refused_by_name_and_nothing_is_written() {
    let d = temp_dir("farm_k8s", "bad");
    let shadows = pipeline("shadows.ron");
    let base = ["farm", "k8s", &shadows, "--tiles", "4"];
    refused(&wedge(&[&base[..], &["--out", "o"]].concat(), &d), &["--image"]);
    refused(&wedge(&[&base[..], &["--image", "a b", "--out", "o"]].concat(), &d), &["--image `a b`"]);
    refused(
        &wedge(&[&base[..], &["--image", "w", "--name", "Film_1", "--out", "o"]].concat(), &d),
        &["--name `Film_1`", "DNS-1123"],
    );
    refused(
        &wedge(&[&base[..], &["--image", "w", "--parallelism", "5", "--out", "o"]].concat(), &d),
        &["--parallelism 5", "4 task(s)"],
    );
    refused(
        &wedge(&[&base[..], &["--image", "w", "--storage", "ten", "--out", "o"]].concat(), &d),
        &["--storage `ten`"],
    );
    refused(
        &wedge(&[&base[..], &["--image", "w", "--frames", "3..1", "--out", "o"]].concat(), &d),
        &["--frames", "ends before it starts"],
    );
    refused(
        &wedge(
            &[
                "farm", "k8s", &shadows, "--tiles", "65536", "--frames", "0..1", "--width", "1024", "--height", "1024",
                "--image", "w", "--out", "o",
            ],
            &d,
        ),
        &["131072 tasks", "100000"],
    );
    refused(
        &wedge(&["farm", "k8s", &pipeline("lightfield_ao.ron"), "--tiles", "4", "--image", "w", "--out", "o"], &d),
        &["cannot be tiled"],
    );
    refused(
        &wedge(
            &[
                "farm",
                "k8s",
                &pipeline("environment_temporal.ron"),
                "--tiles",
                "2",
                "--frames",
                "0..3",
                "--image",
                "w",
                "--out",
                "o",
            ],
            &d,
        ),
        &["keeps frame history"],
    );
    assert!(!d.join("o").exists(), "nothing written");
}
