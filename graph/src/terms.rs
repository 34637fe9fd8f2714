//! Light terms: which light a radiance buffer holds, as part of its port's type.
//!
//! A radiance image is a sum of light-path terms — emission seen directly, the environment seen
//! directly, direct light from area lights and from the environment, indirect light, ambient
//! occlusion, the real layer of a mixed-reality composite — each integrated over some camera
//! dimensions (a pinhole, the lens, the shutter). Two nodes that each hold a term, summed, count it
//! twice; a factoring node fed an image it cannot factor blurs the wrong thing. Both rendered
//! without any error before terms existed (a pinhole image in `Defocus.direct`, emission added
//! twice through `Add`). With terms they are type errors found by `wedge graph`, before anything runs.
//!
//! The rules are data, not checks of node kinds:
//! - each node kind states the terms of its radiance outputs in [`crate::NodeKind::terms`] (from its
//!   parameters, the terms of its wired inputs and the pipeline's factoring node: [`TermQuery`]);
//! - an input port may state which terms it accepts ([`Accepts`], on its [`crate::PortDecl`]);
//! - [`check`] walks the nodes in order and refuses an output that holds one term twice (naming the
//!   two inputs it came through), an output that mixes camera models, and an input given a term it
//!   does not accept; it notes inputs whose terms reach no output (e.g. `emission` wired into a
//!   component that a factoring node renders, which adds emission itself).
//!
//! A user's node that declares no terms has outputs of unknown terms: they are shown as such and
//! cannot be checked, but nothing is refused for it.

use std::collections::BTreeMap;
use std::fmt;

use crate::decl::ParamValue;
use crate::factoring::{CameraSettings, Factoring};
use crate::validate::{Diagnostic, DiagnosticKind, ValidatedPipeline};

/// One kind of light-path term.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum TermKind {
    /// Emitters seen directly by camera rays.
    Emission,
    /// The environment map seen directly by camera rays that miss every surface.
    Background,
    /// Light from area lights (emissive triangles) arriving directly at the surface seen.
    DirectArea,
    /// Light from the environment map arriving directly at the surface seen.
    DirectEnvironment,
    /// Light arriving at the surface seen after one or more further bounces (from every light).
    Indirect,
    /// Ambient occlusion: an unoccluded fraction, not radiance.
    AmbientOcclusion,
    /// The real layer of a mixed-reality composite (the photograph, differentially relit).
    RealLayer,
}

impl TermKind {
    /// Every kind, in display order.
    pub const ALL: [TermKind; 7] = [
        TermKind::Emission,
        TermKind::Background,
        TermKind::DirectArea,
        TermKind::DirectEnvironment,
        TermKind::Indirect,
        TermKind::AmbientOcclusion,
        TermKind::RealLayer,
    ];
    /// The name shown in `wedge graph` and messages.
    pub const fn name(self) -> &'static str {
        match self {
            TermKind::Emission => "emission",
            TermKind::Background => "background",
            TermKind::DirectArea => "direct(area)",
            TermKind::DirectEnvironment => "direct(environment)",
            TermKind::Indirect => "indirect",
            TermKind::AmbientOcclusion => "ambient occlusion",
            TermKind::RealLayer => "real layer",
        }
    }
    /// What the term is, in words (documentation, `wedge graph --help`).
    pub const fn meaning(self) -> &'static str {
        match self {
            TermKind::Emission => "emitters seen directly by camera rays",
            TermKind::Background => "the environment map seen directly where camera rays miss every surface",
            TermKind::DirectArea => "light from area lights arriving directly at the surface seen",
            TermKind::DirectEnvironment => "light from the environment map arriving directly at the surface seen",
            TermKind::Indirect => "light from every source arriving after one or more further bounces",
            TermKind::AmbientOcclusion => "the unoccluded fraction of the hemisphere (not radiance)",
            TermKind::RealLayer => "the photograph of a mixed-reality composite, relit",
        }
    }
}

/// The camera dimensions a term is integrated over: a pinhole at the shutter's centre, the lens's
/// aperture, the shutter's interval, or both.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct View {
    pub lens: bool,
    pub shutter: bool,
}

impl View {
    pub const PINHOLE: View = View { lens: false, shutter: false };
    /// The view of paths sampled with these camera settings.
    pub fn of(settings: &CameraSettings) -> View {
        View { lens: settings.aperture().is_some_and(|a| a > 0.0), shutter: settings.time }
    }
}

impl fmt::Display for View {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match (self.lens, self.shutter) {
            (false, false) => "through a pinhole at the shutter's centre",
            (true, false) => "through the lens",
            (false, true) => "over the shutter",
            (true, true) => "through the lens and over the shutter",
        })
    }
}

/// One term a radiance buffer holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Term {
    pub kind: TermKind,
    /// For [`TermKind::DirectArea`]: the one area light it covers (`None`: every light).
    pub light: Option<u32>,
    /// Shown after the name, e.g. `1 bounce, diffuse+glossy`.
    pub detail: String,
    pub view: View,
    /// The output (`node.port`) it reached the node through; empty for the node's own terms.
    pub via: String,
}

impl Term {
    pub fn new(kind: TermKind, view: View) -> Term {
        Term { kind, light: None, detail: String::new(), view, via: String::new() }
    }
    /// A direct term of one area light.
    pub fn light(mut self, index: u32) -> Term {
        self.light = Some(index);
        self
    }
    pub fn detail(mut self, detail: impl Into<String>) -> Term {
        self.detail = detail.into();
        self
    }
    /// Whether the two count some of the same light (the same kind; for area lights, a light in
    /// common).
    pub fn overlaps(&self, other: &Term) -> bool {
        self.kind == other.kind && (self.light.is_none() || other.light.is_none() || self.light == other.light)
    }
    /// `direct(area light 0, diffuse)`, `indirect(1 bounce, diffuse+glossy)`, `emission`.
    pub fn label(&self) -> String {
        match (self.kind, self.light, self.detail.is_empty()) {
            (TermKind::DirectArea, Some(i), true) => format!("direct(area light {i})"),
            (TermKind::DirectArea, None, true) => "direct(area, every light)".into(),
            (TermKind::DirectArea, Some(i), false) => format!("direct(area light {i}, {})", self.detail),
            (TermKind::DirectArea, None, false) => format!("direct(area, every light, {})", self.detail),
            (k, _, true) => k.name().into(),
            (k, _, false) => format!("{}({})", k.name(), self.detail),
        }
    }
}

/// The terms a radiance output holds. Sums keep every copy (a term twice is what [`check`] refuses).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Terms {
    pub terms: Vec<Term>,
    /// Outputs summed in whose terms are not declared (a user's node without [`crate::NodeKind::terms`]).
    pub undeclared: Vec<String>,
}

impl Terms {
    pub fn new() -> Terms {
        Terms::default()
    }
    pub fn with(mut self, term: Term) -> Terms {
        self.terms.push(term);
        self
    }
    /// This sum plus `other` (an unconnected input adds nothing).
    pub fn plus(mut self, other: Option<&Terms>) -> Terms {
        if let Some(o) = other {
            self.terms.extend(o.terms.iter().cloned());
            self.undeclared.extend(o.undeclared.iter().cloned());
        }
        self
    }
    pub fn holds(&self, kind: TermKind) -> bool {
        self.terms.iter().any(|t| t.kind == kind)
    }
    /// Every pair of terms that count the same light.
    pub fn overlapping(&self) -> Vec<(&Term, &Term)> {
        let t = &self.terms;
        (0..t.len())
            .flat_map(|i| (i + 1..t.len()).map(move |j| (i, j)))
            .filter(|&(i, j)| t[i].overlaps(&t[j]))
            .map(|(i, j)| (&t[i], &t[j]))
            .collect()
    }
    /// The distinct views, in order of appearance.
    pub fn views(&self) -> Vec<View> {
        let mut v: Vec<View> = Vec::new();
        for t in &self.terms {
            if !v.contains(&t.view) {
                v.push(t.view);
            }
        }
        v
    }
    /// Area lights covered: `None` when some term covers every light, else the indices.
    pub fn area_lights(&self) -> Option<Vec<u32>> {
        let direct: Vec<&Term> = self.terms.iter().filter(|t| t.kind == TermKind::DirectArea).collect();
        if direct.iter().any(|t| t.light.is_none()) {
            return None;
        }
        Some(direct.iter().filter_map(|t| t.light).collect())
    }
    /// Only ambient occlusion: not a radiance image (nothing about light can be missing from it).
    pub fn is_occlusion(&self) -> bool {
        !self.terms.is_empty() && self.terms.iter().all(|t| t.kind == TermKind::AmbientOcclusion)
    }
    /// The sum in display order, e.g. `emission + direct(area light 0) + indirect(1 bounce)`.
    pub fn sum_label(&self) -> String {
        let mut sorted: Vec<&Term> = self.terms.iter().collect();
        sorted.sort_by_key(|t| (t.kind, t.light));
        let mut parts: Vec<String> = sorted.iter().map(|t| t.label()).collect();
        parts.extend(self.undeclared.iter().map(|u| format!("the undeclared terms of `{u}`")));
        if parts.is_empty() {
            "nothing".into()
        } else {
            parts.join(" + ")
        }
    }
    fn via(mut self, reference: &str) -> Terms {
        for t in &mut self.terms {
            t.via = reference.to_string();
        }
        self
    }
}

impl fmt::Display for Terms {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.sum_label())?;
        match self.views().as_slice() {
            [] => Ok(()),
            [one] => write!(f, ", {one}"),
            many => write!(f, ", mixed: {}", many.iter().map(View::to_string).collect::<Vec<_>>().join(" / ")),
        }
    }
}

/// Which view an input accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AcceptView {
    /// Any.
    Any,
    /// The view of the pipeline's shared sampler: the factoring node's camera (its lens, its shutter)
    /// where one factors, else a pinhole. A factoring node's component inputs state this: an image
    /// that did not sample its lens or shutter cannot be blurred into one that did.
    Sampler,
}

/// What an input port accepts: radiance made only of these kinds, seen as `view` says; `fix` is the
/// help shown when something else is wired in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Accepts {
    pub kinds: &'static [TermKind],
    pub view: AcceptView,
    pub fix: &'static str,
}

impl Accepts {
    /// Any radiance, through any camera: a sum's operands, a sink's image. Declared so that the
    /// undeclared terms of a user's node are carried through them by name.
    pub const ANY: Accepts = Accepts { kinds: &TermKind::ALL, view: AcceptView::Any, fix: "" };
}

/// What a node kind's [`crate::NodeKind::terms`] may read: its parameters, the terms of its wired
/// radiance inputs, and the pipeline's factoring node.
pub struct TermQuery<'a> {
    pub node: &'a str,
    pub params: &'a BTreeMap<String, ParamValue>,
    pub inputs: &'a BTreeMap<String, Terms>,
    /// Every connected input port, radiance or not.
    pub connected: Vec<&'a str>,
    pub factoring: Option<&'a Factoring>,
    /// The pipeline's `camera:` block, if it has one.
    pub camera: Option<&'a crate::pipeline::CameraSpec>,
    /// The loaded scene's facts (`None`: decided without a scene).
    pub scene: Option<&'a crate::SceneFacts>,
}

impl TermQuery<'_> {
    /// The view of the shared sampler's paths: the factoring node's camera, else the camera block's
    /// (its lens and shutter unfiltered: [`TermQuery::plain_camera`]).
    pub fn sampler_view(&self) -> View {
        self.own_view()
    }
    /// The camera block samples a lens or a shutter and no factoring node filters them
    /// ([`CameraSettings::unfiltered`]).
    pub fn plain_camera(&self) -> bool {
        CameraSettings::unfiltered(self.factoring, self.camera, self.scene)
    }
    /// The view of a node that traces its own camera paths through the pipeline's camera block: its
    /// lens where the block gives an aperture, its shutter where the block opens it over an interval
    /// and the scene moves (or is not loaded yet: a static scene looks the same at every time).
    pub fn camera_view(&self) -> View {
        View::of(&CameraSettings::of_block(self.camera, self.scene))
    }
    /// The view of a node that traces its own camera paths and is a component under a factoring
    /// node ([`CameraSettings::own_paths`]: the factoring node's camera, else the camera block's).
    pub fn own_view(&self) -> View {
        View::of(&CameraSettings::own_paths(self.factoring, self.camera, self.scene))
    }
    /// Some node factors the pipeline: the shared sampler's components are rendered for it.
    pub fn factored(&self) -> bool {
        self.factoring.is_some()
    }
    /// This node is the pipeline's factoring node.
    pub fn is_factoring_node(&self) -> bool {
        self.factoring.is_some_and(|f| f.node == self.node)
    }
    /// The terms wired into input `port` (`None`: unconnected or not radiance).
    pub fn input(&self, port: &str) -> Option<&Terms> {
        self.inputs.get(port)
    }
    /// Whether input `port` is connected (radiance or not).
    pub fn is_connected(&self, port: &str) -> bool {
        self.connected.contains(&port)
    }
    /// The sum of the terms wired into `ports`.
    pub fn sum(&self, ports: &[&str]) -> Terms {
        ports.iter().fold(Terms::new(), |t, p| t.plus(self.input(p)))
    }
    pub fn int(&self, name: &str) -> Option<i64> {
        match self.params.get(name)? {
            ParamValue::Int(v) => Some(*v),
            _ => None,
        }
    }
    pub fn flag(&self, name: &str) -> bool {
        self.params.get(name).and_then(ParamValue::as_bool) == Some(true)
    }
    pub fn choice(&self, name: &str) -> Option<&str> {
        self.params.get(name).and_then(ParamValue::as_str)
    }
    /// `N bounce(s)` from the integer parameter `name`.
    pub fn bounces(&self, name: &str) -> String {
        match self.int(name) {
            Some(1) => "1 bounce".into(),
            Some(b) => format!("{b} bounces"),
            None => String::new(),
        }
    }
}

/// What [`check`] found: the terms of every radiance output, the image each sink input receives,
/// and notes (inputs whose terms reach no output).
#[derive(Clone, Debug, Default)]
pub struct TermReport {
    /// `(node, port)` → terms, for every output whose kind declares terms.
    pub outputs: BTreeMap<(String, String), Terms>,
    /// `(sink node, input port, producer "node.port", terms)` for the radiance inputs of sinks.
    pub images: Vec<(String, String, String, Terms)>,
    pub notes: Vec<String>,
}

impl TermReport {
    /// The terms of output `node.port`.
    pub fn of(&self, node: &str, port: &str) -> Option<&Terms> {
        self.outputs.get(&(node.to_string(), port.to_string()))
    }
}

/// Work out the terms of every radiance output of `v` (its nodes in order) and check them: a term
/// counted twice, mixed camera models, an input given terms it does not accept.
pub(crate) fn check(v: &ValidatedPipeline) -> (TermReport, Vec<Diagnostic>) {
    let mut report = TermReport::default();
    let mut problems: Vec<Diagnostic> = Vec::new();
    // Nodes already reported, and every node downstream of one: their sums are not checked again,
    // so one wrong wire is one error, not a cascade.
    let mut reported: Vec<&str> = Vec::new();
    for node in &v.nodes {
        let inputs = wired_terms(node, &report);
        let upstream_reported = node.inputs.values().any(|(n, _)| reported.contains(&n.as_str()));
        let refused = if upstream_reported { Vec::new() } else { check_accepted(v, node, &inputs) };
        let connected = node.inputs.keys().map(String::as_str).collect();
        let (factoring, camera, scene) = (v.factoring.as_ref(), v.pipeline.camera.as_ref(), v.scene_facts.as_ref());
        let q =
            TermQuery { node: &node.name, params: &node.params, inputs: &inputs, connected, factoring, camera, scene };
        let mut own: Vec<(&'static str, Terms)> = Vec::new();
        for port in node.kind.outputs() {
            if let Some(t) = node.kind.terms(port.name, &q) {
                own.push((port.name, t));
            }
        }
        let mut found = match own.first() {
            Some((_, first)) if refused.is_empty() && !upstream_reported => check_sum(node, first),
            _ => refused,
        };
        if let (Some((_, first)), Some(facts)) = (own.first(), scene) {
            found.extend(check_lights_exist(node, first, facts));
        }
        if upstream_reported || !found.is_empty() {
            reported.push(&node.name);
        }
        problems.extend(found);
        report.notes.extend(unread_inputs(v, node, &inputs, &own));
        if node.kind.is_sink() {
            for (port, (pnode, pport)) in &node.inputs {
                if let Some(t) = inputs.get(port) {
                    report.images.push((node.name.clone(), port.clone(), format!("{pnode}.{pport}"), t.clone()));
                }
            }
        }
        for (port, t) in own {
            report.outputs.insert((node.name.clone(), port.to_string()), t);
        }
    }
    (report, problems)
}

/// The terms of `node`'s wired inputs, each term marked with the output it came through.
fn wired_terms(node: &crate::ValidatedNode, report: &TermReport) -> BTreeMap<String, Terms> {
    node.inputs
        .iter()
        .filter_map(|(port, (pnode, pport))| {
            let reference = format!("{pnode}.{pport}");
            let terms = match report.of(pnode, pport) {
                Some(t) => t.clone().via(&reference),
                // A radiance output whose kind declares no terms: unknown, carried by name.
                None if is_undeclared_radiance(node, port) => {
                    Terms { terms: Vec::new(), undeclared: vec![reference.clone()] }
                }
                None => return None,
            };
            Some((port.clone(), terms))
        })
        .collect()
}

/// Whether input `port` of `node` takes radiance (it accepts terms, or it is a sink's vec3 image),
/// so an output wired into it without declared terms is carried as unknown.
fn is_undeclared_radiance(node: &crate::ValidatedNode, port: &str) -> bool {
    node.kind
        .inputs()
        .iter()
        .any(|d| d.name == port && (d.accepts.is_some() || (node.kind.is_sink() && d.format == crate::Format::Vec3)))
}

/// An input given a term it does not accept, or a view it does not.
fn check_accepted(
    v: &ValidatedPipeline,
    node: &crate::ValidatedNode,
    inputs: &BTreeMap<String, Terms>,
) -> Vec<Diagnostic> {
    let sampler_view =
        View::of(&CameraSettings::own_paths(v.factoring.as_ref(), v.pipeline.camera.as_ref(), v.scene_facts.as_ref()));
    let mut out = Vec::new();
    for decl in node.kind.inputs() {
        let (Some(accepts), Some(terms)) = (decl.accepts, inputs.get(decl.name)) else { continue };
        let foreign: Vec<String> =
            terms.terms.iter().filter(|t| !accepts.kinds.contains(&t.kind)).map(Term::label).collect();
        let wrong_view = accepts.view == AcceptView::Sampler && terms.views().iter().any(|w| *w != sampler_view);
        if foreign.is_empty() && !wrong_view {
            continue;
        }
        let (pnode, pport) = &node.inputs[decl.name];
        let takes: Vec<&str> = accepts.kinds.iter().map(|k| k.name()).collect();
        let view_note = match (accepts.view, wrong_view) {
            (AcceptView::Sampler, true) => format!(
                "; it takes them {sampler_view} (the pipeline's shared sampler{}), and `{pnode}.{pport}` is rendered {}",
                v.factoring.as_ref().map_or(String::new(), |f| format!(", whose camera is `{}`'s", f.node)),
                terms.views().iter().map(View::to_string).collect::<Vec<_>>().join(" and ")
            ),
            _ => String::new(),
        };
        let what = if foreign.is_empty() {
            String::new()
        } else {
            format!(", which include {} that it does not take", foreign.join(", "))
        };
        out.push(Diagnostic {
            kind: DiagnosticKind::TermNotAccepted,
            location: node.location.clone(),
            message: format!(
                "input `{}` of node `{}` ({}) takes {} but `{pnode}.{pport}` holds {}{what}{view_note}",
                decl.name,
                node.name,
                node.kind.kind(),
                takes.join(" or "),
                terms.sum_label()
            ),
            help: accepts.fix.to_string(),
        });
    }
    out
}

/// A node's own direct light from an area light the scene does not have: refused with the node's
/// location before anything renders (the kernel's own check would stop the run at that pass — in a
/// bench suite, after the scenes before it had rendered).
fn check_lights_exist(node: &crate::ValidatedNode, terms: &Terms, facts: &crate::SceneFacts) -> Vec<Diagnostic> {
    let missing = terms.terms.iter().filter_map(|t| {
        let own_light = t.via.is_empty() && t.kind == TermKind::DirectArea;
        t.light.filter(|i| own_light && *i >= facts.area_lights)
    });
    missing
        .map(|i| Diagnostic {
            kind: DiagnosticKind::MissingLight,
            location: node.location.clone(),
            message: if facts.area_lights == 0 {
                format!(
                    "node `{}` ({}) renders area light {i}, but the scene has no area light (no emissive triangles)",
                    node.name,
                    node.kind.kind()
                )
            } else {
                format!(
                    "node `{}` ({}) renders area light {i}, but the scene has {} area light(s): 0..{}",
                    node.name,
                    node.kind.kind(),
                    facts.area_lights,
                    facts.area_lights - 1
                )
            },
            help:
                "add an emissive material to the scene (glTF emissiveFactor, MTL Ke, a `lights` entry in a .ron scene) \
                   or render one with that light (e.g. --scene grids), set the node's `light` to one the scene has, or \
                   leave the node out for a scene lit by its environment map alone"
                    .into(),
        })
        .collect()
}

/// An output that counts one term twice, or sums images of different camera models.
fn check_sum(node: &crate::ValidatedNode, terms: &Terms) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    let source = |t: &Term| {
        if t.via.is_empty() {
            format!("node `{}` itself", node.name)
        } else {
            let port = node
                .inputs
                .iter()
                .find(|(_, (n, p))| format!("{n}.{p}") == t.via)
                .map(|(port, _)| port.as_str())
                .unwrap_or("?");
            format!("input `{port}` = `{}`", t.via)
        }
    };
    let mut twice: Vec<String> = Vec::new();
    for (a, b) in terms.overlapping() {
        twice.push(format!(
            "{}: {} holds {} and {} holds {}",
            a.kind.name(),
            source(a),
            a.label(),
            source(b),
            b.label()
        ));
    }
    if !twice.is_empty() {
        out.push(Diagnostic {
            kind: DiagnosticKind::TermOverlap,
            location: node.location.clone(),
            message: format!("node `{}` ({}) counts light twice: {}", node.name, node.kind.kind(), twice.join("; ")),
            help: "each light must be counted once: remove one of the two producers, or have one leave the term out \
                   (e.g. do not wire `emission` into the node that already adds it; `emission: false` on Environment; \
                   a SoftShadows `light` per area light)"
                .into(),
        });
    }
    let views = terms.views();
    if views.len() > 1 {
        let by_view: Vec<String> = views
            .iter()
            .map(|w| {
                let from: Vec<String> = terms
                    .terms
                    .iter()
                    .filter(|t| t.view == *w)
                    .map(source)
                    .collect::<std::collections::BTreeSet<_>>()
                    .into_iter()
                    .collect();
                format!("{} {w}", from.join(", "))
            })
            .collect();
        out.push(Diagnostic {
            kind: DiagnosticKind::TermOverlap,
            location: node.location.clone(),
            message: format!("node `{}` ({}) sums images of different cameras: {}", node.name, node.kind.kind(), by_view.join("; ")),
            help: "sum images rendered through the same camera: wire components into the factoring node (Defocus, Motion) \
                   and read its output, instead of adding a pinhole image to a blurred one"
                .into(),
        });
    }
    out
}

/// Wired radiance inputs whose terms reach none of the node's outputs.
fn unread_inputs(
    v: &ValidatedPipeline,
    node: &crate::ValidatedNode,
    inputs: &BTreeMap<String, Terms>,
    own: &[(&'static str, Terms)],
) -> Vec<String> {
    if own.is_empty() {
        return Vec::new();
    }
    inputs
        .iter()
        .filter(|(_, t)| !t.terms.is_empty())
        .filter(|(port, _)| {
            let (n, p) = &node.inputs[port.as_str()];
            let reference = format!("{n}.{p}");
            !own.iter().any(|(_, o)| o.terms.iter().any(|t| t.via == reference) || o.undeclared.contains(&reference))
        })
        .map(|(port, t)| {
            // The node's image holds every kind of light the input carries, from its own paths (a
            // node that traces a camera its inputs were not rendered through).
            let own_kinds = |kind| own.iter().any(|(_, o)| o.terms.iter().any(|ot| ot.kind == kind && ot.via.is_empty()));
            let why = match &v.factoring {
                Some(f) => format!(
                    " while `{}` ({}) factors the pipeline: it renders `{}`'s component on the shared sampler and adds the emission seen directly once itself",
                    f.node, f.kind, node.name
                ),
                None if t.terms.iter().all(|it| own_kinds(it.kind)) => {
                    ": its image already holds that light, from its own camera paths".to_string()
                }
                None => String::new(),
            };
            format!("{}: input `{port}` of node `{}` ({}) is not added to its image{why}", node.location, node.name, t.sum_label())
        })
        .collect()
}

impl ValidatedPipeline {
    /// The images the sinks receive and the terms each holds, one line per image, then the notes
    /// (`wedge graph`).
    pub fn light_summary(&self) -> String {
        let mut s = String::from("light terms of the images:\n");
        for (sink, port, producer, terms) in &self.terms.images {
            s.push_str(&format!("    {sink}.{port} = {producer}: {terms}\n"));
        }
        for n in &self.terms.notes {
            s.push_str(&format!("note: {n}\n"));
        }
        s
    }

    /// Light the camera or the scene has that no term of an image covers: a lens or shutter the
    /// image is not rendered through, area lights or an environment no term holds (with `scene`,
    /// once one is loaded). One check per sink, on its first radiance input.
    pub fn light_warnings(&self, scene: Option<&crate::SceneFacts>) -> Vec<String> {
        let mut out = Vec::new();
        let mut sinks_seen: Vec<&str> = Vec::new();
        for (sink, port, producer, terms) in &self.terms.images {
            if sinks_seen.contains(&sink.as_str()) || !terms.undeclared.is_empty() || terms.terms.is_empty() {
                continue;
            }
            sinks_seen.push(sink);
            let image = format!("`{sink}.{port}` (= `{producer}`)");
            out.extend(self.camera_warnings(&image, terms, scene));
            if let Some(facts) = scene.filter(|_| !terms.is_occlusion()) {
                out.extend(uncovered_light(&image, terms, facts));
            }
        }
        out.extend(self.unread_factoring_node());
        out
    }

    /// A factoring node no other node reads: its components still render through its camera on the
    /// shared sampler, but its own image (their blurred sum, with the emission seen directly) is
    /// culled, so what reaches the sinks is components that are neither blurred nor complete.
    fn unread_factoring_node(&self) -> Option<String> {
        let f = self.factoring.as_ref()?;
        let read = self.nodes.iter().any(|n| n.inputs.values().any(|(from, _)| *from == f.node));
        let node = self.node(&f.node)?;
        let image =
            node.kind.outputs().first().map_or_else(|| "its image".to_string(), |o| format!("`{}.{}`", f.node, o.name));
        (!read).then(|| {
            format!(
                "{}: node `{}` ({}) factors the pipeline but no node reads its outputs: its components render through \
                 its camera, while its image (their blurred sum with the emission seen directly) is culled — take \
                 {image} to the Output",
                node.location, f.node, f.kind
            )
        })
    }

    fn camera_warnings(&self, image: &str, terms: &Terms, scene: Option<&crate::SceneFacts>) -> Vec<String> {
        let Some(camera) = &self.pipeline.camera else { return Vec::new() };
        let mut out = Vec::new();
        let views = terms.views();
        if camera.aperture_radius > 0.0 && views.iter().all(|w| !w.lens) {
            out.push(format!(
                "{}: the camera block's aperture_radius = {} is not sampled: {image} is rendered {} (no camera \
                 path renders it, e.g. a G-buffer image) — take the image of a node that traces camera rays, or \
                 set aperture_radius: 0",
                self.path.display(),
                camera.aperture_radius,
                View::PINHOLE
            ));
        }
        let moving = scene.is_none_or(|f| f.motion);
        if camera.shutter.is_some_and(|(open, close)| open < close) && moving && views.iter().all(|w| !w.shutter) {
            out.push(format!(
                "{}: the camera block's shutter is open over an interval, but {image} is rendered at the shutter's \
                 centre (no camera path renders it, e.g. a G-buffer image) — take the image of a node that traces \
                 camera rays, or give the shutter equal times",
                self.path.display()
            ));
        }
        out
    }
}

/// The scene's light that no term of `terms` covers, in words.
fn uncovered_light(image: &str, terms: &Terms, facts: &crate::SceneFacts) -> Vec<String> {
    let mut missing: Vec<String> = Vec::new();
    if facts.area_lights > 0 {
        match terms.area_lights() {
            None => {}
            Some(covered) if covered.is_empty() => {
                missing.push(format!("direct light from its {} area light(s)", facts.area_lights))
            }
            Some(covered) => {
                let rest: Vec<String> =
                    (0..facts.area_lights).filter(|i| !covered.contains(i)).map(|i| i.to_string()).collect();
                if !rest.is_empty() {
                    missing.push(format!(
                        "direct light from area light(s) {} (a SoftShadows node per light, summed with Add)",
                        rest.join(", ")
                    ));
                }
            }
        }
        if !terms.holds(TermKind::Emission) {
            missing.push("the emission of its lights seen directly (they show black)".into());
        }
    }
    if facts.environment && !terms.holds(TermKind::DirectEnvironment) && !terms.holds(TermKind::RealLayer) {
        missing.push("direct light from its environment map (an Environment node)".into());
    }
    if missing.is_empty() {
        return Vec::new();
    }
    vec![format!(
        "the scene has light that {image} does not hold: {}; the image holds {}",
        missing.join("; "),
        terms.sum_label()
    )]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(kind: TermKind) -> Term {
        Term::new(kind, View::PINHOLE)
    }

    #[test]
    fn area_lights_overlap_only_where_they_share_a_light() {
        assert!(!t(TermKind::DirectArea).light(0).overlaps(&t(TermKind::DirectArea).light(1)));
        assert!(t(TermKind::DirectArea).overlaps(&t(TermKind::DirectArea).light(1)), "every light covers light 1");
        assert!(!t(TermKind::Emission).overlaps(&t(TermKind::Background)));
        let sum =
            Terms::new().with(t(TermKind::Emission)).with(t(TermKind::DirectArea).light(0)).with(t(TermKind::Emission));
        assert_eq!(sum.overlapping().len(), 1);
    }

    #[test]
    fn a_sum_prints_in_display_order_with_its_view() {
        let lens = View { lens: true, shutter: false };
        let sum = Terms::new()
            .with(Term::new(TermKind::Indirect, lens).detail("1 bounce, diffuse+glossy"))
            .with(Term::new(TermKind::DirectArea, lens).light(0))
            .with(Term::new(TermKind::Emission, lens));
        assert_eq!(
            sum.to_string(),
            "emission + direct(area light 0) + indirect(1 bounce, diffuse+glossy), through the lens"
        );
        assert_eq!(sum.area_lights(), Some(vec![0]));
        let mixed = sum.clone().with(t(TermKind::Background));
        assert!(
            mixed.to_string().ends_with("mixed: through the lens / through a pinhole at the shutter's centre"),
            "{mixed}"
        );
    }
}
