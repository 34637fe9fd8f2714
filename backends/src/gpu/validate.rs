//! WGSL checked without a device: every pass's shader, composed exactly as the wgpu backend composes
//! it ([`super::shaders::kernel_wgsl`]), parsed and validated by naga (the compiler wgpu itself runs
//! first), with each error mapped back through the composition's line map to the file and line the
//! user wrote (`fog.wgsl`'s line, not line 275 of the concatenated shader). Sessions run it when
//! they are built, so a WGSL typo in a user's kernel fails `wedge render --backend cpu` and a
//! CPU-only CI too, not only a machine with a GPU.
//!
//! Validation is cached per composed text for the process: the many sessions of a bench or a test
//! binary pay for each distinct shader once.

use std::collections::HashSet;
use std::hash::{Hash, Hasher};
use std::sync::Mutex;

use super::shaders::{kernel_wgsl, BindingPlan, Composed};
use super::GpuBackend;
use crate::{BackendError, Job};

/// Composed texts that validated (by hash).
static VALID: Mutex<Option<HashSet<u64>>> = Mutex::new(None);

/// Parse and validate the WGSL of every pass of `job` that has a WGSL implementation; every failing
/// kernel is reported at once, each error at its source file and line. A kernel without WGSL is
/// left to the wgpu backend, which refuses it when it would run; so is a pass whose uniforms this
/// job cannot evaluate (its `Params` block comes from the scene, e.g. a mixed-reality pass in a
/// session opened without its real layer for `export-scene`): running it reports why, and its
/// shader is checked in any session that can run it.
pub fn check_job(job: &Job<'_>) -> Result<(), BackendError> {
    let mut problems = Vec::new();
    let mut checked = HashSet::new();
    for pass in &job.schedule.passes {
        let Some(kernel) = job.kernels.get(&pass.kernel) else { continue };
        let Some(src) = kernel.wgsl() else { continue };
        let Ok((uniforms, _)) = GpuBackend::uniforms(job, pass, &src) else { continue };
        // The binding plan only changes the generated accessors; the traversal stack size only an
        // array length: the direct plan and the default stack check the user's code.
        let stack = wedge_scene::bvh::STACK_SIZE as u32;
        let composed = kernel_wgsl(kernel.name(), &src, &kernel.bindings(), &uniforms, BindingPlan::Direct, stack)?;
        if !checked.insert(composed.text.clone()) {
            continue;
        }
        if let Err(e) = validate_cached(&composed) {
            problems.push(format!("kernel `{}` (pass `{}`): {e}", kernel.name(), pass.name));
        }
    }
    match problems.len() {
        0 => Ok(()),
        n => Err(BackendError::Wgsl(format!(
            "{n} kernel(s) have WGSL that does not compile (checked with naga, no device needed):\n  - {}",
            problems.join("\n  - ")
        ))),
    }
}

fn validate_cached(composed: &Composed) -> Result<(), String> {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    composed.text.hash(&mut h);
    let key = h.finish();
    if VALID.lock().unwrap_or_else(|p| p.into_inner()).get_or_insert_with(HashSet::new).contains(&key) {
        return Ok(());
    }
    validate(composed)?;
    VALID.lock().unwrap_or_else(|p| p.into_inner()).get_or_insert_with(HashSet::new).insert(key);
    Ok(())
}

/// naga's parse and validation of one composed shader; the first error, at its origin.
pub fn validate(composed: &Composed) -> Result<(), String> {
    let text = &composed.text;
    let module = naga::front::wgsl::parse_str(text).map_err(|e| at(composed, e.location(text), e.message()))?;
    let mut validator =
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default());
    validator.validate(&module).map_err(|e| {
        let mut message = e.as_inner().to_string();
        let mut source = std::error::Error::source(e.as_inner());
        while let Some(s) = source {
            message.push_str(&format!(": {s}"));
            source = s.source();
        }
        at(composed, e.location(text), &message)
    })?;
    Ok(())
}

/// `file:line:column: message` and the offending line, from a location in the composed text.
fn at(composed: &Composed, location: Option<naga::SourceLocation>, message: &str) -> String {
    let Some(loc) = location else { return message.to_string() };
    let line_text = composed.text.lines().nth(loc.line_number.saturating_sub(1) as usize).unwrap_or("").trim();
    match composed.origin_of(loc.line_number as usize) {
        Some((file, line)) => format!("{file}:{line}:{}: {message}\n      | {line_text}", loc.line_position),
        None => format!("line {}: {message}", loc.line_number),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{Uniforms, WgslSource};
    use crate::Binding;
    use wedge_graph::Format;

    fn composed(source: &'static str) -> Composed {
        let src = WgslSource::new(source, |_| Ok(Uniforms::new().f32("scale", 1.0)));
        let bindings = [Binding::read("value", Format::Vec3), Binding::write("out", Format::Vec3)];
        kernel_wgsl("test.scale", &src, &bindings, &Uniforms::new().f32("scale", 1.0), BindingPlan::Direct, 32).unwrap()
    }

    const GOOD: &str = "#include \"common.wgsl\"\n\n@compute @workgroup_size(8, 8)\nfn main(@builtin(global_invocation_id) gid: vec3<u32>) {\n    if (!pixel_of(gid)) {\n        return;\n    }\n    let i = pixel_index(gid);\n    out_put(i, value_at(i) * params.scale);\n}\n";

    #[test]
    fn a_correct_kernel_validates() {
        validate(&composed(GOOD)).unwrap();
    }

    /// A typo in the kernel's own line 9 is reported at line 9 of the kernel, not of the composed
    /// shader (which starts with a few hundred lines of common.wgsl and the generated header).
    #[test]
    fn an_error_points_at_the_kernels_own_line() {
        let typo: &'static str = Box::leak(GOOD.replace("params.scale", "params.scael").into_boxed_str());
        let e = validate(&composed(typo)).unwrap_err();
        assert!(e.starts_with("test.scale:9:"), "{e}");
        assert!(e.contains("scael") && e.contains("out_put(i, value_at(i) * params.scael)"), "{e}");
        let undefined: &'static str = Box::leak(GOOD.replace("value_at(i)", "valeu_at(i)").into_boxed_str());
        let e = validate(&composed(undefined)).unwrap_err();
        assert!(e.starts_with("test.scale:9:") && e.contains("valeu_at"), "{e}");
    }

    /// A type error found only by validation (not by the parser) is mapped too.
    #[test]
    fn a_validation_error_is_mapped() {
        let wrong: &'static str =
            Box::leak(GOOD.replace("value_at(i) * params.scale", "params.scale").into_boxed_str());
        let e = validate(&composed(wrong)).unwrap_err();
        assert!(e.starts_with("test.scale:9:"), "{e}");
    }
}
