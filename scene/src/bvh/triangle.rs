//! The one definition of a traced triangle and of a hit, shared by every traversal (CPU here,
//! `shaders/bvh.wgsl` on the GPU): the 48-byte record, Möller–Trumbore in f32 with a fixed operation
//! order, and the rule that picks the closest hit when two triangles report the same `t`.

use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec3A, Vec4};

/// Marker for "no light" in [`TriangleRecord::light`].
pub const NO_LIGHT: u32 = u32::MAX;

/// A triangle as traced (48 bytes, `repr(C)`, Pod): `v0`, `e1 = v1 - v0`, `e2 = v2 - v0`, each followed
/// by a u32 so every vec3 sits in a 16-byte slot (WGSL `vec3<f32>` + `u32` packs exactly like this):
/// - `material`: index into `Scene::materials` (same as `Scene::shading[i].material`, duplicated so a
///   shadow/any-hit kernel need not read the shading array),
/// - `light`: index into `Scene::lights` of the emitter this triangle belongs to, or [`NO_LIGHT`],
/// - `source`: the triangle's index in the input order given to `Scene::from_triangles` (before BVH
///   reordering), for debugging and for callers that kept per-input-triangle data.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TriangleRecord {
    pub v0: [f32; 3],
    pub material: u32,
    pub e1: [f32; 3],
    pub light: u32,
    pub e2: [f32; 3],
    pub source: u32,
}

impl TriangleRecord {
    pub fn new(a: Vec3, b: Vec3, c: Vec3, material: u32, source: u32) -> Self {
        TriangleRecord {
            v0: a.to_array(),
            material,
            e1: (b - a).to_array(),
            light: NO_LIGHT,
            e2: (c - a).to_array(),
            source,
        }
    }
    pub fn vertices(&self) -> [Vec3; 3] {
        let v0 = Vec3::from(self.v0);
        [v0, v0 + Vec3::from(self.e1), v0 + Vec3::from(self.e2)]
    }
}

/// A ray–scene intersection: distance along the (not necessarily unit) direction, the triangle index in
/// `Scene::triangles`, and the barycentric weights of v1 and v2 (v0's is 1 - b1 - b2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub triangle: u32,
    pub b1: f32,
    pub b2: f32,
}

/// Möller–Trumbore. Returns (t, b1, b2) for a hit with tmin < t < tmax. Single-sided tests are not done:
/// both faces are hit.
#[inline]
pub fn intersect_triangle(
    tri: &TriangleRecord,
    o: Vec3,
    d: Vec3,
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32, f32)> {
    let (t, b1, b2) = triangle_hit(tri, o.into(), d.into())?;
    (t > tmin && t < tmax).then_some((t, b1, b2))
}

/// Möller–Trumbore without the range test: (t, b1, b2) where the ray's line crosses the triangle.
///
/// Written out per component — `cross` as `a.y·b.z − a.z·b.y` …, `dot` as `(x·x' + y·y') + z·z'` —
/// and Rust never fuses multiply-adds, so this is bit-identical to [`TrianglePack::intersect`]'s lanes
/// and to the WGSL mirror (`shaders/bvh.wgsl`). (glam's own `cross` uses FMA when a build enables it,
/// which is what made a `target-cpu=native` build change hits: DESIGN-NOTES "Ray tracing core".)
#[inline(always)]
pub(crate) fn triangle_hit(tri: &TriangleRecord, o: Vec3A, d: Vec3A) -> Option<(f32, f32, f32)> {
    let (e1, e2, v0) = (tri.e1, tri.e2, tri.v0);
    let p = [
        d.y * e2[2] - d.z * e2[1],
        d.z * e2[0] - d.x * e2[2],
        d.x * e2[1] - d.y * e2[0],
    ];
    let det = (e1[0] * p[0] + e1[1] * p[1]) + e1[2] * p[2];
    if det == 0.0 || !det.is_finite() {
        return None; // ray parallel to the plane (or degenerate triangle)
    }
    let inv_det = 1.0 / det;
    let s = [o.x - v0[0], o.y - v0[1], o.z - v0[2]];
    let b1 = ((s[0] * p[0] + s[1] * p[1]) + s[2] * p[2]) * inv_det;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let q = [
        s[1] * e1[2] - s[2] * e1[1],
        s[2] * e1[0] - s[0] * e1[2],
        s[0] * e1[1] - s[1] * e1[0],
    ];
    let b2 = ((d.x * q[0] + d.y * q[1]) + d.z * q[2]) * inv_det;
    if b2 < 0.0 || b1 + b2 > 1.0 {
        return None;
    }
    Some((
        ((e2[0] * q[0] + e2[1] * q[1]) + e2[2] * q[2]) * inv_det,
        b1,
        b2,
    ))
}

/// Four triangles as structure of arrays (160 bytes, Pod; uploaded to the GPU byte for byte): the leaf
/// format both traversals test, one SIMD lane per triangle. `v0`, `e1`, `e2` hold the x, y and z rows of
/// the same values as the triangles' [`TriangleRecord`]s; `index` is each lane's position in
/// `Scene::triangles`. Unused lanes are all-zero triangles (determinant 0: never hit) with index
/// [`NO_TRIANGLE`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TrianglePack {
    pub v0: [[f32; 4]; 3],
    pub e1: [[f32; 4]; 3],
    pub e2: [[f32; 4]; 3],
    pub index: [u32; 4],
}

/// [`TrianglePack::index`] of an unused lane.
pub const NO_TRIANGLE: u32 = u32::MAX;

/// Per-ray lanes for [`TrianglePack::intersect`]: origin and direction splatted.
pub(crate) struct PackRay {
    pub o: [Vec4; 3],
    pub d: [Vec4; 3],
}

impl PackRay {
    pub fn new(o: Vec3A, d: Vec3A) -> Self {
        PackRay {
            o: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            d: [Vec4::splat(d.x), Vec4::splat(d.y), Vec4::splat(d.z)],
        }
    }
}

impl TrianglePack {
    /// Up to four consecutive triangles, `first` being the first one's index in `tris`.
    pub fn new(tris: &[TriangleRecord], first: u32) -> Self {
        let mut pack = TrianglePack::zeroed();
        pack.index = [NO_TRIANGLE; 4];
        for (lane, t) in tris.iter().take(4).enumerate() {
            for axis in 0..3 {
                pack.v0[axis][lane] = t.v0[axis];
                pack.e1[axis][lane] = t.e1[axis];
                pack.e2[axis][lane] = t.e2[axis];
            }
            pack.index[lane] = first + lane as u32;
        }
        pack
    }

    /// [`triangle_hit`] on all four lanes at once, with the range test `tmin < t ≤ tmax` (inclusive, so
    /// the caller can apply [`closer`]'s tie rule at `tmax` = the best distance so far): returns the
    /// lanes' t, b1, b2 and the mask of lanes that pass (bit i: lane i).
    #[inline(always)]
    pub(crate) fn intersect(&self, r: &PackRay, tmin: f32, tmax: f32) -> (Vec4, Vec4, Vec4, u32) {
        let v = |a: &[[f32; 4]; 3]| [Vec4::from(a[0]), Vec4::from(a[1]), Vec4::from(a[2])];
        let (e1, e2, v0) = (v(&self.e1), v(&self.e2), v(&self.v0));
        let d = &r.d;
        let p = [
            d[1] * e2[2] - d[2] * e2[1],
            d[2] * e2[0] - d[0] * e2[2],
            d[0] * e2[1] - d[1] * e2[0],
        ];
        let det = (e1[0] * p[0] + e1[1] * p[1]) + e1[2] * p[2];
        let inv_det = Vec4::ONE / det;
        let s = [r.o[0] - v0[0], r.o[1] - v0[1], r.o[2] - v0[2]];
        let b1 = ((s[0] * p[0] + s[1] * p[1]) + s[2] * p[2]) * inv_det;
        let q = [
            s[1] * e1[2] - s[2] * e1[1],
            s[2] * e1[0] - s[0] * e1[2],
            s[0] * e1[1] - s[1] * e1[0],
        ];
        let b2 = ((d[0] * q[0] + d[1] * q[1]) + d[2] * q[2]) * inv_det;
        let t = ((e2[0] * q[0] + e2[1] * q[1]) + e2[2] * q[2]) * inv_det;
        // The scalar test's conditions lane by lane, NaN cases included (its `contains` rejects a NaN
        // b1, its `b2 < 0 || b1 + b2 > 1` lets a NaN b2 through to the t test).
        let ok = det.cmpne(Vec4::ZERO)
            & det.is_finite_mask()
            & b1.cmpge(Vec4::ZERO)
            & b1.cmple(Vec4::ONE)
            & !(b2.cmplt(Vec4::ZERO) | (b1 + b2).cmpgt(Vec4::ONE))
            & t.cmpgt(Vec4::splat(tmin))
            & t.cmple(Vec4::splat(tmax));
        (t, b1, b2, ok.bitmask())
    }
}

/// The closest-hit rule: a candidate `(t, triangle)` replaces the best so far when it is nearer, or
/// equally near with a lower triangle index. The result is then the minimum of `(t, triangle)` over
/// every triangle the ray crosses — independent of the order a traversal visits them in, so CPU and
/// GPU agree whatever order their stacks pop in. `best_triangle` is 0 while nothing is hit (no
/// candidate can tie below index 0, and `t_best` is then the ray's exclusive `tmax`).
#[inline(always)]
pub fn closer(t: f32, triangle: u32, t_best: f32, best_triangle: u32) -> bool {
    t < t_best || (t == t_best && triangle < best_triangle)
}
