//! What a node kind declares about itself (Falcor's `reflect()`): its input and output ports with
//! their buffer formats, and its typed parameters with ranges. The validator checks a pipeline
//! against these declarations before anything runs, and reports every problem at once.

use std::fmt;
use std::sync::Arc;

use crate::expand::ExpandCtx;
use crate::GraphError;

/// Per-pixel element format of a buffer. Buffers are full-resolution per-pixel arrays; on the CPU a
/// `Vec` of the element type, on the GPU a storage buffer of the same layout (vec3 padded to 16 bytes
/// there, which the GPU backend handles).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Format {
    F32,
    Vec2,
    Vec3,
    Vec4,
    U32,
}

impl Format {
    /// Number of 32-bit components per element.
    pub fn components(self) -> usize {
        match self {
            Format::F32 | Format::U32 => 1,
            Format::Vec2 => 2,
            Format::Vec3 => 3,
            Format::Vec4 => 4,
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Format::F32 => "f32",
            Format::Vec2 => "vec2<f32>",
            Format::Vec3 => "vec3<f32>",
            Format::Vec4 => "vec4<f32>",
            Format::U32 => "u32",
        })
    }
}

/// One input or output port of a node kind.
#[derive(Clone, Debug)]
pub struct PortDecl {
    pub name: &'static str,
    pub format: Format,
    /// An input that may be left unconnected (outputs ignore this).
    pub optional: bool,
    pub doc: &'static str,
}

impl PortDecl {
    pub const fn new(name: &'static str, format: Format, doc: &'static str) -> Self {
        PortDecl {
            name,
            format,
            optional: false,
            doc,
        }
    }
    pub const fn optional(name: &'static str, format: Format, doc: &'static str) -> Self {
        PortDecl {
            name,
            format,
            optional: true,
            doc,
        }
    }
}

/// A parameter value as written in a pipeline, after type checking.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    Float(f64),
    Int(i64),
    Bool(bool),
    Str(String),
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamValue::Float(v) => write!(f, "{v}"),
            ParamValue::Int(v) => write!(f, "{v}"),
            ParamValue::Bool(v) => write!(f, "{v}"),
            ParamValue::Str(v) => write!(f, "{v:?}"),
        }
    }
}

/// The type and admissible range of a parameter.
#[derive(Clone, Debug)]
pub enum ParamKind {
    /// A real number in `min..=max`, or `min < x` when `min_exclusive` (e.g. `mu > 0`).
    Float {
        default: f64,
        min: f64,
        max: f64,
        min_exclusive: bool,
    },
    /// An integer in `min..=max`.
    Int {
        default: i64,
        min: i64,
        max: i64,
    },
    Bool {
        default: bool,
    },
    /// One of a fixed set of names.
    Choice {
        default: &'static str,
        options: &'static [&'static str],
    },
}

#[derive(Clone, Debug)]
pub struct ParamDecl {
    pub name: &'static str,
    pub kind: ParamKind,
    pub doc: &'static str,
}

impl ParamDecl {
    pub const fn float(
        name: &'static str,
        default: f64,
        min: f64,
        max: f64,
        doc: &'static str,
    ) -> Self {
        ParamDecl {
            name,
            kind: ParamKind::Float {
                default,
                min,
                max,
                min_exclusive: false,
            },
            doc,
        }
    }
    /// A float that must be strictly greater than `min` (e.g. `mu`, where 0 means an infinitely wide filter).
    pub const fn positive(name: &'static str, default: f64, max: f64, doc: &'static str) -> Self {
        ParamDecl {
            name,
            kind: ParamKind::Float {
                default,
                min: 0.0,
                max,
                min_exclusive: true,
            },
            doc,
        }
    }
    pub const fn int(
        name: &'static str,
        default: i64,
        min: i64,
        max: i64,
        doc: &'static str,
    ) -> Self {
        ParamDecl {
            name,
            kind: ParamKind::Int { default, min, max },
            doc,
        }
    }
    pub const fn boolean(name: &'static str, default: bool, doc: &'static str) -> Self {
        ParamDecl {
            name,
            kind: ParamKind::Bool { default },
            doc,
        }
    }
    pub const fn choice(
        name: &'static str,
        default: &'static str,
        options: &'static [&'static str],
        doc: &'static str,
    ) -> Self {
        ParamDecl {
            name,
            kind: ParamKind::Choice { default, options },
            doc,
        }
    }

    pub fn default_value(&self) -> ParamValue {
        match &self.kind {
            ParamKind::Float { default, .. } => ParamValue::Float(*default),
            ParamKind::Int { default, .. } => ParamValue::Int(*default),
            ParamKind::Bool { default } => ParamValue::Bool(*default),
            ParamKind::Choice { default, .. } => ParamValue::Str((*default).to_string()),
        }
    }

    /// Type-check and range-check a written value; integers are accepted where a float is declared.
    /// The error string says what is allowed, so it can be shown to the user as the fix.
    pub fn check(&self, value: &ParamValue) -> Result<ParamValue, String> {
        match (&self.kind, value) {
            (
                ParamKind::Float {
                    min,
                    max,
                    min_exclusive,
                    ..
                },
                ParamValue::Float(_) | ParamValue::Int(_),
            ) => {
                let v = match value {
                    ParamValue::Float(v) => *v,
                    ParamValue::Int(v) => *v as f64,
                    _ => unreachable!(),
                };
                let low_ok = if *min_exclusive { v > *min } else { v >= *min };
                if !v.is_finite() || !low_ok || v > *max {
                    let lo = if *min_exclusive {
                        format!("{min} < {}", self.name)
                    } else {
                        format!("{min} <= {}", self.name)
                    };
                    return Err(format!(
                        "{} = {v} is out of range; it must satisfy {lo} <= {max}",
                        self.name
                    ));
                }
                Ok(ParamValue::Float(v))
            }
            (ParamKind::Int { min, max, .. }, ParamValue::Int(v)) => {
                if v < min || v > max {
                    return Err(format!(
                        "{} = {v} is out of range; it must satisfy {min} <= {} <= {max}",
                        self.name, self.name
                    ));
                }
                Ok(ParamValue::Int(*v))
            }
            (ParamKind::Bool { .. }, ParamValue::Bool(v)) => Ok(ParamValue::Bool(*v)),
            (ParamKind::Choice { options, .. }, ParamValue::Str(s)) => {
                if options.contains(&s.as_str()) {
                    Ok(ParamValue::Str(s.clone()))
                } else {
                    Err(format!("{} = {s:?} is not one of {options:?}", self.name))
                }
            }
            (kind, v) => Err(format!(
                "{} = {v} has the wrong type; expected {}",
                self.name,
                kind_name(kind)
            )),
        }
    }
}

fn kind_name(kind: &ParamKind) -> &'static str {
    match kind {
        ParamKind::Float { .. } => "a number",
        ParamKind::Int { .. } => "an integer",
        ParamKind::Bool { .. } => "true or false",
        ParamKind::Choice { .. } => "a string",
    }
}

/// A node kind: an effect (SoftShadows, Indirect, …), a producer of per-pixel surface data (Primary),
/// or a sink (Output). Implemented inside wedge and by user crates alike, and registered by name.
pub trait NodeKind: Send + Sync {
    /// The name written as `kind: "…"` in a pipeline.
    fn kind(&self) -> &'static str;
    fn doc(&self) -> &'static str {
        ""
    }
    fn inputs(&self) -> Vec<PortDecl>;
    fn outputs(&self) -> Vec<PortDecl>;
    fn params(&self) -> Vec<ParamDecl>;
    /// Sinks are the roots of culling: a pass survives only if some sink input depends on it.
    fn is_sink(&self) -> bool {
        false
    }
    /// Turn one validated node instance into passes, binding every declared output port.
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError>;
}

/// Node kinds by name. wedge registers its own; a user crate adds more before loading a pipeline.
#[derive(Clone, Default)]
pub struct NodeRegistry {
    kinds: Vec<Arc<dyn NodeKind>>,
}

impl NodeRegistry {
    pub fn new() -> Self {
        Self::default()
    }
    /// Register a kind; a later registration under the same name replaces the earlier one, so a
    /// user crate can override a built-in node.
    pub fn register(&mut self, kind: Arc<dyn NodeKind>) -> &mut Self {
        self.kinds.retain(|k| k.kind() != kind.kind());
        self.kinds.push(kind);
        self
    }
    pub fn get(&self, name: &str) -> Option<&Arc<dyn NodeKind>> {
        self.kinds.iter().find(|k| k.kind() == name)
    }
    pub fn names(&self) -> Vec<&'static str> {
        self.kinds.iter().map(|k| k.kind()).collect()
    }
}
