//! WGSL composition: wedge's shared shader files and `#include` resolution.
//!
//! A kernel's WGSL names the shared code it needs with `#include "NAME.wgsl"` lines (a line holding
//! only the directive). [`compose_mapped`] replaces each with the file's text, recursively, each file at
//! most once — so `bvh.wgsl` and `sampling.wgsl` may both include `scene.wgsl` and the kernel still
//! gets one copy. `common.wgsl` (frame uniform, counters, NaN-safe math) is always placed first.
//! This is deliberately plain text concatenation: WGSL has no modules, and naga reports errors with
//! line numbers in the composed text, which [`compose_mapped`]'s output keeps readable (each file starts
//! with a `// ---- NAME ----` marker).
//!
//! The binding header is generated here too ([`binding_header`]): kernels never declare group(1);
//! they call `NAME_at(i)` / `NAME_put(i, v)` / `NAME_bound()` per binding of `Kernel::bindings()`,
//! so the WGSL cannot drift from the Rust declaration, and the backend may bind the buffers either
//! one per binding or packed into two buffers ([`BindingPlan`]) without the kernel noticing.

use std::collections::HashSet;

use wedge_graph::{FieldType, Format, StructLayout};

use crate::kernel::{Access, Binding, WgslSource};
use crate::BackendError;

/// wedge's shared WGSL, available to every kernel (built-in and user kernels alike).
pub const SHARED: &[(&str, &str)] = &[
    ("common.wgsl", include_str!("../../../shaders/common.wgsl")),
    ("rng.wgsl", include_str!("../../../shaders/rng.wgsl")),
    ("scene.wgsl", include_str!("../../../shaders/scene.wgsl")),
    ("motion.wgsl", include_str!("../../../shaders/motion.wgsl")),
    ("environment.wgsl", include_str!("../../../shaders/environment.wgsl")),
    ("real_layer.wgsl", include_str!("../../../shaders/real_layer.wgsl")),
    ("bvh.wgsl", include_str!("../../../shaders/bvh.wgsl")),
    ("sampling.wgsl", include_str!("../../../shaders/sampling.wgsl")),
    ("camera.wgsl", include_str!("../../../shaders/camera.wgsl")),
    ("sobol.wgsl", include_str!("../../../shaders/sobol.wgsl")),
    ("hemisphere.wgsl", include_str!("../../../shaders/hemisphere.wgsl")),
    // The direct and indirect estimators, shared by direct.light / indirect.sample and paths.trace.
    // The diffuse + glossy lobe mixture (weight_of, lobe_mixture, lobe_sample, lobe_eval).
    ("lobe_mixture.wgsl", include_str!("../../../shaders/lobe_mixture.wgsl")),
    ("light_sample.wgsl", include_str!("../../../shaders/light_sample.wgsl")),
    ("indirect_path.wgsl", include_str!("../../../shaders/indirect_path.wgsl")),
    // A camera path's first vertex and radiance sample, shared by pixel_filter.sample and
    // radiance_filter.sample (wedge-effects' camera_paths.rs first_vertex).
    ("first_vertex.wgsl", include_str!("../../../shaders/first_vertex.wgsl")),
    // Their camera and the camera ray of a path (camera_paths.rs camera_uniforms, camera_ray), shared
    // with pixel_filter.range.
    ("camera_path.wgsl", include_str!("../../../shaders/camera_path.wgsl")),
    // Environment look-ups and next-event estimation of the environment (kernels/environment.rs).
    ("environment_light.wgsl", include_str!("../../../shaders/environment_light.wgsl")),
];

/// A kernel's composed WGSL and, for each of its lines, where that line came from: the file (a
/// shared file's name, `generated` for the header, or the kernel's own source) and its 1-based line
/// (0 for a `// ---- NAME ----` marker), so a compiler's error points at what the user wrote.
pub struct Composed {
    pub text: String,
    pub origin: Vec<(String, usize)>,
}

impl Composed {
    /// `file:line` of line `line` (1-based) of the composed text.
    pub fn origin_of(&self, line: usize) -> Option<(&str, usize)> {
        self.origin.get(line.checked_sub(1)?).map(|(f, l)| (f.as_str(), *l))
    }
}

/// The text a kernel's pipeline compiles, as the wgpu backend builds it: the `Params` struct of
/// `uniforms`, the binding header under `plan`, the traversal stack size for a scene kernel, then
/// [`compose_mapped`]. Shared by the backend and the device-less check ([`super::validate`]).
pub fn kernel_wgsl(
    name: &str,
    src: &WgslSource,
    bindings: &[Binding],
    uniforms: &crate::kernel::Uniforms,
    plan: BindingPlan,
    stack_entries: u32,
) -> Result<Composed, BackendError> {
    let params = uniforms.wgsl_struct().map_err(|e| BackendError::Gpu(format!("kernel `{name}`: {e}")))?;
    let mut header = params + &binding_header(name, bindings, plan)?;
    if src.scene {
        header.push_str(&format!("const BVH_STACK_SIZE: u32 = {stack_entries}u;\n"));
    }
    compose_mapped(name, src, &header)
}

/// The full WGSL of a kernel: `common.wgsl`, the generated `header` (its bindings, see
/// [`binding_header`]), then its source with every include resolved, with the origin of every line.
pub fn compose_mapped(kernel: &str, src: &WgslSource, header: &str) -> Result<Composed, BackendError> {
    let mut out = Composed { text: String::new(), origin: Vec::new() };
    let mut seen = HashSet::new();
    let lookup = |name: &str| -> Option<String> {
        src.includes
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, t)| t.to_string())
            .or_else(|| SHARED.iter().find(|(n, _)| *n == name).map(|(_, t)| t.to_string()))
    };
    expand(kernel, "common.wgsl", &lookup("common.wgsl").unwrap_or_default(), &lookup, &mut seen, &mut out, 0)?;
    for (k, line) in header.lines().enumerate() {
        out.push(line, "generated header", k + 1);
    }
    // The kernel's own source is named by the kernel (it has no file name of its own here).
    expand(kernel, kernel, &src.source, &lookup, &mut seen, &mut out, 0)?;
    Ok(out)
}

impl Composed {
    fn push(&mut self, line: &str, file: &str, line_no: usize) {
        self.text.push_str(line);
        self.text.push('\n');
        self.origin.push((file.to_string(), line_no));
    }
}

fn expand(
    kernel: &str,
    name: &str,
    text: &str,
    lookup: &dyn Fn(&str) -> Option<String>,
    seen: &mut HashSet<String>,
    out: &mut Composed,
    depth: usize,
) -> Result<(), BackendError> {
    if depth > 16 {
        return Err(BackendError::Gpu(format!("kernel `{kernel}`: #include nesting deeper than 16 at `{name}`")));
    }
    if !seen.insert(name.to_string()) {
        return Ok(());
    }
    out.push(&format!("// ---- {name} ----"), name, 0);
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
            out.push(line, name, line_no + 1);
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
/// even though it is stored as 3 packed floats; a struct format as its generated WGSL struct).
fn element_type(format: Format) -> &'static str {
    match format {
        Format::F32 => "f32",
        Format::Vec2 => "vec2<f32>",
        Format::Vec3 => "vec3<f32>",
        Format::Vec4 => "vec4<f32>",
        Format::U32 => "u32",
        Format::Struct(layout) => layout.name,
    }
}

/// The WGSL `struct` of a struct format: its fields as values (`vec3<f32>` members and all). The
/// struct is never a memory layout — storage is `array<u32>` and the generated accessors move each
/// field word by word ([`struct_load`], [`struct_store`]) — so WGSL's vec3 alignment never applies.
pub fn struct_declaration(layout: &StructLayout) -> String {
    let mut s = format!("struct {} {{\n", layout.name);
    for f in layout.fields {
        s.push_str(&format!("    {}: {},\n", f.name, f.ty.wgsl()));
    }
    s.push_str("}\n");
    s
}

/// Body loading a struct element whose first word is `array[b]`.
fn struct_load(layout: &StructLayout, array: &str) -> String {
    let word = |k: usize| format!("{array}[b + {k}u]");
    let fw = |k: usize| format!("bitcast<f32>({})", word(k));
    let values: Vec<String> = layout
        .offsets()
        .map(|(o, f)| match f.ty {
            FieldType::U32 => word(o),
            FieldType::F32 => fw(o),
            ty => {
                let n = ty.words();
                format!("vec{n}<f32>({})", (o..o + n).map(fw).collect::<Vec<_>>().join(", "))
            }
        })
        .collect();
    format!("    return {}({});\n", layout.name, values.join(", "))
}

/// Body storing struct element `v` from word `array[b]` on.
fn struct_store(layout: &StructLayout, array: &str) -> String {
    let mut s = String::new();
    for (o, f) in layout.offsets() {
        match f.ty {
            FieldType::U32 => s.push_str(&format!("    {array}[b + {o}u] = v.{};\n", f.name)),
            FieldType::F32 => s.push_str(&format!("    {array}[b + {o}u] = bitcast<u32>(v.{});\n", f.name)),
            ty => {
                for (c, comp) in ["x", "y", "z", "w"].iter().take(ty.words()).enumerate() {
                    s.push_str(&format!("    {array}[b + {}u] = bitcast<u32>(v.{}.{comp});\n", o + c, f.name));
                }
            }
        }
    }
    s
}

/// Storage bindings group(1) uses under `plan` (inputs, outputs): for the limit check.
pub fn storage_bindings(bindings: &[Binding], plan: BindingPlan) -> u32 {
    match plan {
        BindingPlan::Direct => bindings.len() as u32,
        BindingPlan::Packed => {
            bindings.iter().any(|b| b.access == Access::Read) as u32
                + bindings.iter().any(|b| b.access == Access::Write) as u32
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
                out.push_str(&format!(
                    "@group(1) @binding({out_slot}) var<storage, read_write> packed_outputs: array<u32>;\n"
                ));
            }
        }
    }
    // One WGSL struct per struct layout the bindings use (several bindings may share one).
    let mut declared: Vec<&'static StructLayout> = Vec::new();
    for b in bindings {
        if let Format::Struct(layout) = b.format {
            if let Some(other) = declared.iter().find(|d| d.name == layout.name) {
                if let Some(diff) = layout.difference(other) {
                    return Err(BackendError::Gpu(format!(
                        "kernel `{kernel}`: two layouts named `{}`: {diff}",
                        layout.name
                    )));
                }
                continue;
            }
            let problems = layout.problems();
            if !problems.is_empty() {
                return Err(BackendError::Gpu(format!("kernel `{kernel}`: {}", problems.join("; "))));
            }
            out.push_str(&struct_declaration(layout));
            declared.push(layout);
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
        let guard_at =
            if b.optional { format!("    if (!is_bound({k}u)) {{ return {ty}(); }}\n") } else { String::new() };
        let guard_put = if b.optional { format!("    if (!is_bound({k}u)) {{ return; }}\n") } else { String::new() };
        out.push_str(&format!("fn {name}_bound() -> bool {{ return is_bound({k}u); }}\n"));
        // Element load/store bodies, per plan.
        let (load, store) = match plan {
            BindingPlan::Direct => {
                let access = if write { "read_write" } else { "read" };
                let array = match b.format {
                    Format::Vec3 => "array<f32>".to_string(),
                    Format::Struct(_) => "array<u32>".to_string(),
                    f => format!("array<{}>", element_type(f)),
                };
                out.push_str(&format!("@group(1) @binding({k}) var<storage, {access}> buf_{name}: {array};\n"));
                match b.format {
                    Format::Struct(layout) => {
                        let base = format!("    let b = {n}u * i;\n");
                        (
                            format!("{base}{}", struct_load(layout, &format!("buf_{name}"))),
                            format!("{base}{}", struct_store(layout, &format!("buf_{name}"))),
                        )
                    }
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
                    Format::Struct(layout) => format!("{base}{}", struct_load(layout, array)),
                    Format::U32 => format!("{base}    return {array}[b];\n"),
                    Format::F32 => format!("{base}    return bitcast<f32>({array}[b]);\n"),
                    _ => {
                        let words: Vec<String> = (0..n).map(|c| format!("{array}[b + {c}u]")).collect();
                        format!("{base}    return bitcast<{ty}>(vec{n}<u32>({}));\n", words.join(", "))
                    }
                };
                let store = match b.format {
                    Format::Struct(layout) => format!("{base}{}", struct_store(layout, array)),
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
        assert!(
            h.contains("fn albedo_at(i: u32) -> vec3<f32>") && h.contains("21u * frame.packed_pixels + 3u * i"),
            "{h}"
        );
        assert!(h.contains("fn depth_put(i: u32, v: f32) {\n    if (!is_bound(8u)) { return; }"), "{h}");
        assert!(!h.contains("fn position_put"), "inputs get no writer: {h}");
        let d = binding_header("k", &b, BindingPlan::Direct).unwrap();
        assert!(d.contains("@group(1) @binding(6) var<storage, read> buf_albedo: array<f32>;"), "{d}");
        assert!(d.contains("return vec3<f32>(buf_albedo[b], buf_albedo[b + 1u], buf_albedo[b + 2u]);"), "{d}");
    }

    #[test]
    fn struct_bindings_get_a_generated_struct_and_word_accessors() {
        use wedge_graph::Field;
        static REC: StructLayout = StructLayout {
            name: "Rec",
            fields: &[
                Field::new("l", FieldType::Vec3),
                Field::new("n", FieldType::U32),
                Field::new("d", FieldType::F32),
            ],
        };
        let b = vec![
            Binding::read("a", Format::Vec3),
            Binding::read_opt("prev", Format::Struct(&REC)),
            Binding::write("rec", Format::Struct(&REC)),
        ];
        let d = binding_header("k", &b, BindingPlan::Direct).unwrap();
        assert_eq!(d.matches("struct Rec {").count(), 1, "one declaration for two bindings: {d}");
        assert!(d.contains("struct Rec {\n    l: vec3<f32>,\n    n: u32,\n    d: f32,\n}"), "{d}");
        assert!(d.contains("var<storage, read_write> buf_rec: array<u32>;"), "{d}");
        assert!(d.contains("let b = 5u * i;\n    return Rec(vec3<f32>(bitcast<f32>(buf_rec[b + 0u]), bitcast<f32>(buf_rec[b + 1u]), bitcast<f32>(buf_rec[b + 2u])), buf_rec[b + 3u], bitcast<f32>(buf_rec[b + 4u]));"), "{d}");
        assert!(d.contains("buf_rec[b + 2u] = bitcast<u32>(v.l.z);\n    buf_rec[b + 3u] = v.n;\n    buf_rec[b + 4u] = bitcast<u32>(v.d);"), "{d}");
        assert!(d.contains("fn prev_at(i: u32) -> Rec {\n    if (!is_bound(1u)) { return Rec(); }"), "{d}");
        let p = binding_header("k", &b, BindingPlan::Packed).unwrap();
        let (offsets, inputs, outputs) = packed_layout(&b);
        assert_eq!((offsets, inputs, outputs), (vec![0, 3, 0], 8, 5));
        assert!(p.contains("let b = 3u * frame.packed_pixels + 5u * i;\n    return Rec(vec3<f32>(bitcast<f32>(packed_inputs[b + 0u])"), "{p}");
        static OTHER: StructLayout = StructLayout { name: "Rec", fields: &[Field::new("l", FieldType::Vec4)] };
        let e = binding_header(
            "k",
            &[Binding::read("a", Format::Struct(&REC)), Binding::write("b", Format::Struct(&OTHER))],
            BindingPlan::Direct,
        )
        .unwrap_err();
        assert!(e.to_string().contains("two layouts named `Rec`"), "{e}");
    }

    #[test]
    fn binding_names_must_be_wgsl_identifiers() {
        let e = binding_header("user.k", &[Binding::read("my-input", Format::F32)], BindingPlan::Direct).unwrap_err();
        assert!(
            e.to_string().contains("`my-input` is not a WGSL identifier") && e.to_string().contains("user.k"),
            "{e}"
        );
    }
}
