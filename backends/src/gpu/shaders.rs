//! WGSL composition: wedge's shared shader files and `#include` resolution.
//!
//! A kernel's WGSL names the shared code it needs with `#include "NAME.wgsl"` lines (a line holding
//! only the directive). [`compose`] replaces each with the file's text, recursively, each file at
//! most once — so `bvh.wgsl` and `sampling.wgsl` may both include `scene.wgsl` and the kernel still
//! gets one copy. `common.wgsl` (frame uniform, counters, NaN-safe math) is always placed first.
//! This is deliberately plain text concatenation: WGSL has no modules, and naga reports errors with
//! line numbers in the composed text, which [`compose`]'s output keeps readable (each file starts
//! with a `// ---- NAME ----` marker).
//!
//! The binding header is generated here too ([`binding_header`]): kernels never declare group(1);
//! they call `NAME_at(i)` / `NAME_put(i, v)` / `NAME_bound()` per binding of `Kernel::bindings()`,
//! so the WGSL cannot drift from the Rust declaration, and the backend may bind the buffers either
//! one per binding or packed into two buffers ([`BindingPlan`]) without the kernel noticing.

use std::collections::HashSet;

use wedge_graph::Format;

use crate::kernel::{Access, Binding, WgslSource};
use crate::BackendError;

/// wedge's shared WGSL, available to every kernel (built-in and user kernels alike).
pub const SHARED: &[(&str, &str)] = &[
    ("common.wgsl", include_str!("../../../shaders/common.wgsl")),
    ("rng.wgsl", include_str!("../../../shaders/rng.wgsl")),
    ("scene.wgsl", include_str!("../../../shaders/scene.wgsl")),
    ("bvh.wgsl", include_str!("../../../shaders/bvh.wgsl")),
    ("sampling.wgsl", include_str!("../../../shaders/sampling.wgsl")),
];

/// The full WGSL of a kernel: `common.wgsl`, the generated `header` (its bindings, see
/// [`binding_header`]), then its source with every include resolved.
pub fn compose(kernel: &str, src: &WgslSource, header: &str) -> Result<String, BackendError> {
    let mut out = String::new();
    let mut seen = HashSet::new();
    let lookup = |name: &str| -> Option<String> {
        src.includes
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, t)| t.to_string())
            .or_else(|| SHARED.iter().find(|(n, _)| *n == name).map(|(_, t)| t.to_string()))
    };
    expand(kernel, "common.wgsl", &lookup("common.wgsl").unwrap_or_default(), &lookup, &mut seen, &mut out, 0)?;
    out.push_str(header);
    expand(kernel, kernel, &src.source, &lookup, &mut seen, &mut out, 0)?;
    Ok(out)
}

fn expand(
    kernel: &str,
    name: &str,
    text: &str,
    lookup: &dyn Fn(&str) -> Option<String>,
    seen: &mut HashSet<String>,
    out: &mut String,
    depth: usize,
) -> Result<(), BackendError> {
    if depth > 16 {
        return Err(BackendError::Gpu(format!("kernel `{kernel}`: #include nesting deeper than 16 at `{name}`")));
    }
    if !seen.insert(name.to_string()) {
        return Ok(());
    }
    out.push_str(&format!("// ---- {name} ----\n"));
    for (line_no, line) in text.lines().enumerate() {
        let t = line.trim();
        if let Some(rest) = t.strip_prefix("#include") {
            let inc = rest.trim().trim_matches('"');
            let body = lookup(inc).ok_or_else(|| {
                let known: Vec<&str> = SHARED.iter().map(|(n, _)| *n).collect();
                BackendError::Gpu(format!(
                    "kernel `{kernel}`: {name}:{}: #include \"{inc}\" names no known file (shared: {}; or add it with WgslSource::with_include)",
                    line_no + 1,
                    known.join(", ")
                ))
            })?;
            expand(kernel, inc, &body, lookup, seen, out, depth + 1)?;
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    Ok(())
}

/// How a dispatch binds its per-pixel buffers in group(1) (chosen per dispatch by the backend from
/// the kernel's bindings and the device's `max_storage_buffers_per_shader_stage`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BindingPlan {
    /// One storage binding per declared binding, `@binding(k)` = k-th of `Kernel::bindings()`.
    Direct,
    /// Two storage bindings: every input in one read-only `array<u32>`, every output in one
    /// read-write `array<u32>`, each binding a region of `frame.packed_pixels` elements at a fixed
    /// component offset; the backend copies the band's pixels in and out around the dispatch.
    Packed,
}

/// WGSL type of one element of a per-pixel buffer of `format` (vec3 is handed out as `vec3<f32>`
/// even though it is stored as 3 packed floats).
fn element_type(format: Format) -> &'static str {
    match format {
        Format::F32 => "f32",
        Format::Vec2 => "vec2<f32>",
        Format::Vec3 => "vec3<f32>",
        Format::Vec4 => "vec4<f32>",
        Format::U32 => "u32",
    }
}

/// Storage bindings group(1) uses under `plan` (inputs, outputs): for the limit check.
pub fn storage_bindings(bindings: &[Binding], plan: BindingPlan) -> u32 {
    match plan {
        BindingPlan::Direct => bindings.len() as u32,
        BindingPlan::Packed => {
            bindings.iter().any(|b| b.access == Access::Read) as u32 + bindings.iter().any(|b| b.access == Access::Write) as u32
        }
    }
}

/// Offsets (in 4-byte components per pixel) of each binding within its packed buffer, and the
/// components per pixel of the packed input and output buffers.
pub fn packed_layout(bindings: &[Binding]) -> (Vec<u64>, u64, u64) {
    let (mut inputs, mut outputs) = (0u64, 0u64);
    let offsets = bindings
        .iter()
        .map(|b| {
            let total = if b.access == Access::Read { &mut inputs } else { &mut outputs };
            let at = *total;
            *total += b.format.components() as u64;
            at
        })
        .collect();
    (offsets, inputs, outputs)
}

/// The generated group(1) header of a kernel: declarations for `plan` and, per binding `NAME`,
/// `NAME_at(i) -> T` (inputs and outputs: a kernel that resumes reads its own outputs),
/// `NAME_put(i, v)` (outputs) and `NAME_bound() -> bool`. `i` is an element index
/// (`pixel_index(gid)` / `index_at(x, y)`). An unbound optional binding reads as zero and ignores
/// writes. Kernel code is the same under either plan.
pub fn binding_header(kernel: &str, bindings: &[Binding], plan: BindingPlan) -> Result<String, BackendError> {
    let mut out = String::from("// ---- generated bindings (backends/src/gpu/shaders.rs) ----\n");
    let (offsets, inputs, _) = packed_layout(bindings);
    let in_slot = 0u32;
    let out_slot = (inputs > 0) as u32;
    match plan {
        BindingPlan::Direct => {}
        BindingPlan::Packed => {
            if inputs > 0 {
                out.push_str(&format!("@group(1) @binding({in_slot}) var<storage, read> packed_inputs: array<u32>;\n"));
            }
            if bindings.iter().any(|b| b.access == Access::Write) {
                out.push_str(&format!("@group(1) @binding({out_slot}) var<storage, read_write> packed_outputs: array<u32>;\n"));
            }
        }
    }
    for (k, b) in bindings.iter().enumerate() {
        let name = b.name;
        let valid = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            && !name.contains("__");
        if !valid {
            return Err(BackendError::Gpu(format!(
                "kernel `{kernel}`: binding `{name}` is not a WGSL identifier (a letter, then letters, digits or single `_`); rename it in Kernel::bindings()"
            )));
        }
        let ty = element_type(b.format);
        let n = b.format.components();
        let write = b.access == Access::Write;
        let guard_at = if b.optional { format!("    if (!is_bound({k}u)) {{ return {ty}(); }}\n") } else { String::new() };
        let guard_put = if b.optional { format!("    if (!is_bound({k}u)) {{ return; }}\n") } else { String::new() };
        out.push_str(&format!("fn {name}_bound() -> bool {{ return is_bound({k}u); }}\n"));
        // Element load/store bodies, per plan.
        let (load, store) = match plan {
            BindingPlan::Direct => {
                let access = if write { "read_write" } else { "read" };
                let array = match b.format {
                    Format::Vec3 => "array<f32>".to_string(),
                    f => format!("array<{}>", element_type(f)),
                };
                out.push_str(&format!("@group(1) @binding({k}) var<storage, {access}> buf_{name}: {array};\n"));
                match b.format {
                    Format::Vec3 => (
                        format!("    let b = 3u * i;\n    return vec3<f32>(buf_{name}[b], buf_{name}[b + 1u], buf_{name}[b + 2u]);\n"),
                        format!("    let b = 3u * i;\n    buf_{name}[b] = v.x;\n    buf_{name}[b + 1u] = v.y;\n    buf_{name}[b + 2u] = v.z;\n"),
                    ),
                    _ => (format!("    return buf_{name}[i];\n"), format!("    buf_{name}[i] = v;\n")),
                }
            }
            BindingPlan::Packed => {
                let array = if write { "packed_outputs" } else { "packed_inputs" };
                let base = format!("    let b = {}u * frame.packed_pixels + {n}u * i;\n", offsets[k]);
                let load = match b.format {
                    Format::U32 => format!("{base}    return {array}[b];\n"),
                    Format::F32 => format!("{base}    return bitcast<f32>({array}[b]);\n"),
                    _ => {
                        let words: Vec<String> = (0..n).map(|c| format!("{array}[b + {c}u]")).collect();
                        format!("{base}    return bitcast<{ty}>(vec{n}<u32>({}));\n", words.join(", "))
                    }
                };
                let store = match b.format {
                    Format::U32 => format!("{base}    {array}[b] = v;\n"),
                    Format::F32 => format!("{base}    {array}[b] = bitcast<u32>(v);\n"),
                    _ => {
                        let mut s = format!("{base}    let w = bitcast<vec{n}<u32>>(v);\n");
                        for (c, comp) in ["x", "y", "z", "w"].iter().take(n).enumerate() {
                            s.push_str(&format!("    {array}[b + {c}u] = w.{comp};\n"));
                        }
                        s
                    }
                };
                (load, store)
            }
        };
        out.push_str(&format!("fn {name}_at(i: u32) -> {ty} {{\n{guard_at}{load}}}\n"));
        if write {
            out.push_str(&format!("fn {name}_put(i: u32, v: {ty}) {{\n{guard_put}{store}}}\n"));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn indirect_like() -> Vec<Binding> {
        let mut v: Vec<Binding> = ["position", "normal", "specular", "previous_diffuse", "previous_glossy"]
            .iter()
            .map(|n| Binding::read(n, Format::Vec4))
            .collect();
        v.push(Binding::read_opt("rays", Format::U32));
        v.push(Binding::read("albedo", Format::Vec3));
        v.push(Binding::write("diffuse", Format::Vec4));
        v.push(Binding::write_opt("depth", Format::F32));
        v
    }

    #[test]
    fn packed_plan_uses_two_storage_bindings_and_fixed_offsets() {
        let b = indirect_like();
        assert_eq!(storage_bindings(&b, BindingPlan::Direct), 9);
        assert_eq!(storage_bindings(&b, BindingPlan::Packed), 2);
        let (offsets, inputs, outputs) = packed_layout(&b);
        assert_eq!(offsets, vec![0, 4, 8, 12, 16, 20, 21, 0, 4]);
        assert_eq!((inputs, outputs), (24, 5));
        let h = binding_header("k", &b, BindingPlan::Packed).unwrap();
        assert!(h.contains("@group(1) @binding(0) var<storage, read> packed_inputs: array<u32>;"), "{h}");
        assert!(h.contains("@group(1) @binding(1) var<storage, read_write> packed_outputs: array<u32>;"), "{h}");
        assert!(h.contains("fn albedo_at(i: u32) -> vec3<f32>") && h.contains("21u * frame.packed_pixels + 3u * i"), "{h}");
        assert!(h.contains("fn depth_put(i: u32, v: f32) {\n    if (!is_bound(8u)) { return; }"), "{h}");
        assert!(!h.contains("fn position_put"), "inputs get no writer: {h}");
        let d = binding_header("k", &b, BindingPlan::Direct).unwrap();
        assert!(d.contains("@group(1) @binding(6) var<storage, read> buf_albedo: array<f32>;"), "{d}");
        assert!(d.contains("return vec3<f32>(buf_albedo[b], buf_albedo[b + 1u], buf_albedo[b + 2u]);"), "{d}");
    }

    #[test]
    fn binding_names_must_be_wgsl_identifiers() {
        let e = binding_header("user.k", &[Binding::read("my-input", Format::F32)], BindingPlan::Direct).unwrap_err();
        assert!(e.to_string().contains("`my-input` is not a WGSL identifier") && e.to_string().contains("user.k"), "{e}");
    }
}
