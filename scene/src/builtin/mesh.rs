//! Mesh generators shared by the built-in scenes: everything here writes loose triangles into a
//! [`SceneData`] with outward, consistently wound normals, so any built-in (and later ones) can build
//! ground planes, textured panels, boxes and long bars, spheres, tori, surfaces of revolution (lathes:
//! cylinders, cones, chess pieces) and rectangular area lights from a few numbers instead of files.

use std::f32::consts::{PI, TAU};

use glam::{Mat4, Vec2, Vec3};

use crate::data::SceneData;
use crate::Material;

/// Push a triangle with per-vertex normals/uvs, wound so its geometric normal agrees with the vertex
/// normals (so one-sided consumers see a consistent front).
pub(crate) fn smooth_tri(d: &mut SceneData, p: [Vec3; 3], n: [Vec3; 3], uv: [Vec2; 3], material: u32, object: u32) {
    let g = (p[1] - p[0]).cross(p[2] - p[0]);
    if g.length_squared() == 0.0 {
        return; // degenerate (sphere poles): skip rather than store an untraceable triangle
    }
    let (p, n, uv) = if g.dot(n[0] + n[1] + n[2]) < 0.0 {
        ([p[0], p[2], p[1]], [n[0], n[2], n[1]], [uv[0], uv[2], uv[1]])
    } else {
        (p, n, uv)
    };
    d.push(p, n, uv, material, object);
}

/// Tessellate a parametric surface f(u,v) -> (position, normal), u,v in [0,1], into nu×nv cells.
pub(crate) fn parametric(
    d: &mut SceneData,
    nu: u32,
    nv: u32,
    material: u32,
    object: u32,
    f: impl Fn(f32, f32) -> (Vec3, Vec3),
) {
    let at = |i: u32, j: u32| {
        let (u, v) = (i as f32 / nu as f32, j as f32 / nv as f32);
        let (p, n) = f(u, v);
        (p, n, Vec2::new(u, v))
    };
    for j in 0..nv {
        for i in 0..nu {
            let c = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
            for idx in [[0, 1, 2], [0, 2, 3]] {
                let t = idx.map(|k| c[k]);
                smooth_tri(d, t.map(|x| x.0), t.map(|x| x.1), t.map(|x| x.2), material, object);
            }
        }
    }
}

/// A horizontal ground rectangle at y = 0, x in `x0..x1`, z in `z0..z1`, facing up (+y), as two
/// smooth triangles with uv = (x, z) · `uv_per_metre` (for checker textures). Shared by `grids`,
/// `envmap` and the scene suite; the vertex order and arithmetic are fixed (the `envmap` triangles
/// are compared bit for bit by the real-layer tests).
pub(crate) fn add_ground(
    d: &mut SceneData,
    (x0, x1, z0, z1): (f32, f32, f32, f32),
    uv_per_metre: f32,
    material: u32,
    object: u32,
) {
    let p = [Vec3::new(x0, 0.0, z1), Vec3::new(x1, 0.0, z1), Vec3::new(x1, 0.0, z0), Vec3::new(x0, 0.0, z0)];
    let uv = p.map(|p| Vec2::new(p.x, p.z) * uv_per_metre);
    for idx in [[0, 1, 2], [0, 2, 3]] {
        smooth_tri(d, idx.map(|k| p[k]), [Vec3::Y; 3], idx.map(|k| uv[k]), material, object);
    }
}

/// A flat quad `p[0..4]` (a parallelogram or any planar convex quad, corners in order) facing
/// `normal`, with uv = distance along the edges p0→p1 and p0→p3 · `uv_per_metre`: walls, table tops
/// and panels that carry a texture.
pub(crate) fn add_panel(d: &mut SceneData, p: [Vec3; 4], normal: Vec3, uv_per_metre: f32, material: u32, object: u32) {
    let (eu, ev) = ((p[1] - p[0]).normalize_or_zero(), (p[3] - p[0]).normalize_or_zero());
    let uv = p.map(|q| Vec2::new((q - p[0]).dot(eu), (q - p[0]).dot(ev)) * uv_per_metre);
    for idx in [[0, 1, 2], [0, 2, 3]] {
        smooth_tri(d, idx.map(|k| p[k]), [normal; 3], idx.map(|k| uv[k]), material, object);
    }
}

/// A box that may be long and thin (a bar, slat or plank): split along its longest local axis into
/// pieces at most `segment` m long, so each BVH box stays tight even when the bar is rotated (one
/// long rotated bar has a huge axis-aligned box; see `add_grids`). `xf` places the box's centre and
/// orientation, `half` its half-extents.
pub(crate) fn add_bar(d: &mut SceneData, xf: Mat4, half: Vec3, segment: f32, material: u32, object: u32) {
    let axis = if half.x >= half.y && half.x >= half.z {
        0
    } else if half.y >= half.z {
        1
    } else {
        2
    };
    let len = 2.0 * half[axis];
    let pieces = ((len / segment.max(1e-3)).ceil() as i32).max(1);
    let mut piece_half = half;
    piece_half[axis] = half[axis] / pieces as f32;
    for k in 0..pieces {
        let mut offset = Vec3::ZERO;
        offset[axis] = -half[axis] + (2 * k + 1) as f32 * piece_half[axis];
        add_box(d, xf * Mat4::from_translation(offset), piece_half, material, object);
    }
}

/// A closed cylinder of `radius` and `length` along the y axis of `xf`, centred on its origin (a lathe
/// with flat, creased caps).
pub(crate) fn add_cylinder(
    d: &mut SceneData,
    xf: Mat4,
    radius: f32,
    length: f32,
    slices: u32,
    material: u32,
    object: u32,
) {
    let h = 0.5 * length;
    let profile = [Vec2::new(0.0, -h), Vec2::new(radius, -h), Vec2::new(radius, h), Vec2::new(0.0, h)];
    lathe(d, xf, &profile, slices, material, object);
}

/// An oriented box (12 flat triangles, outward normals).
pub(crate) fn add_box(d: &mut SceneData, xf: Mat4, half: Vec3, material: u32, object: u32) {
    let c = |sx: f32, sy: f32, sz: f32| xf.transform_point3(Vec3::new(sx * half.x, sy * half.y, sz * half.z));
    let centre = xf.transform_point3(Vec3::ZERO);
    let faces = [
        [c(1., -1., -1.), c(1., 1., -1.), c(1., 1., 1.), c(1., -1., 1.)],
        [c(-1., -1., -1.), c(-1., -1., 1.), c(-1., 1., 1.), c(-1., 1., -1.)],
        [c(-1., 1., -1.), c(-1., 1., 1.), c(1., 1., 1.), c(1., 1., -1.)],
        [c(-1., -1., -1.), c(1., -1., -1.), c(1., -1., 1.), c(-1., -1., 1.)],
        [c(-1., -1., 1.), c(1., -1., 1.), c(1., 1., 1.), c(-1., 1., 1.)],
        [c(-1., -1., -1.), c(-1., 1., -1.), c(1., 1., -1.), c(1., -1., -1.)],
    ];
    for [a, b, cc, dd] in faces {
        let fc = (a + b + cc + dd) * 0.25;
        if (b - a).cross(cc - a).dot(fc - centre) >= 0.0 {
            d.quad(a, b, cc, dd, material, object);
        } else {
            d.quad(a, dd, cc, b, material, object);
        }
    }
}

pub(crate) fn add_sphere(
    d: &mut SceneData,
    centre: Vec3,
    r: f32,
    stacks: u32,
    slices: u32,
    material: u32,
    object: u32,
) {
    parametric(d, slices, stacks, material, object, |u, v| {
        let n = sphere_normal(u, v);
        (centre + r * n, n)
    });
}

/// The unit-sphere point (= outward normal) at longitude `u`·2π and colatitude `v`·π. In f32, sin π is
/// −8.7e-8, not 0, so the v = 1 ring is not exactly one point: added to a sphere centre it can survive
/// rounding and leave sliver triangles at the bottom pole instead of zero-area ones that
/// [`smooth_tri`] drops.
pub(crate) fn sphere_normal(u: f32, v: f32) -> Vec3 {
    let (phi, theta) = (u * TAU, v * PI);
    Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())
}

pub(crate) fn add_torus(d: &mut SceneData, xf: Mat4, big_r: f32, small_r: f32, material: u32, object: u32) {
    let nm = xf.inverse().transpose();
    parametric(d, 96, 32, material, object, |u, v| {
        let (a, b) = (u * TAU, v * TAU);
        let ring = Vec3::new(a.cos(), 0.0, a.sin());
        let n = ring * b.cos() + Vec3::Y * b.sin();
        let p = ring * big_r + n * small_r;
        (xf.transform_point3(p), nm.transform_vector3(n).normalize())
    });
}

/// A rectangular area light with corner `corner` and edges `eu`, `ev` (two emissive triangles, which the
/// scene merges into one `Rect` light). It emits on the side of `eu × ev` only.
pub(crate) fn add_rect_light(d: &mut SceneData, name: &str, radiance: Vec3, corner: Vec3, eu: Vec3, ev: Vec3) {
    let m = d.add_material(Material::emitter(name, radiance), false);
    let o = d.new_object();
    d.quad(corner, corner + eu, corner + eu + ev, corner + ev, m, o);
}

/// A square light of `side` m centred at `centre`, facing down (`eu × ev = −Y`), of grey radiance
/// `radiance`: the ceiling light of most built-ins.
pub(crate) fn add_square_light(d: &mut SceneData, radiance: f32, centre: Vec3, side: f32) {
    let corner = Vec3::new(centre.x - 0.5 * side, centre.y, centre.z - 0.5 * side);
    add_rect_light(d, "light", Vec3::splat(radiance), corner, Vec3::X * side, Vec3::Z * side);
}

/// Cosine of the largest angle between the normals of two profile segments that a lathe still shades
/// smoothly across; sharper corners (a rook's crown, a base's rim) keep a crease, as turned wood does.
const LATHE_SMOOTH_COS: f32 = 0.766; // cos 40°

/// A surface of revolution about the y axis of `xf`: `profile` holds (radius, height) points and is
/// walked from the axis at the bottom, out along the base, up the side and back in over the top, so
/// the outward normal of the segment from `a` to `b` is `(b.y − a.y, a.x − b.x)` in the (radius, height)
/// plane. Points on the axis (radius 0) close the solid; the zero-area triangles they produce are
/// skipped by [`smooth_tri`]. Each segment is shaded with normals averaged with its neighbours' where
/// they meet at less than 40°, and creased otherwise. `slices` steps around the axis. uv = (angle/2π,
/// point index / (points − 1)).
pub(crate) fn lathe(d: &mut SceneData, xf: Mat4, profile: &[Vec2], slices: u32, material: u32, object: u32) {
    let segments = profile.len().saturating_sub(1);
    let slices = slices.max(3);
    let seg_normal: Vec<Vec2> = (0..segments)
        .map(|k| {
            let (a, b) = (profile[k], profile[k + 1]);
            Vec2::new(b.y - a.y, a.x - b.x).normalize_or_zero()
        })
        .collect();
    // Profile normal of segment k at its start (end = false) or end (end = true).
    let normal_at = |k: usize, end: bool| -> Vec2 {
        let own = seg_normal[k];
        let other = if end { seg_normal.get(k + 1) } else { k.checked_sub(1).map(|j| &seg_normal[j]) };
        match other {
            Some(&o) if o != Vec2::ZERO && own.dot(o) >= LATHE_SMOOTH_COS => (own + o).normalize_or_zero(),
            _ => own,
        }
    };
    let nm = xf.inverse().transpose();
    let vertex = |p: Vec2, n: Vec2, s: u32| {
        let a = s as f32 / slices as f32 * TAU;
        let (sin, cos) = a.sin_cos();
        let pos = Vec3::new(p.x * cos, p.y, p.x * sin);
        let nrm = Vec3::new(n.x * cos, n.y, n.x * sin);
        (xf.transform_point3(pos), nm.transform_vector3(nrm).normalize_or_zero())
    };
    let last = segments.max(1) as f32;
    for k in 0..segments {
        if seg_normal[k] == Vec2::ZERO {
            continue; // repeated point
        }
        let (n0, n1) = (normal_at(k, false), normal_at(k, true));
        for s in 0..slices {
            let c = [
                (vertex(profile[k], n0, s), Vec2::new(s as f32 / slices as f32, k as f32 / last)),
                (vertex(profile[k], n0, s + 1), Vec2::new((s + 1) as f32 / slices as f32, k as f32 / last)),
                (vertex(profile[k + 1], n1, s + 1), Vec2::new((s + 1) as f32 / slices as f32, (k + 1) as f32 / last)),
                (vertex(profile[k + 1], n1, s), Vec2::new(s as f32 / slices as f32, (k + 1) as f32 / last)),
            ];
            for idx in [[0, 1, 2], [0, 2, 3]] {
                let t = idx.map(|i| c[i]);
                smooth_tri(d, t.map(|x| x.0 .0), t.map(|x| x.0 .1), t.map(|x| x.1), material, object);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Signed volume by the divergence theorem: positive when every triangle winds outward.
    fn signed_volume(d: &SceneData) -> f32 {
        d.tris.iter().map(|(a, b, c, _)| a.dot(b.cross(*c)) / 6.0).sum()
    }

    #[test]
    fn lathe_of_a_rectangle_is_a_closed_outward_prism_with_creased_caps() {
        let mut d = SceneData::default();
        let (r, h, n) = (0.5f32, 2.0f32, 12u32);
        let profile = [Vec2::new(0.0, 0.0), Vec2::new(r, 0.0), Vec2::new(r, h), Vec2::new(0.0, h)];
        lathe(&mut d, Mat4::IDENTITY, &profile, n, 0, 0);
        // Bottom and top: one triangle per slice (the other of each quad has zero area); side: two.
        assert_eq!(d.tris.len(), 4 * n as usize);
        // An n-gon prism: (n/2) r² sin(2π/n) · h, positive because every face winds outward.
        let expect = 0.5 * n as f32 * r * r * (TAU / n as f32).sin() * h;
        assert!((signed_volume(&d) - expect).abs() < 1e-5 * expect, "{} vs {expect}", signed_volume(&d));
        for (a, b, c, s) in &d.tris {
            let g = (*b - *a).cross(*c - *a).normalize();
            let centre = (*a + *b + *c) / 3.0;
            let expect_n = if centre.y < 1e-6 {
                -Vec3::Y
            } else if centre.y > h - 1e-6 {
                Vec3::Y
            } else {
                Vec3::new(centre.x, 0.0, centre.z).normalize()
            };
            // Caps meet the side at 90°: creased, so cap normals are exactly ±y and side normals radial.
            for v in s.n {
                assert!(v.dot(g) > 0.0);
                if expect_n.y != 0.0 {
                    assert!(v.abs_diff_eq(expect_n, 1e-6), "{v} vs {expect_n}");
                } else {
                    // Vertex normals sit on their own slice, within one slice step of the centroid.
                    assert!(v.y.abs() < 1e-6 && v.dot(expect_n) > (TAU / n as f32).cos(), "{v}");
                }
            }
        }
    }

    #[test]
    fn lathe_smooths_gentle_bends_and_scales_with_its_transform() {
        // A cone frustum on a cylinder: 10° bend, shaded smoothly (shared normal at the joint).
        let p =
            [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.82, 2.0), Vec2::new(0.0, 2.0)];
        let mut d = SceneData::default();
        lathe(&mut d, Mat4::from_scale(Vec3::splat(2.0)), &p, 16, 0, 0);
        let at_joint: Vec<Vec3> = d
            .tris
            .iter()
            .flat_map(|(a, b, c, s)| [(*a, s.n[0]), (*b, s.n[1]), (*c, s.n[2])])
            .filter(|(pos, _)| (pos.y - 2.0).abs() < 1e-5 && pos.x > 1.9)
            .map(|(_, n)| n)
            .collect();
        assert!(at_joint.len() >= 2);
        let bend = ((1.0f32 - 0.82).atan2(1.0) * 0.5).sin(); // half the 10.2° bend
        for n in &at_joint {
            assert!(n.abs_diff_eq(at_joint[0], 1e-6), "joint normals differ: {n} vs {}", at_joint[0]);
            assert!((n.y - bend).abs() < 1e-4, "{n}");
        }
        assert!(signed_volume(&d) > 0.0);
    }
}
