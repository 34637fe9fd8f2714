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
//! - A component node that sees a factoring node samples through the shared sampler with the factoring
//!   node's settings and outputs its composed component (thesis eq. 5.32's term); the factoring node
//!   reads the components through the pipeline's wiring and filters the sum. The pipeline file states
//!   that wiring, so `wedge graph` shows it.

use std::collections::BTreeMap;

use crate::decl::ParamValue;

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
