//! A "real" world rendered by wedge itself, for mixed reality (issue 15): the `MixedReality` node's
//! `capture` parameter names a scene, and this renders, from the pipeline's camera and under its
//! environment map, what a capture of that scene would give — the camera image `L_cam` (plain Monte
//! Carlo of the `Environment` node's light, direct and one-bounce indirect, at `spp` samples per
//! pixel: `wedge reference` of an Environment pipeline) and the position, normal and albedo maps
//! (`crate::aov`, the same maps `wedge render --aov` writes). So a shipped example needs no files, and
//! a round-trip test can compare the composite with a full render of real + virtual scenes.
//!
//! Captures are kept for the life of the process, keyed by everything that makes them (scene, camera,
//! map, size, samples, seed): a bench or a test suite that opens the same pipeline many times renders
//! its real layer once.

use std::collections::HashMap;
use std::path::Path;
use std::sync::{Mutex, OnceLock};

use wedge_backends::cpu::CpuBackend;
use wedge_backends::{BufferData, Silent};
use wedge_scene::{Camera, EnvironmentMap, RealLayer};

use crate::aov::Aovs;
use crate::session::{Session, WedgeError};

/// What to capture and how.
pub struct Capture<'a> {
    /// `builtin:NAME` or a scene file (relative to `base_dir`), already checked against the
    /// pipeline's directory (`crate::session::pipeline_file`).
    pub spec: &'a str,
    pub base_dir: &'a Path,
    /// Let the captured scene file read files outside its directory (`--allow-outside-dir`).
    pub allow_outside_dir: bool,
    pub camera: Camera,
    /// The environment that lights it (the pipeline's); `None`: the captured scene's own.
    pub environment: Option<EnvironmentMap>,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u32,
}

/// The key of a capture in the process-wide cache: every input, printed.
fn key(c: &Capture<'_>) -> String {
    let env =
        c.environment.as_ref().map(|e| format!("{}|{}|{}", e.name(), e.scale().to_bits(), e.rotation_deg().to_bits()));
    format!(
        "{}|{}|{}|{:?}|{env:?}|{}x{}|{}|{}",
        c.spec,
        c.base_dir.display(),
        c.allow_outside_dir,
        c.camera,
        c.width,
        c.height,
        c.spp,
        c.seed
    )
}

/// Render the real layer of [`Capture`] (module doc), or return the process's earlier render of it.
pub fn capture_real_layer(c: &Capture<'_>) -> Result<RealLayer, WedgeError> {
    static CACHE: OnceLock<Mutex<HashMap<String, RealLayer>>> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    let k = key(c);
    if let Some(layer) = cache.lock().unwrap_or_else(|p| p.into_inner()).get(&k) {
        return Ok(layer.clone());
    }
    let layer = render(c)?;
    cache.lock().unwrap_or_else(|p| p.into_inner()).insert(k, layer.clone());
    Ok(layer)
}

fn render(c: &Capture<'_>) -> Result<RealLayer, WedgeError> {
    eprintln!("capturing the real layer from `{}` at {} samples per pixel ({}x{})", c.spec, c.spp, c.width, c.height);
    let scene =
        if c.spec.starts_with("builtin:") { c.spec.to_string() } else { c.base_dir.join(c.spec).display().to_string() };
    // The captured scene is lit by the pipeline's map, set on its scene below, not by a map of its own
    // (which it may not have, e.g. `builtin:cornell`): its Environment node names a built-in map only
    // so that building the session does not ask the captured scene for one; it is replaced before
    // anything runs. Without a pipeline map the captured scene's own lights it.
    let map = if c.environment.is_some() { r#""map": "builtin:sky", "# } else { "" };
    // `{:?}` quotes and escapes the string as RON reads it.
    let text = format!(
        r#"Pipeline(scene: {scene:?}, width: {}, height: {}, seed: {}, nodes: [
            (name: "env", kind: "Environment", params: {{{map}"indirect": true}}),
            (name: "out", kind: "Output", inputs: {{"color": "env.radiance"}}),
        ])"#,
        c.width, c.height, c.seed
    );
    let loaded = wedge_graph::parse_pipeline(Path::new("<capture>"), &text)?;
    let (nodes, kernels) = wedge_effects::builtin();
    // The scene goes in as an override: as this generated pipeline's `scene:` it would be confined
    // to the directory of `<capture>` (the working directory), while the user's pipeline named it.
    let ov = crate::session::Overrides {
        scene: Some(scene.clone()),
        allow_outside_dir: c.allow_outside_dir,
        ..Default::default()
    };
    let mut session = Session::build_reference(loaded, &ov, nodes, kernels, c.spp, "stratified")
        .map_err(|e| WedgeError::Usage(format!("capture of `{}`: {e}", c.spec)))?;
    session.scene.camera = c.camera;
    if let Some(env) = &c.environment {
        session.scene.set_environment(Some(env.clone()));
    }
    let run = session.run(&mut CpuBackend::new(), &Silent)?;
    let Some(BufferData::Vec3(l_cam)) = run.output("color") else {
        return Err(WedgeError::Usage(format!("capture of `{}`: the render gave no colour image (a bug)", c.spec)));
    };
    let aovs = Aovs::render(&session.scene, c.width, c.height)?;
    Ok(RealLayer::from_maps(c.width, c.height, l_cam.clone(), aovs.position, aovs.normal, aovs.albedo)?)
}
