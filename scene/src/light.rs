//! Planar area lights: sampling, the thesis's footprint std-dev, and closed-form unoccluded irradiance.

use glam::{Vec2, Vec3};

/// A planar emitter. Rectangles (parallelograms, strictly) are the thesis's case; triangles are allowed too.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightShape {
    /// The parallelogram `corner + s*edge_u + t*edge_v`, s,t in [0,1]. Its emitting side is
    /// `edge_u × edge_v`.
    Rect { corner: Vec3, edge_u: Vec3, edge_v: Vec3 },
    /// Emitting side `(v1-v0) × (v2-v0)` (counter-clockwise seen from the lit side).
    Triangle { v0: Vec3, v1: Vec3, v2: Vec3 },
}

/// A uniformly emitting planar light. `radiance` is L_e toward `normal()`; with `two_sided` it also
/// emits the same radiance from the back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaLight {
    pub shape: LightShape,
    pub radiance: Vec3,
    pub two_sided: bool,
}

/// A light with the constants its samples use — unit normal, area, centre — computed once (per
/// pass, or per path where the light moves) rather than per sample. The values are those of
/// [`AreaLight::normal`], [`AreaLight::area`] and [`AreaLight::centre`], bit for bit. Dereferences to
/// the light for everything else (`sample_point`, `radiance`, `two_sided`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreparedLight {
    pub light: AreaLight,
    pub normal: Vec3,
    pub area: f32,
    pub centre: Vec3,
}

impl std::ops::Deref for PreparedLight {
    type Target = AreaLight;
    fn deref(&self) -> &AreaLight {
        &self.light
    }
}

impl AreaLight {
    /// The light with its per-sample constants computed ([`PreparedLight`]).
    pub fn prepare(&self) -> PreparedLight {
        PreparedLight { light: *self, normal: self.normal(), area: self.area(), centre: self.centre() }
    }

    fn cross(&self) -> Vec3 {
        match self.shape {
            LightShape::Rect { edge_u, edge_v, .. } => edge_u.cross(edge_v),
            LightShape::Triangle { v0, v1, v2 } => (v1 - v0).cross(v2 - v0),
        }
    }

    /// The polygon's vertices in order, counter-clockwise around `normal()`.
    pub fn vertices(&self) -> Vec<Vec3> {
        match self.shape {
            LightShape::Rect { corner, edge_u, edge_v } => {
                vec![corner, corner + edge_u, corner + edge_u + edge_v, corner + edge_v]
            }
            LightShape::Triangle { v0, v1, v2 } => vec![v0, v1, v2],
        }
    }

    pub fn area(&self) -> f32 {
        match self.shape {
            LightShape::Rect { .. } => self.cross().length(),
            LightShape::Triangle { .. } => 0.5 * self.cross().length(),
        }
    }

    /// Unit normal of the emitting side (`edge_u × edge_v` for a rect).
    pub fn normal(&self) -> Vec3 {
        self.cross().normalize_or_zero()
    }

    /// The cosine at the light of a sample reached along unit direction `dir` (receiver → light),
    /// against the light's unit normal `normal` ([`AreaLight::normal`], or a [`PreparedLight`]'s):
    /// `|cos|` for a two-sided light; ≤ 0 where the sample sees the light's back. WGSL:
    /// `light_facing_cos` in sampling.wgsl.
    pub fn facing_cos(&self, normal: Vec3, dir: Vec3) -> f32 {
        let cos = normal.dot(-dir);
        if self.two_sided {
            cos.abs()
        } else {
            cos
        }
    }

    /// Centroid.
    pub fn centre(&self) -> Vec3 {
        match self.shape {
            LightShape::Rect { corner, edge_u, edge_v } => corner + 0.5 * (edge_u + edge_v),
            LightShape::Triangle { v0, v1, v2 } => (v0 + v1 + v2) / 3.0,
        }
    }

    /// Uniform-area sample from u in [0,1)^2 (pdf w.r.t. area = 1/area()). Rect: `corner + u.x*edge_u +
    /// u.y*edge_v`, so a stratified u gives stratified points. Triangle: the square-root parameterisation
    /// `(1-√u.x) v0 + √u.x (1-u.y) v1 + √u.x u.y v2`.
    pub fn sample_point(&self, u: Vec2) -> Vec3 {
        match self.shape {
            LightShape::Rect { corner, edge_u, edge_v } => corner + u.x * edge_u + u.y * edge_v,
            LightShape::Triangle { v0, v1, v2 } => {
                let su = u.x.max(0.0).sqrt();
                (1.0 - su) * v0 + su * (1.0 - u.y) * v1 + su * u.y * v2
            }
        }
    }

    /// Std-dev (metres) of the emitter's footprint, the σ of the thesis's bandwidth (docs/EQUATIONS.md,
    /// SoftShadows). Rect: `max(|edge_u|, |edge_v|)/√12`, the std-dev of a uniform distribution over the
    /// longer side. Triangle: √(largest eigenvalue) of the covariance of a point uniformly distributed over
    /// the triangle, `Cov = (e1 e1ᵀ + e2 e2ᵀ)/18 − (e1 e2ᵀ + e2 e1ᵀ)/36` with e1 = v1−v0, e2 = v2−v0 (from
    /// the barycentric moments Var(s) = 1/18, Cov(s,t) = −1/36). For a rect the same eigen-analysis would
    /// give the same value when its edges are orthogonal.
    pub fn sigma(&self) -> f32 {
        match self.shape {
            LightShape::Rect { edge_u, edge_v, .. } => edge_u.length().max(edge_v.length()) / 12f32.sqrt(),
            LightShape::Triangle { v0, v1, v2 } => {
                let (e1, e2) = ((v1 - v0) as Vec3, (v2 - v0) as Vec3);
                // Work in a 2-D orthonormal basis of the triangle's plane: the covariance has rank ≤ 2.
                let t1 = e1.normalize_or_zero();
                let t2 = (e2 - t1 * e2.dot(t1)).normalize_or_zero();
                let a = Vec2::new(e1.dot(t1), e1.dot(t2));
                let b = Vec2::new(e2.dot(t1), e2.dot(t2));
                let cxx = (a.x * a.x + b.x * b.x) / 18.0 - (2.0 * a.x * b.x) / 36.0;
                let cyy = (a.y * a.y + b.y * b.y) / 18.0 - (2.0 * a.y * b.y) / 36.0;
                let cxy = (a.x * a.y + b.x * b.y) / 18.0 - (a.x * b.y + b.x * a.y) / 36.0;
                let mean = 0.5 * (cxx + cyy);
                let disc = (0.25 * (cxx - cyy) * (cxx - cyy) + cxy * cxy).sqrt();
                (mean + disc).max(0.0).sqrt()
            }
        }
    }

    /// The polygon's vertices (as [`AreaLight::vertices`]) in a fixed array, and how many there are.
    pub fn corners(&self) -> ([Vec3; 4], usize) {
        match self.shape {
            LightShape::Rect { corner, edge_u, edge_v } => {
                ([corner, corner + edge_u, corner + edge_u + edge_v, corner + edge_v], 4)
            }
            LightShape::Triangle { v0, v1, v2 } => ([v0, v1, v2, v2], 3),
        }
    }

    /// Exact irradiance at `p` (unit normal `n`) from this light, ignoring occlusion, by Lambert's
    /// closed-form polygon formula E = L_e/2 · Σ_i θ_i (n · Γ_i), with v_i = vertex_i − p,
    /// θ_i = angle(v_i, v_{i+1}) and Γ_i = normalize(v_i × v_{i+1}), over the part of the polygon
    /// above p's tangent plane (clipped to it, Sutherland–Hodgman: a light straddling the plane, e.g.
    /// a ceiling light seen from the side of a box under it, gives its visible part's irradiance).
    ///
    /// Sign: with vertices counter-clockwise around `normal()` and `p` on the emitting side, the raw sum
    /// is negative, so we negate it; seen from the back the order flips. A one-sided light seen from
    /// behind gives 0.
    ///
    /// f32, term by term as `shaders/shadows_shade.wgsl` (`polygon_irradiance`) computes it, with
    /// its own [`angle`] (a GPU's `atan2` may be 4096 ulp off, and the sum cancels by about
    /// distance/size), so the two backends agree to round-off (docs/DESIGN-NOTES.md "Analytic
    /// unoccluded irradiance" under "SoftShadows after the suite").
    pub fn irradiance_unoccluded(&self, p: Vec3, n: Vec3) -> Vec3 {
        let (verts, count) = self.corners();
        // Which side p is on, from the unit normal (the WGSL mirror gets the same vector).
        let side = (p - verts[0]).dot(self.normal());
        if side == 0.0 || (side < 0.0 && !self.two_sided) {
            return Vec3::ZERO;
        }
        // Clip the polygon (relative to p) to the half-space n·v ≥ 0: at most one more vertex.
        let mut poly = [Vec3::ZERO; 5];
        let mut m = 0;
        for i in 0..count {
            let a = verts[i] - p;
            let b = verts[(i + 1) % count] - p;
            let (da, db) = (n.dot(a), n.dot(b));
            if da >= 0.0 {
                poly[m] = a;
                m += 1;
            }
            if (da >= 0.0) != (db >= 0.0) {
                poly[m] = a + (b - a) * (da / (da - db));
                m += 1;
            }
        }
        let mut sum = 0.0f32;
        for i in 0..m {
            let (a, b) = (poly[i], poly[(i + 1) % m]);
            let c = a.cross(b);
            let cl = c.length();
            if cl == 0.0 {
                continue;
            }
            let theta = angle(cl, a.dot(b));
            sum += theta * (n.dot(c) / cl);
        }
        let oriented = if side > 0.0 { -sum } else { sum };
        self.radiance * (0.5 * oriented.max(0.0))
    }
}

/// `atan2(y, x)` for `y ≥ 0` (an angle in [0, π]) from + − × ÷ only, so the WGSL mirror
/// (`shaders/shadows_shade.wgsl` `angle`) rounds alike: Vulkan allows `atan2` 4096 ulp. Octant
/// reduction to `t ∈ [0, 1]`, then `atan t = π/6 + atan((t − 1/√3)/(1 + t/√3))` above tan(π/12),
/// and the odd Taylor series to t¹³ on |t| ≤ tan(π/12) (truncation < 1e-8; measured against
/// `f64::atan2` in `scene/tests/scene_tests.rs`).
pub fn angle(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (num, den) = if ay <= ax { (ay, ax) } else { (ax, ay) };
    if den == 0.0 {
        return 0.0;
    }
    let t = num / den;
    const TAN_PI_12: f32 = 0.267_949_2;
    const INV_SQRT3: f32 = 0.577_350_26;
    let (t, base) =
        if t > TAN_PI_12 { ((t - INV_SQRT3) / (1.0 + t * INV_SQRT3), std::f32::consts::FRAC_PI_6) } else { (t, 0.0) };
    let t2 = t * t;
    let series = t
        * (1.0
            + t2 * (-1.0 / 3.0
                + t2 * (1.0 / 5.0 + t2 * (-1.0 / 7.0 + t2 * (1.0 / 9.0 + t2 * (-1.0 / 11.0 + t2 * (1.0 / 13.0)))))));
    let mut a = base + series;
    if ay > ax {
        a = std::f32::consts::FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = std::f32::consts::PI - a;
    }
    a
}
