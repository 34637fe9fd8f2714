//! The one definition of a traced triangle and of a hit, shared by every traversal (CPU here,
//! `shaders/bvh.wgsl` on the GPU): the 48-byte record, the watertight ray–triangle test of Woop,
//! Benthin and Wald (2013) in f32 with a fixed operation order, and the rule that picks the closest
//! hit when two triangles report the same `t`.
//!
//! **Watertight.** The test moves the ray origin to 0, permutes the axes so the direction's largest
//! component is z and shears x and y so the ray becomes the z axis; the triangle is hit where the
//! three 2D edge functions of its sheared vertices have one sign (0 included). An edge shared by two
//! triangles gives both the same two products with the roles swapped, so their edge functions are
//! exact negatives of each other: a ray through the edge is inside one of them or on the edge of both,
//! never between them, and a ray through a shared vertex is inside some triangle of the fan. This needs
//! the vertices themselves (not edge vectors, whose rounding differs per triangle), so records and
//! packs store `v0`, `v1`, `v2`. Woop et al. recompute an edge function that is exactly 0 in double
//! precision, to decide *which* of two triangles owns an edge; that is left out (WGSL has no f64):
//! such a ray hits both, and [`closer`] picks one. Möller–Trumbore, used before, let rays through
//! (`scene/tests/wide_bvh.rs` `rays_through_shared_edges_and_vertices_never_leak` measures both).
//! The WGSL mirror is watertight only where the shader compiler keeps `a·b − c·d` as two roundings
//! (lavapipe and llvmpipe GL do: `tests/parity.rs` `watertight_triangle_wgsl_matches_cpu`, bit for
//! bit); a GPU that fuses it into a multiply-add rounds two neighbours' edge functions differently.

use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec3A, Vec4};

/// Marker for "no light" in [`TriangleRecord::light`].
pub const NO_LIGHT: u32 = u32::MAX;

/// A triangle as traced (48 bytes, `repr(C)`, Pod): its vertices `v0`, `v1`, `v2`, each followed by a
/// u32 so every vec3 sits in a 16-byte slot (WGSL `vec3<f32>` + `u32` packs exactly like this):
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
    pub v1: [f32; 3],
    pub light: u32,
    pub v2: [f32; 3],
    pub source: u32,
}

impl TriangleRecord {
    pub fn new(a: Vec3, b: Vec3, c: Vec3, material: u32, source: u32) -> Self {
        TriangleRecord { v0: a.to_array(), material, v1: b.to_array(), light: NO_LIGHT, v2: c.to_array(), source }
    }
    pub fn vertices(&self) -> [Vec3; 3] {
        [self.v0.into(), self.v1.into(), self.v2.into()]
    }
    /// `v1 − v0` (what surfaces interpolate along; the same bits the record stored before it held `v1`).
    pub fn e1(&self) -> Vec3 {
        Vec3::from(self.v1) - Vec3::from(self.v0)
    }
    /// `v2 − v0`.
    pub fn e2(&self) -> Vec3 {
        Vec3::from(self.v2) - Vec3::from(self.v0)
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

/// The watertight test (module doc). Returns (t, b1, b2) for a hit with tmin < t < tmax. Single-sided
/// tests are not done: both faces are hit.
#[inline]
pub fn intersect_triangle(tri: &TriangleRecord, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
    let (o, d) = (Vec3A::from(o), Vec3A::from(d));
    let (t, b1, b2) = triangle_hit(tri, o, &Shear::new(d))?;
    (t > tmin && t < tmax).then_some((t, b1, b2))
}

/// A ray's constants for the watertight test: the axes `k` = (x, y, z) permuted so that `k[2]` is the
/// direction's largest component (the first of equal ones; x and y swapped where it is negative, which
/// keeps the winding), and the shear `s = (d_kx · s_z, d_ky · s_z, s_z)` with `s_z = 1 / d_kz`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shear {
    pub k: [usize; 3],
    pub s: [f32; 3],
}

impl Shear {
    #[inline(always)]
    pub fn new(d: Vec3A) -> Shear {
        // (kx, ky) for kz = 0, 1, 2, then the same swapped (d_kz negative).
        const XY: [[usize; 2]; 6] = [[1, 2], [2, 0], [0, 1], [2, 1], [0, 2], [1, 0]];
        // Components picked from an array (a `Vec3A` indexed at run time compiles to branches).
        let d = d.to_array();
        let a = d.map(f32::abs);
        let kz = if a[2] > a[0].max(a[1]) { 2 } else { (a[1] > a[0]) as usize };
        let [kx, ky] = XY[kz + 3 * (d[kz] < 0.0) as usize];
        let sz = 1.0 / d[kz];
        Shear { k: [kx, ky, kz], s: [d[kx] * sz, d[ky] * sz, sz] }
    }
}

/// The watertight test without the range test: (t, b1, b2) where the ray's line crosses the triangle.
///
/// Written out per component with a fixed operation order, and Rust never fuses multiply-adds, so
/// this is bit-identical to [`TrianglePack::intersect`]'s lanes and to the WGSL mirror
/// (`shaders/bvh.wgsl`). (glam's own `cross` uses FMA when a build enables it, which is what made a
/// `target-cpu=native` build change hits once: DESIGN-NOTES "Ray tracing core".)
#[inline(always)]
pub(crate) fn triangle_hit(tri: &TriangleRecord, o: Vec3A, r: &Shear) -> Option<(f32, f32, f32)> {
    let ([kx, ky, kz], [sx, sy, sz]) = (r.k, r.s);
    let o = o.to_array();
    let rel = |v: [f32; 3]| [v[kx] - o[kx], v[ky] - o[ky], v[kz] - o[kz]];
    let (a, b, c) = (rel(tri.v0), rel(tri.v1), rel(tri.v2));
    let (ax, ay) = (a[0] - sx * a[2], a[1] - sy * a[2]);
    let (bx, by) = (b[0] - sx * b[2], b[1] - sy * b[2]);
    let (cx, cy) = (c[0] - sx * c[2], c[1] - sy * c[2]);
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = (u + v) + w;
    if det == 0.0 {
        return None; // the ray in the triangle's plane, or a degenerate triangle
    }
    let (az, bz, cz) = (sz * a[2], sz * b[2], sz * c[2]);
    let inv_det = 1.0 / det;
    let t = ((u * az + v * bz) + w * cz) * inv_det;
    // t must exceed its rounding error bound (see `t_error_bound`).
    let max = |p: f32, q: f32, r: f32| p.abs().max(q.abs()).max(r.abs());
    let bound = t_error_bound(max(ax, bx, cx), max(ay, by, cy), max(az, bz, cz), max(u, v, w), inv_det.abs());
    (t > bound).then_some((t, v * inv_det, w * inv_det))
}

/// γ(n) = n·u / (1 − n·u) for u = 2⁻²⁴ (the unit roundoff of f32), rounded to f32: the relative
/// error bound of n roundings (Higham; PBRT §3.9). `shaders/bvh.wgsl` has the same bits.
pub const GAMMA: [f32; 3] = [
    f32::from_bits(0x3400_0001), // γ(2)
    f32::from_bits(0x3440_0002), // γ(3)
    f32::from_bits(0x34a0_0003), // γ(5)
];

/// A bound on the rounding error of the watertight test's `t` (PBRT-v3 §3.9.6, "conservative ray–
/// triangle t"): from the largest sheared |x|, |y|, |z| of the three vertices (z scaled by s_z), the
/// largest |edge function| and |1/det|. A hit is only a hit where `t` exceeds it, so a ray that starts
/// in a triangle's plane (a bounce ray from a corner, offset off one wall but still in the other's
/// plane) never hits that triangle at a rounding-error distance: Möller–Trumbore happened to give
/// exactly 0 there for axis-aligned planes, the sheared computation ±1e-11, which made such rays'
/// hits depend on the last bit of their direction (measured: 45 of 921,600 `cornell` bounce rays
/// flipped between hit and miss under a 1-ulp change of direction without the bound, 0 with it).
/// The same operations in the same order in lanes and in WGSL.
#[inline(always)]
fn t_error_bound<T: Lane>(max_x: T, max_y: T, max_z: T, max_e: T, abs_inv_det: T) -> T {
    let g = |k: usize| T::splat(GAMMA[k]);
    let delta_z = g(1) * max_z;
    let delta_x = g(2) * (max_x + max_z);
    let delta_y = g(2) * (max_y + max_z);
    let delta_e = T::splat(2.0) * ((g(0) * max_x * max_y + delta_y * max_x) + delta_x * max_y);
    T::splat(3.0) * ((g(1) * max_e * max_z + delta_e * max_z) + delta_z * max_e) * abs_inv_det
}

/// f32 or four f32 lanes: what [`t_error_bound`] computes on.
trait Lane: Copy + std::ops::Add<Output = Self> + std::ops::Mul<Output = Self> {
    fn splat(x: f32) -> Self;
}

impl Lane for f32 {
    #[inline(always)]
    fn splat(x: f32) -> f32 {
        x
    }
}

impl Lane for Vec4 {
    #[inline(always)]
    fn splat(x: f32) -> Vec4 {
        Vec4::splat(x)
    }
}

/// Four triangles as structure of arrays (160 bytes, Pod; uploaded to the GPU byte for byte): the leaf
/// format both traversals test, one SIMD lane per triangle. `v0`, `v1`, `v2` hold the x, y and z rows
/// of the triangles' [`TriangleRecord`] vertices; `index` is each lane's position in
/// `Scene::triangles`. Unused lanes are all-zero triangles (edge functions and determinant 0: never
/// hit) with index [`NO_TRIANGLE`].
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TrianglePack {
    pub v0: [[f32; 4]; 3],
    pub v1: [[f32; 4]; 3],
    pub v2: [[f32; 4]; 3],
    pub index: [u32; 4],
}

/// [`TrianglePack::index`] of an unused lane.
pub const NO_TRIANGLE: u32 = u32::MAX;

/// Per-ray lanes for [`TrianglePack::intersect`]: the origin's permuted components and the shear
/// splatted, and the permutation ([`Shear`]).
pub(crate) struct PackRay {
    pub o: [Vec4; 3],
    pub s: [Vec4; 3],
    pub k: [usize; 3],
}

impl PackRay {
    pub fn new(o: Vec3A, d: Vec3A) -> Self {
        let r = Shear::new(d);
        let o = o.to_array();
        PackRay { o: r.k.map(|k| Vec4::splat(o[k])), s: r.s.map(Vec4::splat), k: r.k }
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
                pack.v1[axis][lane] = t.v1[axis];
                pack.v2[axis][lane] = t.v2[axis];
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
        let [kx, ky, kz] = r.k;
        let [sx, sy, sz] = r.s;
        let rel =
            |v: &[[f32; 4]; 3]| [Vec4::from(v[kx]) - r.o[0], Vec4::from(v[ky]) - r.o[1], Vec4::from(v[kz]) - r.o[2]];
        let (a, b, c) = (rel(&self.v0), rel(&self.v1), rel(&self.v2));
        let (ax, ay) = (a[0] - sx * a[2], a[1] - sy * a[2]);
        let (bx, by) = (b[0] - sx * b[2], b[1] - sy * b[2]);
        let (cx, cy) = (c[0] - sx * c[2], c[1] - sy * c[2]);
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        let neg = u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero);
        let pos = u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero);
        // Most packs a ray reaches have no lane it crosses. A lane can only pass below with exactly
        // one of `neg` and `pos` set: not both (outside), not neither (u = v = w = 0 gives det = 0,
        // and a NaN among them gives t = NaN). So leaving here when no lane has that changes no
        // result, and skips the division and the error bound (measured: DESIGN-NOTES "Ray tracing
        // core", watertight test).
        if (neg ^ pos).bitmask() == 0 {
            return (zero, zero, zero, 0);
        }
        let det = (u + v) + w;
        let (az, bz, cz) = (sz * a[2], sz * b[2], sz * c[2]);
        let inv_det = Vec4::ONE / det;
        let t = ((u * az + v * bz) + w * cz) * inv_det;
        let max = |p: Vec4, q: Vec4, r: Vec4| p.abs().max(q.abs()).max(r.abs());
        let bound = t_error_bound(max(ax, bx, cx), max(ay, by, cy), max(az, bz, cz), max(u, v, w), inv_det.abs());
        // The scalar test's conditions lane by lane (a NaN fails the range test there too).
        let ok =
            !(neg & pos) & det.cmpne(zero) & t.cmpgt(bound) & t.cmpgt(Vec4::splat(tmin)) & t.cmple(Vec4::splat(tmax));
        (t, v * inv_det, w * inv_det, ok.bitmask())
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
