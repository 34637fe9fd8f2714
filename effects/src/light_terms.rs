//! The light terms the built-in nodes declare ([`wedge_graph::terms`]), shared where several nodes
//! hold the same ones: a whole path-traced image, what camera rays see directly, indirect light or
//! ambient occlusion, and what a factoring node's component inputs take.

use wedge_graph::{AcceptView, Accepts, Format, PortDecl, Term, TermKind, TermQuery, Terms, View};

/// What camera rays see directly: emitters, and the environment where they miss.
pub(crate) fn seen_directly(view: View) -> Terms {
    Terms::new().with(Term::new(TermKind::Emission, view)).with(Term::new(TermKind::Background, view))
}

/// The lobes of a BRDF a direct-light term integrates (its detail): the same area light through
/// different lobes is different light — on glossy scenes 2.5–4% of the image (docs/NODES.md "Composing
/// effects").
pub(crate) mod lobes {
    /// `k_d` times the irradiance: Ch. 3's receivers (SoftShadows alone, MonteCarlo).
    pub const DIFFUSE: &str = "diffuse";
    /// The whole Phong BRDF at every sample (next-event estimation of a path tracer).
    pub const PHONG: &str = "diffuse+glossy";
    /// `k = k_d + k_s ρ_s(ω_c)`: the glossy lobe toward the light centre folded into the texture
    /// (eq. 5.20), as a factoring node's direct component composes it.
    pub const TOWARD_LIGHT_CENTRE: &str = "diffuse+glossy toward the light centre";
}

/// A whole path-traced image with next-event estimation at every vertex (area lights and the
/// environment), `bounces` from the integer parameter of that name.
pub(crate) fn path_traced(q: &TermQuery<'_>, view: View) -> Terms {
    first_vertex_direct(view).with(Term::new(TermKind::Indirect, view).detail(q.bounces("bounces")))
}

/// A camera path's first vertex alone: what it sees directly and next-event estimation there (area
/// lights through the whole Phong BRDF, the environment).
pub(crate) fn first_vertex_direct(view: View) -> Terms {
    seen_directly(view)
        .with(Term::new(TermKind::DirectArea, view).detail(lobes::PHONG))
        .with(Term::new(TermKind::DirectEnvironment, view))
}

/// `mode: "ao"`: ambient occlusion; else indirect light of `bounces` bounces, its lobes named by
/// `lobes` where the node knows them (`""`: not said).
pub(crate) fn indirect_or_ao(q: &TermQuery<'_>, view: View, lobes: &str) -> Terms {
    if q.choice("mode") == Some("ao") {
        return Terms::new().with(Term::new(TermKind::AmbientOcclusion, view));
    }
    let detail = if lobes.is_empty() { q.bounces("bounces") } else { format!("{}, {lobes}", q.bounces("bounces")) };
    Terms::new().with(Term::new(TermKind::Indirect, view).detail(detail))
}

/// What an `emission` input takes: what camera rays see directly (`Primary.emission`).
pub(crate) const EMISSION_INPUT: Accepts = Accepts {
    kinds: &[TermKind::Emission, TermKind::Background],
    view: AcceptView::Any,
    fix: "wire `primary.emission` (what camera rays see directly)",
};

/// A factoring node's `direct` input: direct light from area lights (and, from a component rendered
/// without factoring — a pinhole Defocus — the emission it adds), through the sampler's camera.
pub(crate) const COMPONENT_DIRECT: Accepts = Accepts {
    kinds: &[TermKind::DirectArea, TermKind::Emission, TermKind::Background],
    view: AcceptView::Sampler,
    fix: "wire the `radiance` of a SoftShadows node: it renders the direct component on the shared sampler, \
          through the factoring node's lens and shutter; a node that traces its own pinhole paths (PixelFilter, \
          RadianceFilter, MonteCarlo) or one that holds indirect light cannot be factored, the environment's direct \
          light goes to `environment`, and the real layer is not a factored component yet (docs/NODES.md \"Composing effects\": \
          what is refused)",
};

/// A factoring node's `indirect` input: indirect light or ambient occlusion, through the sampler's camera.
pub(crate) const COMPONENT_INDIRECT: Accepts = Accepts {
    kinds: &[TermKind::Indirect, TermKind::AmbientOcclusion],
    view: AcceptView::Sampler,
    fix: "wire the `radiance` of an Indirect (or LightField) node: it renders the indirect component through the \
          factoring node's lens and shutter; direct light goes to `direct` (README \"What does not compose\")",
};

/// A factoring node's `environment` input: the environment's direct light (and, from a component
/// rendered without factoring — Motion on a static scene, a pinhole Defocus — what camera rays see
/// directly, which the Environment node then adds itself), through the sampler's camera.
pub(crate) const COMPONENT_ENVIRONMENT: Accepts = Accepts {
    kinds: &[TermKind::DirectEnvironment, TermKind::Emission, TermKind::Background],
    view: AcceptView::Sampler,
    fix: "wire the `radiance` of an Environment node (without `indirect`): it renders the environment's direct light \
          through the factoring node's lens and shutter; indirect light goes to `indirect` (docs/NODES.md \"Composing effects\")",
};

/// A factoring node's component inputs (Defocus and Motion take the same): each a component node's
/// composed term (eq. 5.32), summed with the emission of the sampler's camera rays.
pub(crate) const COMPONENT_PORTS: [&str; 3] = ["direct", "indirect", "environment"];

/// The declarations of [`COMPONENT_PORTS`].
pub(crate) fn component_inputs() -> Vec<PortDecl> {
    vec![
        PortDecl::optional("direct", Format::Vec3, "the direct component (SoftShadows.radiance)")
            .accepts(COMPONENT_DIRECT),
        PortDecl::optional("indirect", Format::Vec3, "the indirect component (Indirect.radiance)")
            .accepts(COMPONENT_INDIRECT),
        PortDecl::optional("environment", Format::Vec3, "the environment's direct light (Environment.radiance)")
            .accepts(COMPONENT_ENVIRONMENT),
    ]
}

/// What a factoring node without any component input is told.
pub(crate) const NO_COMPONENT: &str = "has no component to blur: wire `direct` (from a SoftShadows node's radiance), \
    `indirect` (from an Indirect node's radiance) and/or `environment` (from an Environment node's radiance)";

/// The terms of a factoring node's output: its components, plus — where it factors and a component
/// holds light — what the shared sampler's camera rays see directly (it adds that once itself;
/// ambient occlusion alone is not radiance, and has no emission: [`crate::factored::seen_directly`]
/// renders what this declares).
pub(crate) fn factoring_sum(q: &TermQuery<'_>) -> Terms {
    let components = q.sum(&COMPONENT_PORTS);
    if q.is_factoring_node() && !components.is_occlusion() {
        seen_directly(q.sampler_view()).plus(Some(&components))
    } else {
        components
    }
}
