//! Parameter declarations that more than one node makes, each defined once (issue 36 §2): the
//! glossy lobe model `brdf` (its options are `Lobe`'s, which the kernels parse), the bandwidth
//! scale `mu` (each node its own default and reading of the equation it scales), the light
//! sample's geometry term `form_factor`, and the factoring nodes' (Defocus, Motion) `mode` and
//! `max_primary`.

use wedge_backends::kernels::direct::FormFactor;
use wedge_backends::kernels::hemisphere::Lobe;
use wedge_graph::ParamDecl;

use crate::defocus::formulas::Mode;

/// `brdf`: the glossy lobe of `k_s, m` (`"phong"`, the default, or `"blinn_phong"`).
pub const fn brdf(doc: &'static str) -> ParamDecl {
    ParamDecl::choice("brdf", "phong", Lobe::OPTIONS, doc)
}

/// `mu`: μ > 0 scales a node's bandwidths (larger = narrower filters, more rays).
pub const fn mu(default: f64, doc: &'static str) -> ParamDecl {
    ParamDecl::positive("mu", default, 1e6, doc)
}

/// `form_factor`: a light sample's geometry term per sample (`"exact"`) or the thesis's light-centre
/// form factor (`"light_centre"`); each node its default (the factoring nodes read the thesis).
pub const fn form_factor(default: &'static str, doc: &'static str) -> ParamDecl {
    ParamDecl::choice("form_factor", default, FormFactor::OPTIONS, doc)
}

/// `mode`: how a factoring node's μ scales its bandwidths (eq. 5.29), consistent or as printed.
pub const fn mode() -> ParamDecl {
    ParamDecl::choice("mode", "consistent", Mode::OPTIONS, "consistent (Ω scales with μ without a clamp: converges to Monte Carlo as μ grows; the default since issue 35), or literal: eq. 5.29 as printed (clamped at Ω_pix^max: above μ = 1 the filters narrow while the counts stop growing, so the error rises)")
}

/// `max_primary`: a factoring node's cap on its primary rays per pixel.
pub const fn max_primary() -> ParamDecl {
    ParamDecl::int("max_primary", 256, 1, 4096, "cap on primary rays per pixel n_p (rounded down to a square)")
}
