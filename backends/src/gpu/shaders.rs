//! WGSL composition: wedge's shared shader files and `#include` resolution.
//!
//! A kernel's WGSL names the shared code it needs with `#include "NAME.wgsl"` lines (a line holding
//! only the directive). [`compose`] replaces each with the file's text, recursively, each file at
//! most once — so `bvh.wgsl` and `sampling.wgsl` may both include `scene.wgsl` and the kernel still
//! gets one copy. `common.wgsl` (frame uniform, counters, NaN-safe math) is always placed first.
//! This is deliberately plain text concatenation: WGSL has no modules, and naga reports errors with
//! line numbers in the composed text, which [`compose`]'s output keeps readable (each file starts
//! with a `// ---- NAME ----` marker).

use std::collections::HashSet;

use crate::kernel::WgslSource;
use crate::BackendError;

/// wedge's shared WGSL, available to every kernel (built-in and user kernels alike).
pub const SHARED: &[(&str, &str)] = &[
    ("common.wgsl", include_str!("../../../shaders/common.wgsl")),
    ("rng.wgsl", include_str!("../../../shaders/rng.wgsl")),
    ("scene.wgsl", include_str!("../../../shaders/scene.wgsl")),
    ("bvh.wgsl", include_str!("../../../shaders/bvh.wgsl")),
    ("sampling.wgsl", include_str!("../../../shaders/sampling.wgsl")),
];

/// The full WGSL of a kernel: `common.wgsl`, then its source with every include resolved.
pub fn compose(kernel: &str, src: &WgslSource) -> Result<String, BackendError> {
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
