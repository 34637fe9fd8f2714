//! Per-pixel buffers as the CPU backend holds them, and typed access to them.

use wedge_graph::Format;

/// A per-pixel array in one of the graph's [`Format`]s.
#[derive(Clone, Debug, PartialEq)]
pub enum BufferData {
    F32(Vec<f32>),
    Vec2(Vec<[f32; 2]>),
    Vec3(Vec<[f32; 3]>),
    Vec4(Vec<[f32; 4]>),
    U32(Vec<u32>),
}

impl BufferData {
    pub fn zeroed(format: Format, len: usize) -> Self {
        match format {
            Format::F32 => BufferData::F32(vec![0.0; len]),
            Format::Vec2 => BufferData::Vec2(vec![[0.0; 2]; len]),
            Format::Vec3 => BufferData::Vec3(vec![[0.0; 3]; len]),
            Format::Vec4 => BufferData::Vec4(vec![[0.0; 4]; len]),
            Format::U32 => BufferData::U32(vec![0; len]),
        }
    }
    pub fn format(&self) -> Format {
        match self {
            BufferData::F32(_) => Format::F32,
            BufferData::Vec2(_) => Format::Vec2,
            BufferData::Vec3(_) => Format::Vec3,
            BufferData::Vec4(_) => Format::Vec4,
            BufferData::U32(_) => Format::U32,
        }
    }
    pub fn len(&self) -> usize {
        match self {
            BufferData::F32(v) => v.len(),
            BufferData::Vec2(v) => v.len(),
            BufferData::Vec3(v) => v.len(),
            BufferData::Vec4(v) => v.len(),
            BufferData::U32(v) => v.len(),
        }
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Component `c` of element `i` as f32 (u32 converted), for comparisons and heatmaps.
    pub fn component(&self, i: usize, c: usize) -> f32 {
        match self {
            BufferData::F32(v) => v[i],
            BufferData::Vec2(v) => v[i][c],
            BufferData::Vec3(v) => v[i][c],
            BufferData::Vec4(v) => v[i][c],
            BufferData::U32(v) => v[i] as f32,
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
