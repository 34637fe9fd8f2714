//! Parameter declarations that more than one node makes, each defined once (issue 36 §2): the
//! glossy lobe model `brdf` (its options are `Lobe`'s, which the kernels parse) and the bandwidth
//! scale `mu` (each node its own default and reading of the equation it scales).

use wedge_backends::kernels::hemisphere::Lobe;
use wedge_graph::ParamDecl;

/// `brdf`: the glossy lobe of `k_s, m` (`"phong"`, the default, or `"blinn_phong"`).
pub const fn brdf(doc: &'static str) -> ParamDecl {
    ParamDecl::choice("brdf", "phong", Lobe::OPTIONS, doc)
}

/// `mu`: μ > 0 scales a node's bandwidths (larger = narrower filters, more rays).
pub const fn mu(default: f64, doc: &'static str) -> ParamDecl {
    ParamDecl::positive("mu", default, 1e6, doc)
}
