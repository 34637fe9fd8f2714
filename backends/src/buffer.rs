//! Per-pixel buffers as the CPU backend holds them, and typed access to them.
//!
//! Struct formats ([`Format::Struct`]) are held as their raw words (`BufferData::Words`, the same
//! bytes the GPU stores) and read either field by field by name ([`BufferData::field`],
//! [`BufferData::component`]) or as a `#[repr(C)]` Rust struct implementing [`Record`], whose size
//! is checked against the layout, through the same `KernelCtx::read` / `put` as plain formats.

use wedge_graph::{FieldType, Format, StructLayout};

/// A per-pixel array in one of the graph's [`Format`]s.
#[derive(Clone, Debug, PartialEq)]
pub enum BufferData {
    F32(Vec<f32>),
    Vec2(Vec<[f32; 2]>),
    Vec3(Vec<[f32; 3]>),
    Vec4(Vec<[f32; 4]>),
    U32(Vec<u32>),
    /// A struct format: `layout.words()` words per pixel, fields in layout order (f32 fields as
    /// their bits).
    Words {
        layout: &'static StructLayout,
        data: Vec<u32>,
    },
}

impl BufferData {
    pub fn zeroed(format: Format, len: usize) -> Self {
        match format {
            Format::F32 => BufferData::F32(vec![0.0; len]),
            Format::Vec2 => BufferData::Vec2(vec![[0.0; 2]; len]),
            Format::Vec3 => BufferData::Vec3(vec![[0.0; 3]; len]),
            Format::Vec4 => BufferData::Vec4(vec![[0.0; 4]; len]),
            Format::U32 => BufferData::U32(vec![0; len]),
            Format::Struct(layout) => BufferData::Words { layout, data: vec![0; len * layout.words()] },
        }
    }
    pub fn format(&self) -> Format {
        match self {
            BufferData::F32(_) => Format::F32,
            BufferData::Vec2(_) => Format::Vec2,
            BufferData::Vec3(_) => Format::Vec3,
            BufferData::Vec4(_) => Format::Vec4,
            BufferData::U32(_) => Format::U32,
            BufferData::Words { layout, .. } => Format::Struct(layout),
        }
    }
    pub fn len(&self) -> usize {
        match self {
            BufferData::F32(v) => v.len(),
            BufferData::Vec2(v) => v.len(),
            BufferData::Vec3(v) => v.len(),
            BufferData::Vec4(v) => v.len(),
            BufferData::U32(v) => v.len(),
            BufferData::Words { layout, data } => data.len() / layout.words().max(1),
        }
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Component `c` of element `i` as f32 (u32 converted), for comparisons and heatmaps. For a
    /// struct, component `c` is word `c` of the record, read as its field's type.
    pub fn component(&self, i: usize, c: usize) -> f32 {
        match self {
            BufferData::F32(v) => v[i],
            BufferData::Vec2(v) => v[i][c],
            BufferData::Vec3(v) => v[i][c],
            BufferData::Vec4(v) => v[i][c],
            BufferData::U32(v) => v[i] as f32,
            BufferData::Words { layout, data } => {
                let word = data[i * layout.words() + c];
                let is_u32 = layout.offsets().any(|(o, f)| o == c && f.ty == FieldType::U32);
                if is_u32 {
                    word as f32
                } else {
                    f32::from_bits(word)
                }
            }
        }
    }
    /// One field of a struct buffer as a plain per-pixel buffer (`F32`, `U32`, `Vec2/3/4`), for
    /// parity (compared field by field), heatmaps and tests. `None` for a plain buffer or an unknown name.
    pub fn field(&self, name: &str) -> Option<BufferData> {
        let BufferData::Words { layout, data } = self else {
            return None;
        };
        let (offset, field) = layout.field(name)?;
        let stride = layout.words();
        let words = data.chunks_exact(stride).map(|r| &r[offset..offset + field.ty.words()]);
        let f = |w: &[u32], k: usize| f32::from_bits(w[k]);
        Some(match field.ty {
            FieldType::F32 => BufferData::F32(words.map(|w| f(w, 0)).collect()),
            FieldType::U32 => BufferData::U32(words.map(|w| w[0]).collect()),
            FieldType::Vec2 => BufferData::Vec2(words.map(|w| [f(w, 0), f(w, 1)]).collect()),
            FieldType::Vec3 => BufferData::Vec3(words.map(|w| [f(w, 0), f(w, 1), f(w, 2)]).collect()),
            FieldType::Vec4 => BufferData::Vec4(words.map(|w| [f(w, 0), f(w, 1), f(w, 2), f(w, 3)]).collect()),
        })
    }
    /// The buffer's bytes as the GPU stores them (vec3 packed, structs as their words).
    pub fn as_bytes(&self) -> &[u8] {
        match self {
            BufferData::F32(v) => bytemuck::cast_slice(v),
            BufferData::Vec2(v) => bytemuck::cast_slice(v),
            BufferData::Vec3(v) => bytemuck::cast_slice(v),
            BufferData::Vec4(v) => bytemuck::cast_slice(v),
            BufferData::U32(v) => bytemuck::cast_slice(v),
            BufferData::Words { data, .. } => bytemuck::cast_slice(data),
        }
    }
    /// A buffer of `format` from its bytes (the inverse of [`BufferData::as_bytes`]).
    pub fn from_bytes(format: Format, bytes: &[u8]) -> BufferData {
        match format {
            Format::F32 => BufferData::F32(bytemuck::pod_collect_to_vec(bytes)),
            Format::Vec2 => BufferData::Vec2(bytemuck::pod_collect_to_vec(bytes)),
            Format::Vec3 => BufferData::Vec3(bytemuck::pod_collect_to_vec(bytes)),
            Format::Vec4 => BufferData::Vec4(bytemuck::pod_collect_to_vec(bytes)),
            Format::U32 => BufferData::U32(bytemuck::pod_collect_to_vec(bytes)),
            Format::Struct(layout) => BufferData::Words { layout, data: bytemuck::pod_collect_to_vec(bytes) },
        }
    }
    /// The buffer as one f32 per pixel (first component), for heatmaps.
    pub fn to_scalar(&self) -> Vec<f32> {
        (0..self.len()).map(|i| self.component(i, 0)).collect()
    }
}

/// An element type a kernel can view a buffer as; the format is checked at run time against the
/// declaration, so a kernel asking for the wrong type gets an error, not garbage.
pub trait Texel: Copy + Send + Sync + Default + 'static {
    const FORMAT: Format;
    fn slice(b: &BufferData) -> Option<&[Self]>;
    fn wrap(v: Vec<Self>) -> BufferData;
    fn unwrap(b: BufferData) -> Result<Vec<Self>, BufferData>;
    /// `len` zero elements (every texel's default is its zero bits).
    fn zeroed(len: usize) -> Vec<Self> {
        vec![Self::default(); len]
    }
}

macro_rules! texel {
    ($t:ty, $variant:ident) => {
        impl Texel for $t {
            const FORMAT: Format = Format::$variant;
            fn slice(b: &BufferData) -> Option<&[Self]> {
                match b {
                    BufferData::$variant(v) => Some(v),
                    _ => None,
                }
            }
            fn wrap(v: Vec<Self>) -> BufferData {
                BufferData::$variant(v)
            }
            fn unwrap(b: BufferData) -> Result<Vec<Self>, BufferData> {
                match b {
                    BufferData::$variant(v) => Ok(v),
                    other => Err(other),
                }
            }
        }
    };
}
texel!(f32, F32);
texel!([f32; 2], Vec2);
texel!([f32; 3], Vec3);
texel!([f32; 4], Vec4);
texel!(u32, U32);

/// A Rust view of a struct format: a `#[repr(C)]`, `Pod` struct whose fields are `f32`, `u32` or
/// `[f32; N]` in the order and of the types of [`Record::LAYOUT`]. Implementing it makes the type a
/// [`Texel`], so kernels `ctx.read::<R>(…)` and `ctx.put(…, Vec<R>)` records like any element type.
/// The size is checked against the layout when a buffer is viewed ([`record_matches`]), so a struct
/// that drifted from its layout gives an error, not shifted fields; field order and types are the
/// implementer's promise (keep the layout next to the struct, as `kernels::paths` does).
pub trait Record: bytemuck::Pod + Default + Send + Sync + 'static {
    const LAYOUT: &'static StructLayout;
}

/// Declare a record struct and its [`StructLayout`] from one field list, so the Rust view and the
/// layout the GPU and parity read can never drift apart:
///
/// ```ignore
/// wedge_backends::record! {
///     /// Doc of the struct.
///     pub struct LightSplat / LIGHT_SPLAT {
///         centre: vec3,
///         radius: f32,
///         flags: u32,
///     }
/// }
/// ```
///
/// makes `#[repr(C)] pub struct LightSplat { pub centre: [f32; 3], pub radius: f32, pub flags: u32 }`
/// (`Pod`, `Default`, …; a user crate needs `bytemuck` with `derive`), `pub static LIGHT_SPLAT:
/// StructLayout` named `"LightSplat"` with the same fields, and `impl Record for LightSplat`. Field
/// types: `f32`, `u32`, `vec2`, `vec3`, `vec4`.
#[macro_export]
macro_rules! record {
    ($(#[$meta:meta])* pub struct $name:ident / $layout:ident { $($(#[$fmeta:meta])* $field:ident : $ty:ident),* $(,)? }) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name {
            $($(#[$fmeta])* pub $field: $crate::record!(@rust $ty)),*
        }
        #[doc = concat!("The layout of [`", stringify!($name), "`].")]
        pub static $layout: $crate::__graph::StructLayout = $crate::__graph::StructLayout {
            name: stringify!($name),
            fields: &[$($crate::__graph::Field::new(stringify!($field), $crate::record!(@field $ty))),*],
        };
        impl $crate::buffer::Record for $name {
            const LAYOUT: &'static $crate::__graph::StructLayout = &$layout;
        }
    };
    (@rust f32) => { f32 };
    (@rust u32) => { u32 };
    (@rust vec2) => { [f32; 2] };
    (@rust vec3) => { [f32; 3] };
    (@rust vec4) => { [f32; 4] };
    (@field f32) => { $crate::__graph::FieldType::F32 };
    (@field u32) => { $crate::__graph::FieldType::U32 };
    (@field vec2) => { $crate::__graph::FieldType::Vec2 };
    (@field vec3) => { $crate::__graph::FieldType::Vec3 };
    (@field vec4) => { $crate::__graph::FieldType::Vec4 };
}

/// Whether `R`'s size is the layout's words.
pub fn record_matches<R: Record>() -> bool {
    std::mem::size_of::<R>() == 4 * R::LAYOUT.words() && std::mem::align_of::<R>() <= 4
}

impl<R: Record> Texel for R {
    const FORMAT: Format = Format::Struct(R::LAYOUT);
    fn slice(b: &BufferData) -> Option<&[Self]> {
        match b {
            BufferData::Words { layout, data } if *layout == R::LAYOUT && record_matches::<R>() => {
                Some(bytemuck::cast_slice(data))
            }
            _ => None,
        }
    }
    fn wrap(v: Vec<Self>) -> BufferData {
        BufferData::Words { layout: R::LAYOUT, data: recast(v) }
    }
    fn unwrap(b: BufferData) -> Result<Vec<Self>, BufferData> {
        match b {
            BufferData::Words { layout, data } if layout == R::LAYOUT && record_matches::<R>() => Ok(recast(data)),
            other => Err(other),
        }
    }
    /// From the allocator's zeroed pages: `vec![R::default(); n]` wrote every byte of ~130 MB of
    /// path records before `paths.trace` wrote them again (the plain formats' `vec!` already asks
    /// the allocator for zeroed memory).
    fn zeroed(len: usize) -> Vec<Self> {
        bytemuck::zeroed_vec(len)
    }
}

/// A vector of records as its words, or back: the same allocation handed over where its length and
/// capacity are whole elements of the other type (every buffer the backends make: `zeroed`'s, a
/// kernel's `Vec<R>`), else copied. The sampler's path records are ~130 MB at 640×480; copying them
/// into words after each `paths.trace` (and back for the next) was ~12% of a one-thread render.
fn recast<A: bytemuck::Pod, B: bytemuck::Pod>(v: Vec<A>) -> Vec<B> {
    bytemuck::allocation::try_cast_vec(v).unwrap_or_else(|(_, v)| bytemuck::pod_collect_to_vec(&v))
}

/// Filling a buffer in place (the CPU backend's persistent pool, issue 38 §2).
impl BufferData {
    /// Copy `from`'s contents into this buffer's storage. Panics if the formats or lengths differ
    /// (callers check both: it is a pool invariant, not user input).
    pub fn copy_from(&mut self, from: &BufferData) {
        assert!(self.format() == from.format() && self.len() == from.len(), "copy_from between different buffers");
        match (self, from) {
            (BufferData::F32(a), BufferData::F32(b)) => a.copy_from_slice(b),
            (BufferData::Vec2(a), BufferData::Vec2(b)) => a.copy_from_slice(b),
            (BufferData::Vec3(a), BufferData::Vec3(b)) => a.copy_from_slice(b),
            (BufferData::Vec4(a), BufferData::Vec4(b)) => a.copy_from_slice(b),
            (BufferData::U32(a), BufferData::U32(b)) => a.copy_from_slice(b),
            (BufferData::Words { data: a, .. }, BufferData::Words { data: b, .. }) => a.copy_from_slice(b),
            _ => unreachable!("formats checked above"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wedge_graph::Field;

    static LAYOUT: StructLayout = StructLayout {
        name: "Sample",
        fields: &[
            Field::new("l", FieldType::Vec3),
            Field::new("count", FieldType::U32),
            Field::new("r", FieldType::Vec2),
        ],
    };

    #[repr(C)]
    #[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
    struct Sample {
        l: [f32; 3],
        count: u32,
        r: [f32; 2],
    }
    impl Record for Sample {
        const LAYOUT: &'static StructLayout = &LAYOUT;
    }

    #[test]
    fn records_round_trip_and_fields_read_by_name() {
        assert!(record_matches::<Sample>());
        let recs = vec![
            Sample { l: [1.0, 2.0, 3.0], count: 7, r: [0.5, -0.5] },
            Sample { l: [4.0, 5.0, 6.0], count: 9, r: [1.5, 2.5] },
        ];
        let b = <Sample as Texel>::wrap(recs.clone());
        assert_eq!(b.format(), Format::Struct(&LAYOUT));
        assert_eq!(b.len(), 2);
        assert_eq!(<Sample as Texel>::slice(&b).unwrap(), &recs[..]);
        assert_eq!(b.field("count"), Some(BufferData::U32(vec![7, 9])));
        assert_eq!(b.field("l"), Some(BufferData::Vec3(vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])));
        assert_eq!(b.field("r"), Some(BufferData::Vec2(vec![[0.5, -0.5], [1.5, 2.5]])));
        assert_eq!(b.field("nope"), None);
        assert_eq!(b.component(1, 3), 9.0, "u32 field converted");
        assert_eq!(b.component(1, 5), 2.5, "f32 field from its bits");
        let back = BufferData::from_bytes(b.format(), b.as_bytes());
        assert_eq!(back, b);
        assert_eq!(BufferData::zeroed(Format::Struct(&LAYOUT), 3).len(), 3);
        assert_eq!(<Sample as Texel>::unwrap(b).unwrap(), recs);
    }

    /// `paths.trace`'s records are ~130 MB at 640×480: wrapping them as words and back, and
    /// zeroing a fresh buffer of them, must not copy or write them (`recast`, `Texel::zeroed`).
    #[test]
    fn records_change_hands_without_a_copy() {
        let recs: Vec<Sample> = (0..1000).map(|k| Sample { count: k, ..Sample::default() }).collect();
        let at = recs.as_ptr() as usize;
        let b = <Sample as Texel>::wrap(recs.clone());
        let BufferData::Words { data, .. } = &b else { panic!("a record buffer is words") };
        let words_at = data.as_ptr() as usize;
        let back = <Sample as Texel>::unwrap(b).unwrap();
        assert_eq!(back, recs, "the same records");
        assert_eq!(back.as_ptr() as usize, words_at, "unwrap kept the words' allocation");
        let zeroed = BufferData::zeroed(Format::Struct(&LAYOUT), 7);
        let words_at = match &zeroed {
            BufferData::Words { data, .. } => data.as_ptr() as usize,
            _ => unreachable!(),
        };
        let from_zeroed = <Sample as Texel>::unwrap(zeroed).unwrap();
        assert_eq!(from_zeroed.as_ptr() as usize, words_at, "a zeroed buffer's too");
        let moved = <Sample as Texel>::wrap(recs);
        let BufferData::Words { data, .. } = &moved else { panic!("a record buffer is words") };
        assert_eq!(data.as_ptr() as usize, at, "wrap kept the records' allocation");
        assert_eq!(<Sample as Texel>::zeroed(5), vec![Sample::default(); 5]);
    }

    #[test]
    fn a_record_of_another_layout_is_refused() {
        static OTHER: StructLayout = StructLayout {
            name: "Sample",
            fields: &[Field::new("l", FieldType::Vec4), Field::new("r", FieldType::Vec2)],
        };
        let b = BufferData::zeroed(Format::Struct(&OTHER), 2);
        assert!(<Sample as Texel>::slice(&b).is_none());
        assert!(<[f32; 4] as Texel>::slice(&b).is_none());
    }
}
