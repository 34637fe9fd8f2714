//! Parameter declarations that more than one node makes, each defined once (issue 36 §2): the
//! glossy lobe model `brdf` (its options are `Lobe`'s, which the kernels parse), the bandwidth
//! scale `mu` (each node its own default and reading of the equation it scales) and a factoring
//! node's composed `texture` ([`weighted_texture`]).

use wedge_backends::kernels::hemisphere::Lobe;
use wedge_graph::ParamDecl;

/// `brdf`: the glossy lobe of `k_s, m` (`"phong"`, the default, or `"blinn_phong"`).
pub const fn brdf(doc: &'static str) -> ParamDecl {
    ParamDecl::choice("brdf", "phong", Lobe::OPTIONS, doc)
}

/// `texture`: what a factored pixel's `k` is in eq. 5.32's `k Ẽ` — `"weighted"`, the paths' `k`
/// weighted by the irradiance each brought (`L / Ē`, `defocus::formulas::weighted_texture`), or
/// `"mean"`, the paths' mean `k̄` (5.32 as printed); each node its default and measurement.
pub const fn texture(default: &'static str, doc: &'static str) -> ParamDecl {
    ParamDecl::choice("texture", default, &["weighted", "mean"], doc)
}

/// Whether a node's (or its factoring settings') `texture` asks for the weighted texture.
pub fn weighted_texture(value: Option<&wedge_graph::ParamValue>) -> bool {
    value.and_then(wedge_graph::ParamValue::as_str) == Some("weighted")
}

/// `mu`: μ > 0 scales a node's bandwidths (larger = narrower filters, more rays).
pub const fn mu(default: f64, doc: &'static str) -> ParamDecl {
    ParamDecl::positive("mu", default, 1e6, doc)
}
