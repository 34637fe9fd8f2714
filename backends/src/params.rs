//! Typed kernel parameters: one declaration per parameter (issue 36 §2).
//!
//! Before, a parameter was written four to six times: its [`ParamDecl`] on the node, the name in
//! the node's forwarding list, a string-keyed `ctx.f32_param("…")` in the kernel, again in its
//! `Uniforms`, and as `params.…` in the WGSL — and a kernel reading a parameter its pass does not
//! carry failed only when the pass ran. [`kernel_params!`] declares a typed struct once:
//!
//! ```ignore
//! wedge::backends::kernel_params! {
//!     /// Fog's parameters.
//!     pub struct FogParams {
//!         density: f32 = float(0.1, 0.0, 1e3, "extinction per metre"),
//!         colour: [f32; 3] = colour([0.5, 0.5, 0.5], 1e6, "fog radiance (linear RGB)"),
//!     }
//! }
//! ```
//!
//! and from it come ([`KernelParams`]): the node's declarations (`FogParams::decls()`: the
//! constructor after `=` is a [`ParamDecl`] constructor without the name, which is the field's),
//! the node-side forwarding (`.node_params(FogParams::names())`), the typed struct the CPU kernel
//! reads (`FogParams::read(ctx)?` — no string look-ups in the kernel), the WGSL parameter block
//! (`p.uniforms()`: the WGSL reads `params.density`, `params.colour`), and the signature the
//! schedule check compares every pass with (`Kernel::params` returning `FogParams::specs()`: a
//! missing or mistyped parameter is refused at `wedge graph` / session build, all at once, never
//! when the pass runs). A field without `= …` is a kernel parameter the node computes itself
//! (e.g. a width in pixels from a radius in metres) and sets with `.param(..)`: it is read, checked
//! and uploaded the same way, but not declared on the node.
//!
//! Field types ([`ParamField`]): `f32`, `u32`, `i32`, `bool` (a `u32` 0/1 in WGSL), `[f32; 3]`
//! (a colour or vector, `vec3<f32>`) and choices declared with [`param_choice!`] (a `u32` index in
//! WGSL, in the order of the options).

use wedge_graph::{ParamDecl, ParamValue};

use crate::kernel::{KernelCtx, Uniforms};
use crate::BackendError;

/// What a pass must carry for a parameter: the [`ParamValue`] kind a kernel reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamType {
    /// `Float` (an `Int` is accepted where a number is, as declarations accept it).
    Number,
    Integer,
    Bool,
    /// A name: a choice (or a file path).
    Text,
    Vec3,
}

impl ParamType {
    /// Whether a pass's value is of this type.
    pub fn accepts(self, v: &ParamValue) -> bool {
        matches!(
            (self, v),
            (ParamType::Number, ParamValue::Float(_) | ParamValue::Int(_))
                | (ParamType::Integer, ParamValue::Int(_))
                | (ParamType::Bool, ParamValue::Bool(_))
                | (ParamType::Text, ParamValue::Str(_))
                | (ParamType::Vec3, ParamValue::Vec3(_))
        )
    }
    /// As messages write it.
    pub fn describe(self) -> &'static str {
        match self {
            ParamType::Number => "a number",
            ParamType::Integer => "an integer",
            ParamType::Bool => "true or false",
            ParamType::Text => "a name",
            ParamType::Vec3 => "three numbers",
        }
    }
}

/// One parameter a kernel reads: its name and type (from [`KernelParams::specs`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParamSpec {
    pub name: &'static str,
    pub ty: ParamType,
    /// A pass may leave it out (an `Option<T>` field: the kernel's default applies).
    pub optional: bool,
}

/// A Rust type a kernel parameter can have: how it is read from a pass and uploaded to WGSL.
pub trait ParamField: Sized {
    const TYPE: ParamType;
    /// Whether a pass may leave the parameter out (`Option<T>`).
    const OPTIONAL: bool = false;
    fn read(ctx: &KernelCtx<'_>, name: &str) -> Result<Self, BackendError>;
    /// `u` with this value appended as the uniform field `name`.
    fn uniform(&self, u: Uniforms, name: &'static str) -> Uniforms;
}

/// A parameter a pass may leave out: `None` where it does (the kernel applies its default, written
/// once where it reads the field); a value present is checked as `T`'s. Its uniform is `T`'s where
/// present and nothing where absent, so a kernel with optional parameters builds the WGSL fields it
/// reads from the values it applies (e.g. `paths.trace`'s settings).
impl<T: ParamField> ParamField for Option<T> {
    const TYPE: ParamType = T::TYPE;
    const OPTIONAL: bool = true;
    fn read(ctx: &KernelCtx<'_>, name: &str) -> Result<Self, BackendError> {
        if ctx.params.contains_key(name) {
            T::read(ctx, name).map(Some)
        } else {
            Ok(None)
        }
    }
    fn uniform(&self, u: Uniforms, name: &'static str) -> Uniforms {
        match self {
            Some(v) => v.uniform(u, name),
            None => u,
        }
    }
}

impl ParamField for f32 {
    const TYPE: ParamType = ParamType::Number;
    fn read(ctx: &KernelCtx<'_>, name: &str) -> Result<Self, BackendError> {
        ctx.f32_param(name)
    }
    fn uniform(&self, u: Uniforms, name: &'static str) -> Uniforms {
        u.f32(name, *self)
    }
}

impl ParamField for u32 {
    const TYPE: ParamType = ParamType::Integer;
    fn read(ctx: &KernelCtx<'_>, name: &str) -> Result<Self, BackendError> {
        let v = ctx.int_param(name)?;
        u32::try_from(v).map_err(|_| ctx.err(format!("parameter `{name}` = {v} must be in 0..={}", u32::MAX)))
    }
    fn uniform(&self, u: Uniforms, name: &'static str) -> Uniforms {
        u.u32(name, *self)
    }
}

impl ParamField for i32 {
    const TYPE: ParamType = ParamType::Integer;
    fn read(ctx: &KernelCtx<'_>, name: &str) -> Result<Self, BackendError> {
        let v = ctx.int_param(name)?;
        i32::try_from(v)
            .map_err(|_| ctx.err(format!("parameter `{name}` = {v} must be in {}..={}", i32::MIN, i32::MAX)))
    }
    fn uniform(&self, u: Uniforms, name: &'static str) -> Uniforms {
        u.i32(name, *self)
    }
}

impl ParamField for bool {
    const TYPE: ParamType = ParamType::Bool;
    fn read(ctx: &KernelCtx<'_>, name: &str) -> Result<Self, BackendError> {
        ctx.bool_param(name)
    }
    fn uniform(&self, u: Uniforms, name: &'static str) -> Uniforms {
        u.bool(name, *self)
    }
}

crate::param_choice! {
    /// `sampling`, which every sampling kernel takes: Owen-scrambled Sobol' / correlated
    /// multi-jitter (`stratified`) or independent numbers for the same dimensions (`independent`,
    /// the plain Monte Carlo baseline). WGSL: `params.sampling`, 0 = stratified.
    pub enum Sampling { Stratified = "stratified", Independent = "independent" }
}

/// An area light's index (`light`), checked against the scene as it is read
/// ([`KernelCtx::light_param`]: a scene with no area light, or fewer than the index asks for, is
/// refused with the fix); a `u32` in WGSL.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightIndex(pub usize);

impl ParamField for LightIndex {
    const TYPE: ParamType = ParamType::Integer;
    fn read(ctx: &KernelCtx<'_>, name: &str) -> Result<Self, BackendError> {
        ctx.light_param(name).map(LightIndex)
    }
    fn uniform(&self, u: Uniforms, name: &'static str) -> Uniforms {
        u.u32(name, self.0 as u32)
    }
}

/// `light` where a negative value means every area light (`None`), as `direct.light` takes it;
/// an index is checked like [`LightIndex`]'s. An `i32` in WGSL, −1 for every light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AnyLight(pub Option<usize>);

impl ParamField for AnyLight {
    const TYPE: ParamType = ParamType::Integer;
    fn read(ctx: &KernelCtx<'_>, name: &str) -> Result<Self, BackendError> {
        if ctx.int_param(name)? < 0 {
            return Ok(AnyLight(None));
        }
        ctx.light_param(name).map(|i| AnyLight(Some(i)))
    }
    fn uniform(&self, u: Uniforms, name: &'static str) -> Uniforms {
        u.i32(name, self.0.map_or(-1, |i| i as i32))
    }
}

impl AnyLight {
    /// The lights it covers in a scene of `count` lights.
    pub fn lights(self, count: usize) -> Vec<usize> {
        self.0.map_or_else(|| (0..count).collect(), |i| vec![i])
    }
}

/// A thin lens's shape (`lens`: `disk` | `gaussian`); a `u32` in WGSL, 1 = Gaussian.
impl ParamField for wedge_scene::LensShape {
    const TYPE: ParamType = ParamType::Text;
    fn read(ctx: &KernelCtx<'_>, name: &str) -> Result<Self, BackendError> {
        let s = ctx.str_param(name)?;
        Self::parse(s).ok_or_else(|| ctx.err(format!("unknown {name} `{s}`; use disk or gaussian")))
    }
    fn uniform(&self, u: Uniforms, name: &'static str) -> Uniforms {
        u.u32(name, (*self == wedge_scene::LensShape::Gaussian) as u32)
    }
}

impl ParamField for [f32; 3] {
    const TYPE: ParamType = ParamType::Vec3;
    fn read(ctx: &KernelCtx<'_>, name: &str) -> Result<Self, BackendError> {
        ctx.vec3_param(name)
    }
    fn uniform(&self, u: Uniforms, name: &'static str) -> Uniforms {
        u.vec3(name, *self)
    }
}

/// A typed parameter block, declared once with [`kernel_params!`] (module doc).
pub trait KernelParams: Sized {
    /// Every field's name, in declaration order: `.node_params(P::names())` forwards them all where
    /// every field is a parameter of the node (declared here or elsewhere, e.g. a shared `mu`).
    fn names() -> &'static [&'static str];
    /// The fields the node declares (those written with `= constructor(..)`), for `NodeKind::params`.
    fn decls() -> Vec<ParamDecl>;
    /// Names and types, for `Kernel::params` (the schedule check).
    fn specs() -> Vec<ParamSpec>;
    /// The pass's values, typed.
    fn read(ctx: &KernelCtx<'_>) -> Result<Self, BackendError>;
    /// The WGSL parameter block: one field per parameter, named as declared.
    fn uniforms(&self) -> Uniforms;
}

/// Declare a typed parameter block once (see [`crate::params`]): a struct with `pub` fields and
/// its [`KernelParams`] implementation. A field `name: Type = ctor(args)` is also declared on the
/// node as `ParamDecl::ctor("name", args)` (any [`ParamDecl`] constructor, optionally followed by
/// `.or_special(..)` or other builder calls); a field without `= …` is set by the node's `expand`.
#[macro_export]
macro_rules! kernel_params {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $(
                $(#[$fmeta:meta])*
                $field:ident : $ty:ty $(= $ctor:ident ( $($arg:expr),* $(,)? ) $(. $then:ident ( $($targ:expr),* ))* )?
            ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Debug, PartialEq)]
        $vis struct $name {
            $($(#[$fmeta])* pub $field: $ty,)*
        }
        impl $crate::params::KernelParams for $name {
            fn names() -> &'static [&'static str] {
                &[$(stringify!($field)),*]
            }
            fn decls() -> Vec<$crate::__graph::ParamDecl> {
                vec![$($(
                    $crate::__graph::ParamDecl::$ctor(stringify!($field), $($arg),*) $(. $then ( $($targ),* ))*,
                )?)*]
            }
            fn specs() -> Vec<$crate::params::ParamSpec> {
                vec![$($crate::params::ParamSpec {
                    name: stringify!($field),
                    ty: <$ty as $crate::params::ParamField>::TYPE,
                    optional: <$ty as $crate::params::ParamField>::OPTIONAL,
                }),*]
            }
            fn read(ctx: &$crate::KernelCtx<'_>) -> Result<Self, $crate::BackendError> {
                Ok(Self { $($field: <$ty as $crate::params::ParamField>::read(ctx, stringify!($field))?,)* })
            }
            fn uniforms(&self) -> $crate::Uniforms {
                let u = $crate::Uniforms::new();
                $(let u = $crate::params::ParamField::uniform(&self.$field, u, stringify!($field));)*
                u
            }
        }
    };
}

/// Declare a choice parameter's values once: an enum whose variants are the options (as written in
/// a pipeline), with `OPTIONS` for the declaration (`ParamDecl::choice(.., Lobe::OPTIONS, ..)`) and
/// [`ParamField`] (read by name; a `u32` index in WGSL, in the order written).
#[macro_export]
macro_rules! param_choice {
    ($(#[$meta:meta])* $vis:vis enum $name:ident { $($(#[$vmeta:meta])* $variant:ident = $text:literal),+ $(,)? }) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        $vis enum $name {
            $($(#[$vmeta])* $variant),+
        }
        impl $name {
            /// The options as a pipeline writes them, in WGSL index order.
            pub const OPTIONS: &'static [&'static str] = &[$($text),+];
            /// The option's name.
            pub fn as_str(self) -> &'static str {
                match self { $($name::$variant => $text),+ }
            }
            /// The option named `s`, if any.
            pub fn parse(s: &str) -> Option<Self> {
                match s { $($text => Some($name::$variant),)+ _ => None }
            }
        }
        impl $crate::params::ParamField for $name {
            const TYPE: $crate::params::ParamType = $crate::params::ParamType::Text;
            fn read(ctx: &$crate::KernelCtx<'_>, name: &str) -> Result<Self, $crate::BackendError> {
                let s = ctx.str_param(name)?;
                Self::parse(s).ok_or_else(|| ctx.err(format!("`{name}` = {s:?} is not one of {:?}", Self::OPTIONS)))
            }
            fn uniform(&self, u: $crate::Uniforms, name: &'static str) -> $crate::Uniforms {
                u.u32(name, *self as u32)
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    param_choice! {
        /// A test choice.
        enum Shape { Disk = "disk", Square = "square" }
    }

    kernel_params! {
        /// A test block: two declared fields, one set by the node.
        struct Block {
            /// documented field
            density: f32 = float(0.1, 0.0, 1e3, "extinction per metre"),
            colour: [f32; 3] = colour([0.5, 0.5, 0.5], 1e6, "radiance"),
            shape: Shape = choice("disk", Shape::OPTIONS, "aperture"),
            b_e: f32 = float(-1.0, 0.0, 1e4, "bandwidth").or_special(-1.0, "automatic"),
            radius_px: u32,
        }
    }

    #[test]
    fn one_declaration_gives_names_decls_specs_and_the_wgsl_block() {
        assert_eq!(Block::names(), ["density", "colour", "shape", "b_e", "radius_px"]);
        let decls = Block::decls();
        assert_eq!(decls.iter().map(|d| d.name).collect::<Vec<_>>(), ["density", "colour", "shape", "b_e"]);
        assert!(decls[3].check(&ParamValue::Float(-1.0)).is_ok(), "the builder call after the constructor applies");
        let types: Vec<ParamType> = Block::specs().iter().map(|s| s.ty).collect();
        assert_eq!(types, [ParamType::Number, ParamType::Vec3, ParamType::Text, ParamType::Number, ParamType::Integer]);
        let b = Block { density: 0.5, colour: [1.0, 2.0, 3.0], shape: Shape::Square, b_e: 2.0, radius_px: 7 };
        let s = b.uniforms().wgsl_struct().unwrap();
        assert!(
            s.contains("density: f32,\n    colour: vec3<f32>,\n    shape: u32,\n    b_e: f32,\n    radius_px: u32,"),
            "{s}"
        );
        assert_eq!(Shape::parse("square"), Some(Shape::Square));
        assert_eq!(Shape::Disk.as_str(), "disk");
        assert!(ParamType::Number.accepts(&ParamValue::Int(3)) && !ParamType::Integer.accepts(&ParamValue::Float(3.0)));
    }
}
