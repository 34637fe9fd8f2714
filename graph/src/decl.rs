//! What a node kind declares about itself (Falcor's `reflect()`): its input and output ports with
//! their buffer formats, and its typed parameters with ranges. The validator checks a pipeline
//! against these declarations before anything runs, and reports every problem at once.

use std::fmt;
use std::sync::Arc;

use crate::expand::ExpandCtx;
use crate::GraphError;

/// Per-pixel element format of a buffer. Buffers are full-resolution per-pixel arrays; on the CPU a
/// `Vec` of the element type, on the GPU a storage buffer of the same bytes (vec3 stored as 3 packed
/// floats on both; the GPU backend's generated accessors rebuild the `vec3<f32>`).
///
/// [`Format::Struct`] is a named per-pixel record of 32-bit words with named, typed fields (see
/// [`StructLayout`]): kernels that keep many statistics per pixel (the path sampler's L, k, E per
/// component, lens and occluder ranges, counts) declare them as one typed record instead of several
/// vec4 buffers packed by convention. Two struct formats are equal when their names and field lists
/// are equal, so the validator and `KernelRegistry::check_schedule` compare layouts, not pointers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Format {
    F32,
    Vec2,
    Vec3,
    Vec4,
    U32,
    Struct(&'static StructLayout),
}

/// Type of one field of a [`StructLayout`]: 1–4 words, f32 components or one u32.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum FieldType {
    F32,
    U32,
    Vec2,
    Vec3,
    Vec4,
}

impl FieldType {
    /// Number of 32-bit words the field takes (no padding: vec3 is 3 words).
    pub const fn words(self) -> usize {
        match self {
            FieldType::F32 | FieldType::U32 => 1,
            FieldType::Vec2 => 2,
            FieldType::Vec3 => 3,
            FieldType::Vec4 => 4,
        }
    }
    /// The WGSL type of the field's value.
    pub const fn wgsl(self) -> &'static str {
        match self {
            FieldType::F32 => "f32",
            FieldType::U32 => "u32",
            FieldType::Vec2 => "vec2<f32>",
            FieldType::Vec3 => "vec3<f32>",
            FieldType::Vec4 => "vec4<f32>",
        }
    }
}

/// One named field of a [`StructLayout`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Field {
    pub name: &'static str,
    pub ty: FieldType,
}

impl Field {
    pub const fn new(name: &'static str, ty: FieldType) -> Self {
        Field { name, ty }
    }
}

/// A named per-pixel record: fields laid out in order, each at the word offset where the previous
/// one ended (no alignment padding, so a `vec3` field is 3 words and the field after it starts at
/// the next word). The same words are the CPU's `Vec<u32>` and the GPU's storage, so the layout is
/// one declaration for both; a Rust `#[repr(C)]` struct of `f32`/`u32`/`[f32; N]` fields in the same
/// order has exactly this layout (checked by `wedge_backends::buffer::Record`).
#[derive(Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct StructLayout {
    /// The WGSL struct name (a WGSL identifier) and the name shown in errors.
    pub name: &'static str,
    pub fields: &'static [Field],
}

impl StructLayout {
    /// Words per element.
    pub const fn words(&self) -> usize {
        let mut n = 0;
        let mut k = 0;
        while k < self.fields.len() {
            n += self.fields[k].ty.words();
            k += 1;
        }
        n
    }
    /// The field called `name`, with its word offset.
    pub fn field(&self, name: &str) -> Option<(usize, Field)> {
        let mut offset = 0;
        for f in self.fields {
            if f.name == name {
                return Some((offset, *f));
            }
            offset += f.ty.words();
        }
        None
    }
    /// Every field with its word offset, in order.
    pub fn offsets(&self) -> impl Iterator<Item = (usize, Field)> + '_ {
        self.fields.iter().scan(0usize, |at, f| {
            let o = *at;
            *at += f.ty.words();
            Some((o, *f))
        })
    }
    /// Name of word `w` of an element (`field` or `field.x`), for parity tables and heatmaps.
    pub fn word_name(&self, w: usize) -> Option<String> {
        for (o, f) in self.offsets() {
            if (o..o + f.ty.words()).contains(&w) {
                return Some(if f.ty.words() == 1 {
                    f.name.to_string()
                } else {
                    format!("{}.{}", f.name, ["x", "y", "z", "w"][w - o])
                });
            }
        }
        None
    }
    /// What is wrong with the layout, if anything: field and struct names must be WGSL identifiers
    /// (the GPU backend generates a WGSL struct from it), field names unique, at least one field.
    pub fn problems(&self) -> Vec<String> {
        let ident = |s: &str| {
            s.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
                && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                && !s.contains("__")
        };
        let mut out = Vec::new();
        if !ident(self.name) {
            out.push(format!("struct name `{}` is not a WGSL identifier", self.name));
        }
        if self.fields.is_empty() {
            out.push(format!("struct `{}` has no fields", self.name));
        }
        for (k, f) in self.fields.iter().enumerate() {
            if !ident(f.name) {
                out.push(format!("struct `{}`: field `{}` is not a WGSL identifier", self.name, f.name));
            }
            if self.fields[..k].iter().any(|g| g.name == f.name) {
                out.push(format!("struct `{}`: field `{}` appears twice", self.name, f.name));
            }
        }
        out
    }
    /// The first difference between two layouts, in words (for error messages).
    pub fn difference(&self, other: &StructLayout) -> Option<String> {
        if self.name != other.name {
            return Some(format!("struct `{}` is not struct `{}`", self.name, other.name));
        }
        let n = self.fields.len().max(other.fields.len());
        for k in 0..n {
            match (self.fields.get(k), other.fields.get(k)) {
                (Some(a), Some(b)) if a == b => {}
                (Some(a), Some(b)) => {
                    return Some(format!(
                        "struct `{}` field {k} is `{}: {}` here but `{}: {}` there",
                        self.name,
                        a.name,
                        a.ty.wgsl(),
                        b.name,
                        b.ty.wgsl()
                    ))
                }
                (Some(a), None) => return Some(format!("struct `{}` has an extra field `{}` here", self.name, a.name)),
                (None, Some(b)) => return Some(format!("struct `{}` lacks field `{}` here", self.name, b.name)),
                (None, None) => {}
            }
        }
        None
    }
}

impl Format {
    /// Number of 32-bit components (words) per element.
    pub fn components(self) -> usize {
        match self {
            Format::F32 | Format::U32 => 1,
            Format::Vec2 => 2,
            Format::Vec3 => 3,
            Format::Vec4 => 4,
            Format::Struct(s) => s.words(),
        }
    }
    /// The record layout of a struct format.
    pub fn layout(self) -> Option<&'static StructLayout> {
        match self {
            Format::Struct(s) => Some(s),
            _ => None,
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Format::F32 => f.write_str("f32"),
            Format::Vec2 => f.write_str("vec2<f32>"),
            Format::Vec3 => f.write_str("vec3<f32>"),
            Format::Vec4 => f.write_str("vec4<f32>"),
            Format::U32 => f.write_str("u32"),
            Format::Struct(s) => write!(f, "struct {} ({} words)", s.name, s.words()),
        }
    }
}

#[cfg(test)]
mod struct_tests {
    use super::*;

    static A: StructLayout = StructLayout {
        name: "Rec",
        fields: &[Field::new("l", FieldType::Vec3), Field::new("n", FieldType::U32), Field::new("uv", FieldType::Vec2)],
    };
    static A_COPY: StructLayout = StructLayout {
        name: "Rec",
        fields: &[Field::new("l", FieldType::Vec3), Field::new("n", FieldType::U32), Field::new("uv", FieldType::Vec2)],
    };
    static B: StructLayout = StructLayout {
        name: "Rec",
        fields: &[Field::new("l", FieldType::Vec3), Field::new("n", FieldType::F32), Field::new("uv", FieldType::Vec2)],
    };

    #[test]
    fn layout_packs_vec3_without_padding() {
        assert_eq!(A.words(), 6);
        assert_eq!(Format::Struct(&A).components(), 6);
        assert_eq!(A.field("n"), Some((3, Field::new("n", FieldType::U32))));
        assert_eq!(A.field("uv").unwrap().0, 4);
        assert_eq!(A.field("missing"), None);
        assert_eq!(A.word_name(2).as_deref(), Some("l.z"));
        assert_eq!(A.word_name(3).as_deref(), Some("n"));
        assert_eq!(A.word_name(5).as_deref(), Some("uv.y"));
        assert_eq!(A.word_name(6), None);
        assert!(A.problems().is_empty());
    }

    #[test]
    fn struct_formats_compare_by_name_and_fields() {
        assert_eq!(Format::Struct(&A), Format::Struct(&A_COPY), "equal layouts in two statics are one format");
        assert_ne!(Format::Struct(&A), Format::Struct(&B));
        assert_ne!(Format::Struct(&A), Format::Vec4);
        assert_eq!(A.difference(&A_COPY), None);
        assert_eq!(A.difference(&B).unwrap(), "struct `Rec` field 1 is `n: u32` here but `n: f32` there");
        assert_eq!(Format::Struct(&A).to_string(), "struct Rec (6 words)");
    }

    #[test]
    fn bad_layouts_are_named() {
        static BAD: StructLayout = StructLayout {
            name: "my rec",
            fields: &[
                Field::new("a", FieldType::F32),
                Field::new("a", FieldType::U32),
                Field::new("b-c", FieldType::F32),
            ],
        };
        let p = BAD.problems();
        assert_eq!(p.len(), 3, "{p:?}");
        assert!(p[0].contains("`my rec`") && p[1].contains("`a` appears twice") && p[2].contains("`b-c`"), "{p:?}");
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
    /// For a radiance input: the light terms it takes ([`crate::terms`]); `None`: not checked.
    pub accepts: Option<crate::terms::Accepts>,
}

impl PortDecl {
    pub const fn new(name: &'static str, format: Format, doc: &'static str) -> Self {
        PortDecl { name, format, optional: false, doc, accepts: None }
    }
    pub const fn optional(name: &'static str, format: Format, doc: &'static str) -> Self {
        PortDecl { name, format, optional: true, doc, accepts: None }
    }
    /// The same input, taking only radiance of these terms ([`crate::terms::Accepts`]).
    pub const fn accepts(mut self, accepts: crate::terms::Accepts) -> Self {
        self.accepts = Some(accepts);
        self
    }
}

/// A parameter value as written in a pipeline, after type checking.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    Float(f64),
    Int(i64),
    Bool(bool),
    Str(String),
    /// Three numbers: a colour (linear RGB) or a vector, written `(r, g, b)` in RON and `r,g,b` in
    /// `--set`.
    Vec3([f64; 3]),
}

impl ParamValue {
    /// The number it holds (an integer is accepted where a number is), else `None`.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            ParamValue::Float(v) => Some(*v),
            ParamValue::Int(v) => Some(*v as f64),
            _ => None,
        }
    }
    pub fn as_bool(&self) -> Option<bool> {
        match self {
            ParamValue::Bool(v) => Some(*v),
            _ => None,
        }
    }
    /// The text it holds (a choice), else `None`.
    pub fn as_str(&self) -> Option<&str> {
        match self {
            ParamValue::Str(v) => Some(v),
            _ => None,
        }
    }
    /// Three numbers (a [`ParamKind::Vec3`] value), else `None`.
    pub fn as_vec3(&self) -> Option<[f64; 3]> {
        match self {
            ParamValue::Vec3(v) => Some(*v),
            _ => None,
        }
    }
    /// An integer as a count, clamped to `[1, u32::MAX]` (a validated parameter's range is inside
    /// it), else `None`.
    pub fn as_count(&self) -> Option<u32> {
        match self {
            ParamValue::Int(v) => Some((*v).clamp(1, i64::from(u32::MAX)) as u32),
            _ => None,
        }
    }
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamValue::Float(v) => write!(f, "{v}"),
            ParamValue::Int(v) => write!(f, "{v}"),
            ParamValue::Bool(v) => write!(f, "{v}"),
            ParamValue::Str(v) => write!(f, "{v:?}"),
            ParamValue::Vec3([a, b, c]) => write!(f, "({a}, {b}, {c})"),
        }
    }
}

/// The type and admissible range of a parameter.
#[derive(Clone, Debug)]
pub enum ParamKind {
    /// A real number in `min..=max`, or `min < x` when `min_exclusive` (e.g. `mu > 0`); or, where
    /// `special` is given, exactly that value, which means something other than a number of the range
    /// (e.g. `b_e = -1`: "the map's own bandwidth"), see [`ParamDecl::or_special`].
    Float {
        default: f64,
        min: f64,
        max: f64,
        min_exclusive: bool,
        special: Option<Special>,
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
    /// A file, relative to the pipeline file (or `builtin:NAME` for a resource generated in code);
    /// `""` = none. The node passes it on in a [`SceneRequest`]; whoever loads the scene resolves and
    /// reads it, and reports a file it cannot read at the parameter's position.
    Path {
        default: &'static str,
    },
    /// Three numbers, each in `min..=max`: a colour (linear RGB, [`ParamDecl::colour`]) or a
    /// vector. One declaration, one value — not three `_r`/`_g`/`_b` parameters.
    Vec3 {
        default: [f64; 3],
        min: f64,
        max: f64,
        /// Shown as a colour (the window's colour picker) rather than three numbers.
        colour: bool,
    },
}

/// A value outside a float parameter's range that the parameter accepts with a meaning of its own
/// (a sentinel such as `-1` = automatic), and that meaning, for messages and documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Special {
    pub value: f64,
    pub meaning: &'static str,
}

#[derive(Clone, Debug)]
pub struct ParamDecl {
    pub name: &'static str,
    pub kind: ParamKind,
    pub doc: &'static str,
    /// Optional: absent unless the pipeline writes it (no default is filled in; the node finds it, or
    /// not, in its parameter map and decides, e.g. a Defocus node's `aperture_radius` falls back to the
    /// pipeline's camera block). See [`ParamDecl::optional`].
    pub optional: bool,
}

impl ParamDecl {
    pub const fn float(name: &'static str, default: f64, min: f64, max: f64, doc: &'static str) -> Self {
        ParamDecl {
            name,
            kind: ParamKind::Float { default, min, max, min_exclusive: false, special: None },
            doc,
            optional: false,
        }
    }
    /// A float that must be strictly greater than `min` (e.g. `mu`, where 0 means an infinitely wide filter).
    pub const fn positive(name: &'static str, default: f64, max: f64, doc: &'static str) -> Self {
        ParamDecl {
            name,
            kind: ParamKind::Float { default, min: 0.0, max, min_exclusive: true, special: None },
            doc,
            optional: false,
        }
    }
    pub const fn int(name: &'static str, default: i64, min: i64, max: i64, doc: &'static str) -> Self {
        ParamDecl { name, kind: ParamKind::Int { default, min, max }, doc, optional: false }
    }
    pub const fn boolean(name: &'static str, default: bool, doc: &'static str) -> Self {
        ParamDecl { name, kind: ParamKind::Bool { default }, doc, optional: false }
    }
    pub const fn choice(
        name: &'static str,
        default: &'static str,
        options: &'static [&'static str],
        doc: &'static str,
    ) -> Self {
        ParamDecl { name, kind: ParamKind::Choice { default, options }, doc, optional: false }
    }

    /// A file path (see [`ParamKind::Path`]).
    /// Three numbers, each in `min..=max` (a direction, an offset, a scale per axis).
    pub const fn vec3(name: &'static str, default: [f64; 3], min: f64, max: f64, doc: &'static str) -> Self {
        ParamDecl { name, kind: ParamKind::Vec3 { default, min, max, colour: false }, doc, optional: false }
    }

    /// A linear RGB colour: three non-negative numbers (radiance or albedo; `max` bounds each
    /// channel, e.g. 1 for an albedo). Kernels read it with `KernelCtx::vec3_param`.
    pub const fn colour(name: &'static str, default: [f64; 3], max: f64, doc: &'static str) -> Self {
        ParamDecl { name, kind: ParamKind::Vec3 { default, min: 0.0, max, colour: true }, doc, optional: false }
    }

    pub const fn path(name: &'static str, default: &'static str, doc: &'static str) -> Self {
        ParamDecl { name, kind: ParamKind::Path { default }, doc, optional: false }
    }

    /// The same float declaration, also accepting exactly `value` (outside the range) with the meaning
    /// `meaning`: e.g. `ParamDecl::float("b_e", -1.0, 0.0, 1e4, …).or_special(-1.0, "the map's own
    /// bandwidth")` accepts -1 and 0 ≤ b_e ≤ 1e4, and refuses -0.5 saying so. (Other kinds: unchanged.)
    pub const fn or_special(mut self, value: f64, meaning: &'static str) -> Self {
        if let ParamKind::Float { special, .. } = &mut self.kind {
            *special = Some(Special { value, meaning });
        }
        self
    }

    /// The same declaration, but optional: no default is filled in when the pipeline leaves it out
    /// (the declared default is only what documentation shows as the typical value).
    pub const fn optional(mut self) -> Self {
        self.optional = true;
        self
    }

    pub fn default_value(&self) -> ParamValue {
        match &self.kind {
            ParamKind::Float { default, .. } => ParamValue::Float(*default),
            ParamKind::Int { default, .. } => ParamValue::Int(*default),
            ParamKind::Bool { default } => ParamValue::Bool(*default),
            ParamKind::Choice { default, .. } | ParamKind::Path { default } => ParamValue::Str((*default).to_string()),
            ParamKind::Vec3 { default, .. } => ParamValue::Vec3(*default),
        }
    }

    /// Type-check and range-check a written value; integers are accepted where a float is declared.
    /// The error string says what is allowed, so it can be shown to the user as the fix.
    pub fn check(&self, value: &ParamValue) -> Result<ParamValue, String> {
        match (&self.kind, value) {
            (ParamKind::Float { min, max, min_exclusive, special, .. }, ParamValue::Float(_) | ParamValue::Int(_)) => {
                let v = match value {
                    ParamValue::Float(v) => *v,
                    ParamValue::Int(v) => *v as f64,
                    _ => unreachable!(),
                };
                if special.is_some_and(|s| s.value == v) {
                    return Ok(ParamValue::Float(v));
                }
                let low_ok = if *min_exclusive { v > *min } else { v >= *min };
                if !v.is_finite() || !low_ok || v > *max {
                    let lo = if *min_exclusive {
                        format!("{min} < {}", self.name)
                    } else {
                        format!("{min} <= {}", self.name)
                    };
                    let or = special.map_or(String::new(), |s| format!("be {} ({}) or ", s.value, s.meaning));
                    return Err(format!(
                        "{} = {} is out of range; it must {or}satisfy {lo} <= {max}",
                        self.name,
                        as_written(v)
                    ));
                }
                check_single_precision(self.name, v, *min, *min_exclusive, *max)?;
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
            // A whole number beyond i64 (`--set n=99999999999999999999999` is read as a float) is
            // out of every integer range, not of the wrong type.
            (ParamKind::Int { min, max, .. }, ParamValue::Float(v)) if v.fract() == 0.0 && v.abs() >= 2f64.powi(63) => {
                Err(format!("{} = {v:e} is out of range; it must satisfy {min} <= {} <= {max}", self.name, self.name))
            }
            (ParamKind::Bool { .. }, ParamValue::Bool(v)) => Ok(ParamValue::Bool(*v)),
            (ParamKind::Choice { options, .. }, ParamValue::Str(s)) => {
                if options.contains(&s.as_str()) {
                    Ok(ParamValue::Str(s.clone()))
                } else {
                    Err(format!("{} = {s:?} is not one of {options:?}", self.name))
                }
            }
            (ParamKind::Path { .. }, ParamValue::Str(s)) => {
                if s.contains('\0') {
                    Err(format!("{} contains a NUL character, which no file name can", self.name))
                } else {
                    Ok(ParamValue::Str(s.clone()))
                }
            }
            (ParamKind::Vec3 { min, max, .. }, ParamValue::Vec3(v)) => {
                for (c, x) in ["first", "second", "third"].iter().zip(v) {
                    if !x.is_finite() || x < min || x > max {
                        return Err(format!(
                            "{} = {value}: its {c} number {} is out of range; each must satisfy {min} <= x <= {max}",
                            self.name,
                            as_written(*x)
                        ));
                    }
                    check_single_precision(self.name, *x, *min, false, *max)?;
                }
                Ok(ParamValue::Vec3(*v))
            }
            (kind, v) => Err(format!("{} = {v} has the wrong type; expected {}", self.name, kind_name(kind))),
        }
    }
}

/// Kernels compute in single precision (f32, on the CPU and the GPU alike), so a value that is
/// fine as written (f64) must also survive the conversion: one that becomes infinite, 0 or subnormal
/// (GPUs flush subnormals to 0) would fail at run time as "= 0", or silently mean something else
/// (`max_distance` 1e-300 would become 0 = "no limit"). Refused here, where the message can point
/// at the parameter.
fn check_single_precision(name: &str, v: f64, min: f64, min_exclusive: bool, max: f64) -> Result<(), String> {
    let single = v as f32;
    if single.is_infinite() {
        return Err(format!(
            "{name} = {} is beyond single precision (|x| <= {:e}), which the kernels compute in",
            as_written(v),
            f32::MAX
        ));
    }
    if v != 0.0 && !single.is_normal() {
        let zero_allowed = (if min_exclusive { min < 0.0 } else { min <= 0.0 }) && max >= 0.0;
        let fix = if zero_allowed { "write 0, or a value" } else { "write a value" };
        return Err(format!(
            "{name} = {} is {} in single precision (f32), which the kernels compute in; {fix} of magnitude at least {:e}",
            as_written(v),
            if single == 0.0 { "0" } else { "subnormal (flushed to 0 on GPUs)" },
            f32::MIN_POSITIVE
        ));
    }
    Ok(())
}

/// A number as a user would write it: plain where that is short, else in exponent form (`1e-300`,
/// not three hundred zeros).
fn as_written(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e15).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

fn kind_name(kind: &ParamKind) -> String {
    match kind {
        ParamKind::Float { .. } => "a number".into(),
        ParamKind::Int { .. } => "an integer".into(),
        ParamKind::Bool { .. } => "true or false".into(),
        // The options themselves: the fix for a choice written as a bool (`adaptive: true`) or a number.
        ParamKind::Choice { options, .. } => {
            format!("one of {}", options.iter().map(|o| format!("{o:?}")).collect::<Vec<_>>().join(", "))
        }
        ParamKind::Path { .. } => "a file path string".into(),
        ParamKind::Vec3 { colour: true, .. } => "a colour, three numbers `(r, g, b)`".into(),
        ParamKind::Vec3 { .. } => "three numbers `(x, y, z)`".into(),
    }
}

/// What a node asks of the scene before the graph is built (graph knows no scenes: the session loads
/// and applies it, and refuses two nodes that ask for different things).
#[derive(Clone, Debug, PartialEq)]
pub enum SceneRequest {
    /// Light the scene with an environment map (thesis Ch. 6): `map` a file relative to the pipeline
    /// file or `builtin:NAME` (`""`: the scene's own map), its radiance times `scale`, turned by
    /// `rotation_deg` about +Y. `param` names the parameter that gave `map`, for error positions.
    Environment { map: String, scale: f64, rotation_deg: f64, param: &'static str },
    /// Attach a captured real world for mixed reality (thesis Ch. 6.3–6.5): the camera image, world
    /// position and normal maps and the diffuse albedo (`albedo_map`, or the grey `albedo` where
    /// that is `""`), files relative to the pipeline file — or, where `capture` names a scene
    /// (`builtin:NAME` or a file), maps rendered from that scene by the pipeline's camera, its camera
    /// image plain Monte Carlo at `capture_spp` samples per pixel (an example whose "real" input is
    /// itself rendered).
    RealLayer {
        camera_image: String,
        position_map: String,
        normal_map: String,
        albedo_map: String,
        albedo: f64,
        capture: String,
        capture_spp: i64,
    },
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
    /// What this node (with these validated parameters) asks of the scene before the graph is built
    /// — e.g. an environment map to light it ([`SceneRequest`]). Default: nothing.
    fn scene_requests(&self, _params: &std::collections::BTreeMap<String, ParamValue>) -> Vec<SceneRequest> {
        Vec::new()
    }
    /// The light terms output `port` holds ([`crate::terms`]), given this node's parameters, the
    /// terms of its wired inputs and the pipeline's factoring node; `None`: not a radiance output
    /// (the default for every port: a kind that declares nothing is carried as "undeclared terms").
    fn terms(&self, _port: &str, _q: &crate::terms::TermQuery<'_>) -> Option<crate::terms::Terms> {
        None
    }
    /// Sinks are the roots of culling: a pass survives only if some sink input depends on it.
    fn is_sink(&self) -> bool {
        false
    }
    /// The scene suite `wedge bench --suite` measures a pipeline with this node on (issue 35:
    /// `"defocus"`, `"motion"`, …; the names of `wedge_scene::builtin::SuiteFamily`); `None` (the
    /// default): the node leaves the choice to the others, and a pipeline where every node does is
    /// measured on the soft-shadow suite.
    fn bench_suite(&self) -> Option<&'static str> {
        None
    }
    /// Whether this node, with these (validated) parameters and the pipeline's camera block, is the
    /// pipeline's **factoring node** ([`crate::factoring`]): it takes over the filtering of every
    /// lighting component the other nodes sample (thesis Ch. 5's Defocus; App. B's Motion), and
    /// the settings it returns are what those nodes read through [`ExpandCtx::factoring`].
    /// `Ok(None)` (the default): not a factoring node. `Err`: the configuration cannot work; the
    /// validator reports it at the node's position with the refusal's fix. `inputs` carries the
    /// pipeline's camera block and, once a scene is loaded, facts about it.
    fn factoring(
        &self,
        _params: &std::collections::BTreeMap<String, ParamValue>,
        _inputs: &crate::factoring::FactoringInputs<'_>,
    ) -> Result<Option<crate::factoring::Settings>, crate::factoring::Refusal> {
        Ok(None)
    }
    /// As the pipeline's factoring node: add the passes that render lighting component `component`
    /// for it, in the expansion of the component's node (`ctx.node()`), and bind that node's ports
    /// (`radiance`: the composed component, `unfiltered`, `filter_width`, `rays_per_pixel`).
    /// Component nodes reach it through [`ExpandCtx::component`]. The default refuses: a kind that
    /// returns settings from [`NodeKind::factoring`] implements this.
    fn expand_component(
        &self,
        ctx: &mut ExpandCtx<'_>,
        factoring: &crate::factoring::Factoring,
        component: &crate::factoring::Component,
    ) -> Result<(), GraphError> {
        Err(GraphError::Expand {
            node: ctx.node().to_string(),
            message: format!(
                "the factoring node `{}` ({}) does not render lighting components (its kind implements no \
                 expand_component), so component `{}` cannot be rendered for it",
                factoring.node, factoring.kind, component.name
            ),
        })
    }
    /// Where this node, with these parameters, averages its own earlier frames pixel by pixel
    /// (through [`ExpandCtx::previous_frame`], without following the camera): what it accumulates,
    /// in words. Such an average over a camera that moves mixes different views, so a sequence over
    /// a moving `camera_path` is warned about ([`crate::ValidatedPipeline::sequence_warnings`]).
    /// Default: `None` (no history, or one reprojected to the current view).
    fn accumulates_frames(&self, _params: &std::collections::BTreeMap<String, ParamValue>) -> Option<&'static str> {
        None
    }
    /// Turn one validated node instance into passes, binding every declared output port.
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError>;
}

/// Node kinds by name. wedge registers its own; a user crate adds more before loading a pipeline.
#[derive(Clone, Default)]
pub struct NodeRegistry {
    kinds: Vec<Arc<dyn NodeKind>>,
    sampler: Option<Arc<dyn crate::sampler::SamplerKind>>,
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
    /// Register the shared sampler nodes ask for in `expand` ([`crate::sampler`]); a later one
    /// replaces an earlier one.
    pub fn register_sampler(&mut self, sampler: Arc<dyn crate::sampler::SamplerKind>) -> &mut Self {
        self.sampler = Some(sampler);
        self
    }
    pub fn sampler(&self) -> Option<&Arc<dyn crate::sampler::SamplerKind>> {
        self.sampler.as_ref()
    }
    pub fn names(&self) -> Vec<&'static str> {
        self.kinds.iter().map(|k| k.kind()).collect()
    }
}

#[cfg(test)]
mod param_tests {
    use super::*;

    #[test]
    fn a_special_value_is_the_only_one_outside_the_range() {
        let b_e = ParamDecl::float("b_e", -1.0, 0.0, 1e4, "bandwidth").or_special(-1.0, "automatic");
        assert!(matches!(b_e.check(&ParamValue::Float(-1.0)), Ok(ParamValue::Float(v)) if v == -1.0));
        assert!(matches!(b_e.check(&ParamValue::Int(-1)), Ok(ParamValue::Float(v)) if v == -1.0));
        assert!(b_e.check(&ParamValue::Float(0.0)).is_ok());
        assert_eq!(
            b_e.check(&ParamValue::Float(-0.5)).unwrap_err(),
            "b_e = -0.5 is out of range; it must be -1 (automatic) or satisfy 0 <= b_e <= 10000"
        );
    }

    #[test]
    fn values_single_precision_cannot_hold_are_refused_as_written() {
        let scale = ParamDecl::positive("scale", 1.0, 1e9, "radiance scale");
        assert_eq!(
            scale.check(&ParamValue::Float(1e-300)).unwrap_err(),
            "scale = 1e-300 is 0 in single precision (f32), which the kernels compute in; write a value of magnitude at least 1.1754944e-38"
        );
        assert!(scale
            .check(&ParamValue::Float(1e-39))
            .unwrap_err()
            .starts_with("scale = 1e-39 is subnormal (flushed to 0 on GPUs)"));
        assert!(scale.check(&ParamValue::Float(1e-30)).is_ok());
        // Where 0 is in the range, writing 0 is offered as the fix.
        let dist = ParamDecl::float("max_distance", 0.0, 0.0, 1e300, "0 = no limit");
        assert!(dist.check(&ParamValue::Float(1e-300)).unwrap_err().contains("write 0, or a value of magnitude"));
        assert_eq!(
            dist.check(&ParamValue::Float(1e39)).unwrap_err(),
            "max_distance = 1e39 is beyond single precision (|x| <= 3.4028235e38), which the kernels compute in"
        );
        assert!(dist.check(&ParamValue::Float(0.0)).is_ok());
    }
}
