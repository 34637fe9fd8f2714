//! `wedge farm k8s P.ron --tiles N [--frames A..B] --image IMG`: the Kubernetes manifests of a render
//! as tiles (× frames) and a merge, written as YAML for `kubectl apply`; wedge talks to no cluster.
//!
//! - `OUT/k8s/tiles.yaml`: a ConfigMap holding the pipeline file (mounted read-only at
//!   [`PIPELINE_DIR`]), a PersistentVolumeClaim (`ReadWriteMany`: the tasks run on many nodes) for
//!   the tiles and the merged images (mounted at [`DATA_DIR`]), and an Indexed Job
//!   (`completionMode: Indexed`, `completions` = tiles × frames) whose pod `JOB_COMPLETION_INDEX`
//!   renders that task's tile (of its frame) exactly as a Slurm array task does
//!   ([`crate::farm::task_line`]).
//! - `OUT/k8s/merge.yaml`: the merge Job ([`crate::farm::merge_lines`]), writing to
//!   `DATA_DIR/out` (`frame_FFFF/` per frame). Kubernetes has no `afterok`: apply it after
//!   `kubectl wait --for=condition=complete job/NAME-tiles` (the commands are printed and written to
//!   `OUT/k8s/submit.sh`). Applied too early it fails, naming the missing tiles, and writes nothing.
//!
//! The manifests are built as JSON values and written with serde_yaml_ng; tests/farm_k8s.rs checks
//! them against the batch/v1 Job schema.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use crate::session::WedgeError;

/// Where the pipeline's ConfigMap is mounted in every pod.
pub const PIPELINE_DIR: &str = "/etc/wedge/pipeline";
/// Where the volume claim is mounted: `tiles/` and `out/` below it.
pub const DATA_DIR: &str = "/data";
/// Most completions of one Indexed Job (the API's limit on `parallelism` and what an indexed Job
/// tracks per index).
pub const MAX_COMPLETIONS: u64 = 100_000;

/// What `wedge farm k8s` writes.
#[derive(Clone, Debug)]
pub struct K8sPlan {
    /// Prefix of every object's name: a DNS-1123 label ([`check_name`]).
    pub name: String,
    pub image: String,
    /// The wedge executable inside the image.
    pub wedge: String,
    /// The pipeline file's name (the ConfigMap's key) and its text.
    pub pipeline_file: String,
    pub pipeline_text: String,
    pub tiles: u32,
    pub frames: Option<(u32, u32)>,
    /// `render` flags every task passes on.
    pub render_args: Vec<String>,
    /// Pods at once (default: every task).
    pub parallelism: Option<u32>,
    /// Size of the volume claim (a Kubernetes quantity, e.g. 10Gi).
    pub storage: String,
    pub storage_class: Option<String>,
    pub namespace: Option<String>,
}

/// A DNS-1123 label of at most `max` characters: lower-case letters, digits and `-`, starting and
/// ending with a letter or digit (what Kubernetes accepts as a Job's name and a pod's hostname).
pub fn check_name(flag: &str, v: &str, max: usize) -> Result<(), WedgeError> {
    let ok = !v.is_empty()
        && v.len() <= max
        && v.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')
        && !v.starts_with('-')
        && !v.ends_with('-');
    if ok {
        return Ok(());
    }
    Err(WedgeError::Usage(format!(
        "{flag} `{v}`: use lower-case letters, digits and '-' (not first or last), at most {max} characters (a \
         Kubernetes DNS-1123 label), e.g. wedge-shadows"
    )))
}

/// A container image reference: non-empty, no whitespace or control characters.
pub fn check_image(v: &str) -> Result<(), WedgeError> {
    if v.is_empty() || v.chars().any(|c| c.is_whitespace() || c.is_control()) {
        return Err(WedgeError::Usage(format!(
            "--image `{v}`: give the container image that holds wedge, e.g. registry.example.com/wedge:0.1 (no spaces)"
        )));
    }
    Ok(())
}

/// `s` with every character outside `[-._a-zA-Z0-9]` (a ConfigMap key's alphabet) replaced by `_`.
pub fn config_key(s: &str) -> String {
    let key: String = s.chars().map(|c| if c.is_ascii_alphanumeric() || "-._".contains(c) { c } else { '_' }).collect();
    if key.is_empty() || key == "." || key == ".." {
        "pipeline.ron".into()
    } else {
        key
    }
}

impl K8sPlan {
    /// Indexed Job completions: tiles × frames.
    pub fn tasks(&self) -> u64 {
        crate::farm::task_count(self.tiles, self.frames)
    }

    /// Refuse what Kubernetes would refuse, before anything is written.
    pub fn check(&self) -> Result<(), WedgeError> {
        // The longest suffix is `-pipeline`; a pod's hostname is `NAME-tiles-INDEX` (63 at most).
        check_name("--name", &self.name, 63 - "-tiles-".len() - MAX_COMPLETIONS.to_string().len())?;
        if let Some(ns) = &self.namespace {
            check_name("--namespace", ns, 63)?;
        }
        if let Some(class) = &self.storage_class {
            check_name("--storage-class", class, 253)?;
        }
        check_image(&self.image)?;
        if self.tasks() > MAX_COMPLETIONS {
            return Err(WedgeError::Usage(format!(
                "--tiles {} with {} frame(s) is {} tasks, more than the {MAX_COMPLETIONS} completions of one Indexed Job; \
                 split the frame range (--frames) over several submissions",
                self.tiles,
                self.tasks() / u64::from(self.tiles),
                self.tasks()
            )));
        }
        if let Some(p) = self.parallelism.filter(|p| u64::from(*p) > self.tasks()) {
            return Err(WedgeError::Usage(format!(
                "--parallelism {p} is more than the {} task(s); use at most {} (or leave it out: every task at once)",
                self.tasks(),
                self.tasks()
            )));
        }
        let quantity = self.storage.trim_end_matches(|c: char| c.is_ascii_alphabetic());
        if quantity.is_empty()
            || !quantity.chars().all(|c| c.is_ascii_digit())
            || !["", "Ki", "Mi", "Gi", "Ti", "k", "M", "G", "T"].contains(&&self.storage[quantity.len()..])
        {
            return Err(WedgeError::Usage(format!(
                "--storage `{}`: a whole number with Ki, Mi, Gi or Ti (e.g. 10Gi)",
                self.storage
            )));
        }
        Ok(())
    }

    fn metadata(&self, suffix: &str) -> Value {
        let mut m = json!({ "name": format!("{}-{suffix}", self.name), "labels": { "app.kubernetes.io/name": "wedge", "app.kubernetes.io/instance": self.name } });
        if let Some(ns) = &self.namespace {
            m["namespace"] = json!(ns);
        }
        m
    }

    /// The ConfigMap holding the pipeline file.
    pub fn config_map(&self) -> Value {
        json!({ "apiVersion": "v1", "kind": "ConfigMap", "metadata": self.metadata("pipeline"), "data": { self.pipeline_file.clone(): self.pipeline_text } })
    }

    /// The volume claim for the tiles and the merged images.
    pub fn claim(&self) -> Value {
        let mut spec =
            json!({ "accessModes": ["ReadWriteMany"], "resources": { "requests": { "storage": self.storage } } });
        if let Some(class) = &self.storage_class {
            spec["storageClassName"] = json!(class);
        }
        json!({ "apiVersion": "v1", "kind": "PersistentVolumeClaim", "metadata": self.metadata("data"), "spec": spec })
    }

    /// A Job running `script` (under `/bin/sh -c`) in one container with both volumes mounted.
    fn job(&self, suffix: &str, script: String, spec: Value) -> Value {
        let container = json!({
            "name": "wedge",
            "image": self.image,
            "command": ["/bin/sh", "-c", format!("set -eu\n{script}")],
            "volumeMounts": [
                { "name": "pipeline", "mountPath": PIPELINE_DIR, "readOnly": true },
                { "name": "data", "mountPath": DATA_DIR },
            ],
        });
        let mut job_spec = json!({
            "template": {
                "metadata": { "labels": { "app.kubernetes.io/name": "wedge", "app.kubernetes.io/instance": self.name } },
                "spec": {
                    // A failed pod is a new pod (Never), so its log stays; the Job counts the retries.
                    "restartPolicy": "Never",
                    "containers": [container],
                    "volumes": [
                        { "name": "pipeline", "configMap": { "name": format!("{}-pipeline", self.name) } },
                        { "name": "data", "persistentVolumeClaim": { "claimName": format!("{}-data", self.name) } },
                    ],
                },
            },
        });
        if let (Value::Object(target), Value::Object(extra)) = (&mut job_spec, spec) {
            target.extend(extra);
        }
        json!({ "apiVersion": "batch/v1", "kind": "Job", "metadata": self.metadata(suffix), "spec": job_spec })
    }

    /// The Indexed Job: pod `JOB_COMPLETION_INDEX` renders its tile (of its frame).
    pub fn tiles_job(&self) -> Value {
        let pipeline = format!("{PIPELINE_DIR}/{}", self.pipeline_file);
        let tiles_dir = format!("{DATA_DIR}/tiles");
        let line = crate::farm::task_line(
            &self.wedge,
            &pipeline,
            &self.render_args,
            (self.tiles, self.frames),
            "JOB_COMPLETION_INDEX",
            &tiles_dir,
        );
        let tasks = self.tasks();
        self.job(
            "tiles",
            line,
            json!({
                "completionMode": "Indexed",
                "completions": tasks,
                "parallelism": self.parallelism.map_or(tasks, u64::from),
                // Pod failures over all indices before the Job fails: two per task (a pod may be
                // evicted, not only fail), at most 2000.
                "backoffLimit": tasks.min(1000) * 2,
            }),
        )
    }

    /// The merge Job (one pod): every tile into `DATA_DIR/out`.
    pub fn merge_job(&self) -> Value {
        let line = crate::farm::merge_lines(
            &self.wedge,
            self.frames,
            &format!("{DATA_DIR}/tiles"),
            &format!("{DATA_DIR}/out"),
        );
        self.job("merge", line, json!({ "completions": 1, "parallelism": 1, "backoffLimit": 0 }))
    }

    /// `(file name, YAML)` of the two files: the tiles' objects and the merge Job.
    pub fn files(&self) -> Result<Vec<(&'static str, String)>, WedgeError> {
        let yaml = |docs: &[Value]| -> Result<String, WedgeError> {
            let parts: Result<Vec<String>, _> = docs.iter().map(serde_yaml_ng::to_string).collect();
            Ok(parts.map_err(|e| WedgeError::Usage(format!("writing YAML: {e}")))?.join("---\n"))
        };
        Ok(vec![
            ("tiles.yaml", yaml(&[self.config_map(), self.claim(), self.tiles_job()])?),
            ("merge.yaml", yaml(&[self.merge_job()])?),
            ("submit.sh", self.submit_script()),
        ])
    }

    /// The kubectl commands, in order: what Kubernetes cannot chain itself.
    pub fn submit_script(&self) -> String {
        let ns = self.namespace.as_ref().map_or(String::new(), |n| format!(" -n {n}"));
        let name = &self.name;
        format!(
            "#!/bin/sh\n# {tasks} task(s) of {name}-tiles, then the merge (Kubernetes has no afterok: wait, then apply).\nset -eu\n\
             cd \"$(dirname \"$0\")\"\nkubectl{ns} apply -f tiles.yaml\n\
             kubectl{ns} wait --for=condition=complete --timeout=24h job/{name}-tiles\nkubectl{ns} apply -f merge.yaml\n\
             kubectl{ns} wait --for=condition=complete --timeout=1h job/{name}-merge\n\
             echo \"merged images: {DATA_DIR}/out on the claim {name}-data\"\n",
            tasks = self.tasks()
        )
    }

    /// Write the files into `dir` as one staged set; their paths.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, WedgeError> {
        let files = self.files()?;
        let mut staging = crate::staging::Staging::new(dir)?;
        for (name, text) in &files {
            let path = staging.file(name)?;
            std::fs::write(&path, text).map_err(|e| WedgeError::Usage(format!("{}: {e}", path.display())))?;
        }
        Ok(staging.commit()?)
    }
}
