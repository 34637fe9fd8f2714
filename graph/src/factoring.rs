//! Factoring nodes: one node of a pipeline may take over the filtering of the lighting components the
//! other nodes sample (thesis Ch. 5, `seeds/000_956e982470d7e5bf.txt` Sec. 5.5–5.8; App. B next).
//!
//! Why this exists: with defocus (or motion) blur the components cannot be filtered on their own. Ch. 5
//! couples them — every component's filter width has the lens term `Ω_u^max / r_min` (eqs. 5.18,
//! 5.22), every count has the lens factor `(1 + r_max Ω)²` (5.25–5.28), each component is factored
//! into texture × irradiance (5.9–5.14, 5.30), and the composed image is filtered once more in screen
//! space (5.33). A component node (SoftShadows, Indirect) therefore renders differently when such a
//! node is present, and the node that blurs the image must run after every component.
//!
//! The mechanism, general and declared, not a check of node kinds:
//! - A kind says it factors through [`crate::NodeKind::factoring`], given its validated parameters and
//!   the pipeline's camera block. It returns the [`Settings`] the component nodes read (e.g. `mu`,
//!   `mode`, `factor`), `Ok(None)` when, with these parameters, it does not factor (a Defocus node
//!   with `aperture_radius = 0` is a pinhole: the pipeline renders as without it), or a [`Refusal`]
//!   the validator reports at the node's position (e.g. no lens given anywhere).
//! - The validator allows one factoring node per pipeline (two are reported at the second, naming the
//!   first) and hands it to every node's expansion: [`crate::ExpandCtx::factoring`].
//! - A component node that sees a factoring node declares its lighting [`Component`] (estimator,
//!   statistics, factored parts) and hands it to [`crate::ExpandCtx::component`], which calls the
//!   factoring node's [`crate::NodeKind::expand_component`]: the factoring node's own file decides
//!   which passes render the component (Ch. 5's lens terms for Defocus, App. B's velocity terms for
//!   Motion), so a component node names no factoring kind. The component's node outputs the composed
//!   component (eq. 5.32's term); the factoring node reads the components through the pipeline's
//!   wiring and filters the sum. The pipeline file states that wiring, so `wedge graph` shows it.
//! - **Camera settings.** A factoring node whose paths sample the lens states it as the settings
//!   `aperture_radius`, `focus_distance` (world units) and `lens` (`disk` | `gaussian`); one whose
//!   paths sample the shutter states `time = true`. A node that traces its own camera rays instead of
//!   reading the shared sampler (LightField) reads them through [`CameraSettings`], so every
//!   component of a pipeline sees one lens and one shutter, without naming the factoring kind.
//! - A kind's decision may depend on the scene ([`FactoringInputs::scene`]): a Motion node on a
//!   static scene does not factor, so the pipeline renders as without it.

use std::collections::BTreeMap;

use crate::decl::ParamValue;

/// What a factoring decision may know besides the node's own parameters: the pipeline's camera
/// block, and — once a session has loaded it — facts about the scene (`None` where no scene is loaded,
/// e.g. `wedge graph`: a node then decides as if the scene could need it).
#[derive(Clone, Copy, Debug, Default)]
pub struct FactoringInputs<'a> {
    pub camera: Option<&'a crate::pipeline::CameraSpec>,
    pub scene: Option<SceneFacts>,
}

/// The facts about a loaded scene that factoring decisions read (graph knows no scenes: the session
/// fills these in).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneFacts {
    /// Some object or light moves over the shutter (a non-empty shutter and a motion that is not
    /// the identity).
    pub motion: bool,
    /// Its area lights (emissive triangle groups), by index.
    pub area_lights: u32,
    /// It is lit by an environment map.
    pub environment: bool,
}

/// One factored part of a lighting component: the names of its `L`, `k`, `E` among the shared
/// sampler's resolved outputs (thesis eqs. 5.9–5.14 direct, 5.21 indirect).
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    pub name: &'static str,
    pub radiance: &'static str,
    pub texture: &'static str,
    pub irradiance: &'static str,
}

/// A lighting component as a component node declares it to the factoring node
/// ([`crate::ExpandCtx::component`]): the factoring node (Defocus, Motion, …) decides which passes
/// render it — the component node only says what it samples and which statistics describe it.
#[derive(Clone, Debug, PartialEq)]
pub struct Component {
    /// `direct` or `indirect`: which of the factoring node's widths and counts apply (the light's
    /// occluder term, or the reflector-depth term).
    pub name: &'static str,
    /// The sampler estimator its secondary samples come from (`light`, `hemisphere`), and the
    /// sampler settings that define it (`light`; `bounces`, `brdf`).
    pub estimator: &'static str,
    pub settings: Vec<(&'static str, ParamValue)>,
    /// The first-pass statistic its rates read: (binding name, where it comes from), e.g.
    /// (`occlusion`, the sampler's `occlusion`), (`reflectors`, the sampler's `depth`) or
    /// (`bandlimit`, a buffer the component node computed from the first pass: Environment's Ch. 6
    /// bandwidth).
    pub statistic: (&'static str, Statistic),
    /// Extra rate parameters (`light` for the light's half-width; `omega_v` for a transfer bandlimit).
    pub rate_params: Vec<(&'static str, ParamValue)>,
    /// Its parts; the first one's factoring flag selects the count.
    pub parts: Vec<Part>,
    /// The component node's own cap on its irradiance filter's half-width in pixels (`None`: the
    /// factoring node's `max_radius` alone): [`Component::irradiance_radius`].
    pub max_radius: Option<i64>,
}

/// Where a component's first-pass statistic comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum Statistic {
    /// A first-pass output of the shared sampler, by name.
    Sampler(&'static str),
    /// A buffer the component node's own passes computed (from first-pass outputs).
    Buffer(crate::BufferId),
}

impl Component {
    /// The half-width cap of the component's irradiance filter: the factoring node's (`factoring`,
    /// its `max_radius`) or the component's own where that is smaller. The factoring node's other
    /// filters (its texture, along a velocity or through the lens) keep its own.
    pub fn irradiance_radius(&self, factoring: &ParamValue) -> ParamValue {
        match (self.max_radius, factoring) {
            (Some(own), ParamValue::Int(f)) if own < *f => ParamValue::Int(own),
            _ => factoring.clone(),
        }
    }
    /// The buffer holding the component's first-pass statistic.
    pub fn statistic(&self, ctx: &mut crate::ExpandCtx<'_>) -> Result<crate::BufferId, crate::GraphError> {
        match &self.statistic.1 {
            Statistic::Sampler(output) => ctx.sampler_output(crate::SamplerPass::First, output),
            Statistic::Buffer(id) => Ok(*id),
        }
    }
}

/// Settings a factoring node hands to the component nodes (names are the factoring node's contract:
/// its module documents them).
pub type Settings = BTreeMap<String, ParamValue>;

/// The pipeline's factoring node and its settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Factoring {
    /// The factoring node's name.
    pub node: String,
    /// Its kind (for messages).
    pub kind: String,
    pub settings: Settings,
}

impl Factoring {
    pub fn setting(&self, name: &str) -> Option<&ParamValue> {
        self.settings.get(name)
    }
    /// A number setting (an integer is accepted).
    pub fn float(&self, name: &str) -> Option<f64> {
        self.settings.get(name)?.as_f64()
    }
    pub fn bool(&self, name: &str) -> Option<bool> {
        self.settings.get(name)?.as_bool()
    }
}

/// Why a node's configuration cannot factor: what is wrong and the fix, as the validator prints them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Refusal {
    pub message: String,
    pub help: String,
}

/// The camera a pipeline's paths sample, from its factoring node's camera settings (module doc): a
/// thin lens where it states an aperture, each path at its own shutter time where it states `time`.
/// No factoring node, or one that states neither: a pinhole at the shutter's centre.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CameraSettings {
    /// `aperture_radius`, `focus_distance`, `lens` as the factoring node states them.
    pub lens: Vec<(&'static str, ParamValue)>,
    /// Paths sample the shutter.
    pub time: bool,
}

impl CameraSettings {
    /// The lens settings' names.
    pub const LENS: [&'static str; 3] = ["aperture_radius", "focus_distance", "lens"];
    /// The shutter setting's name.
    pub const TIME: &'static str = "time";

    pub fn of(factoring: Option<&Factoring>) -> CameraSettings {
        let Some(f) = factoring else {
            return CameraSettings::default();
        };
        CameraSettings {
            lens: Self::LENS.into_iter().filter_map(|n| f.setting(n).map(|v| (n, v.clone()))).collect(),
            time: f.bool(Self::TIME).unwrap_or(false),
        }
    }

    /// The camera of a node that traces its own camera paths and renders a component under a
    /// factoring node (LightField): the factoring node's camera where one factors, else the
    /// pipeline's `camera:` block — its lens where it gives an aperture, its shutter where it opens
    /// one over an interval and the scene moves (or is not known yet) — so such a node is never
    /// silently a pinhole (issue 34 §2). [`crate::TermQuery::own_view`] states the same camera.
    pub fn own_paths(
        factoring: Option<&Factoring>,
        camera: Option<&crate::pipeline::CameraSpec>,
        scene: Option<&SceneFacts>,
    ) -> CameraSettings {
        if factoring.is_some() {
            return Self::of(factoring);
        }
        Self::of_block(camera, scene)
    }

    /// The pipeline's `camera:` block as camera settings: its lens where it gives an aperture, its
    /// shutter where it opens one over an interval and the scene moves (or is not known yet); a
    /// pinhole at one instant without a block. PixelFilter and RadianceFilter trace this camera
    /// ([`crate::TermQuery::camera_view`]).
    pub fn of_block(camera: Option<&crate::pipeline::CameraSpec>, scene: Option<&SceneFacts>) -> CameraSettings {
        let Some(c) = camera else {
            return CameraSettings::default();
        };
        let mut lens = Vec::new();
        if c.aperture_radius > 0.0 {
            lens.push(("aperture_radius", ParamValue::Float(f64::from(c.aperture_radius))));
            if let Some(f) = c.focus_distance {
                lens.push(("focus_distance", ParamValue::Float(f64::from(f))));
            }
        }
        let open = c.shutter.is_some_and(|(open, close)| open < close);
        CameraSettings { lens, time: open && scene.is_none_or(|f| f.motion) }
    }

    /// No factoring node, and the camera block samples a lens or a shutter: nothing filters those
    /// dimensions, so the nodes whose own filters assume a pinhole render the plain Monte Carlo image
    /// through the block (Defocus and Motion are the filters of the lens and shutter, not the only
    /// way to have them: docs/ARCHITECTURE.md "The camera"). One rule for expansion
    /// ([`crate::ExpandCtx::plain_camera`]) and terms ([`crate::TermQuery::plain_camera`]).
    pub fn unfiltered(
        factoring: Option<&Factoring>,
        camera: Option<&crate::pipeline::CameraSpec>,
        scene: Option<&SceneFacts>,
    ) -> bool {
        factoring.is_none() && !Self::of_block(camera, scene).fixed()
    }

    /// Every path of a pixel has the same camera ray: no aperture (or a zero one) and no time.
    pub fn fixed(&self) -> bool {
        !self.time && self.aperture().is_none_or(|a| a == 0.0)
    }

    /// The stated `aperture_radius`, if any.
    pub fn aperture(&self) -> Option<f64> {
        self.lens.iter().find(|(n, _)| *n == "aperture_radius").and_then(|(_, v)| v.as_f64())
    }

    /// As pass parameters: the lens settings, `aperture_radius` 0 where none is stated (a pinhole,
    /// whatever the scene camera's aperture: a pipeline states its lens), and `time`.
    pub fn params(&self) -> Vec<(&'static str, ParamValue)> {
        let mut p = self.lens.clone();
        if !p.iter().any(|(n, _)| *n == "aperture_radius") {
            p.push(("aperture_radius", ParamValue::Float(0.0)));
        }
        p.push((Self::TIME, ParamValue::Bool(self.time)));
        p
    }
}
