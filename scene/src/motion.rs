//! Rigid motion of a group of triangles over the shutter (thesis App. B: "per-object linear motion").
//!
//! **Time.** `t ∈ [−1, 1]` over the shutter: −1 = shutter open, +1 = close, 0 = the shutter's centre
//! (docs/EQUATIONS.md "Motion": `t` replaces the lens coordinate `u`, Ω_t^max = 1). Everything that renders
//! without time uses `t = 0`.
//!
//! **Motion.** A [`RigidMotion`] moves points stored in their rest pose `x_rest` to
//! `x(t) = p + T(t) + R(t)·(x_rest − p)` with pivot `p`, `T(t) = lerp(T_open, T_close, s)`,
//! `R(t) = slerp(q_open, q_close, s)` and `s = (t + 1)/2`. Rotation is about the pivot, which moves
//! with the translation, so an object spins about its own centre while it travels.
//!
//! **One formula on CPU and GPU.** [`PreparedMotion`] holds what a time needs, computed once (on the
//! CPU, in f64 where it matters, and uploaded as is): the short-arc end quaternion, the half-angle θ
//! between the two quaternions, `1/sin θ` and the angular velocity. Per time only + − × ÷ √ run, in a
//! fixed order that `shaders/motion.wgsl` repeats line by line: `sin` is the explicit odd polynomial
//! [`sin_poly`] (not the platform's `sin`, which WGSL implementations approximate differently), the
//! quaternion becomes a rotation matrix by the explicit formula of [`RigidTransform`]. A GPU that
//! contracts `a·b + c` into an FMA differs in the last bits (see `common.wgsl`); otherwise the two agree
//! bit for bit.
//!
//! **Velocity** is `dx/dt` per unit `t` (so per *half* shutter), world space:
//! `dT/dt + ω × (x − p − T(t))` with `dT/dt = (T_close − T_open)/2` and ω the slerp's axis times its
//! angle per unit `t` (the rotation angle between the two ends is 2θ over `s ∈ [0, 1]`, so θ per unit
//! `t`). Image-space velocities (the thesis's `v`, pixels per half shutter) follow by projecting it.
//!
//! **Swept bounds.** [`RigidMotion::swept_bounds`] bounds a set of points over the whole shutter; see
//! there for why the bound is conservative.

use glam::{DQuat, DVec3, Quat, Vec3};

use crate::Aabb;

/// Rigid motion over the shutter (see the module doc): pivot `p`, translation `T` and rotation `q` at
/// shutter open (`[0]`, `t = −1`) and close (`[1]`, `t = +1`). The rotation quaternions must be unit
/// length ([`RigidMotion::validate`]); `q` and `−q` are the same rotation and slerp takes the short arc,
/// so a motion turns by at most 180° over the shutter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidMotion {
    pub pivot: Vec3,
    pub translation: [Vec3; 2],
    pub rotation: [Quat; 2],
}

impl Default for RigidMotion {
    fn default() -> Self {
        RigidMotion::IDENTITY
    }
}

/// Largest deviation of a rotation quaternion's length from 1 that [`RigidMotion::validate`] accepts.
pub const UNIT_TOLERANCE: f32 = 1e-3;

/// Below this half-angle (radians) between the two quaternions the rotation is interpolated
/// linearly and renormalised (nlerp) instead of slerped: `1/sin θ` would overflow at θ = 0, and at
/// θ < 1e-5 the two differ by under 1e-15 rad.
pub const NLERP_BELOW: f32 = 1e-5;

impl RigidMotion {
    /// No motion: every point stays where it is stored.
    pub const IDENTITY: RigidMotion =
        RigidMotion { pivot: Vec3::ZERO, translation: [Vec3::ZERO; 2], rotation: [Quat::IDENTITY; 2] };

    /// Pure translation from `open` to `close` (world units over the whole shutter).
    pub fn translation(open: Vec3, close: Vec3) -> RigidMotion {
        RigidMotion { translation: [open, close], ..RigidMotion::IDENTITY }
    }

    /// Rotation about `axis` through `pivot` from `open_rad` to `close_rad` (radians; at most π
    /// apart, since slerp takes the short arc), no translation.
    pub fn rotation_about(pivot: Vec3, axis: Vec3, open_rad: f32, close_rad: f32) -> RigidMotion {
        let axis = axis.normalize_or_zero();
        RigidMotion {
            pivot,
            translation: [Vec3::ZERO; 2],
            rotation: [Quat::from_axis_angle(axis, open_rad), Quat::from_axis_angle(axis, close_rad)],
        }
    }

    /// What is wrong with this motion, if anything: every number finite, both quaternions of unit
    /// length within [`UNIT_TOLERANCE`] (they are renormalised when prepared), pivot and translations
    /// within [`crate::limits::MAX_COORDINATE`].
    pub fn validate(&self) -> Result<(), String> {
        let vectors = [
            ("pivot", self.pivot),
            ("translation at shutter open", self.translation[0]),
            ("translation at shutter close", self.translation[1]),
        ];
        for (name, v) in vectors {
            if !v.is_finite() {
                return Err(format!("the {name} {v} is not finite"));
            }
            if v.abs().max_element() > crate::limits::MAX_COORDINATE {
                return Err(format!("the {name} {v} is beyond ±{:e} m", crate::limits::MAX_COORDINATE));
            }
        }
        for (k, q) in self.rotation.iter().enumerate() {
            let when = ["open", "close"][k];
            if !q.is_finite() {
                return Err(format!("the rotation at shutter {when} {q} is not finite"));
            }
            let len = q.length();
            if (len - 1.0).abs() > UNIT_TOLERANCE {
                return Err(format!("the rotation at shutter {when} {q} has length {len}, not a unit quaternion"));
            }
        }
        Ok(())
    }

    /// Whether every point stays where it is stored at every `t`: no translation at either end and
    /// both rotations the identity (`q = ±1`). Scenes keep such objects in the static tree.
    pub fn is_static(&self) -> bool {
        self.translation[0] == Vec3::ZERO
            && self.translation[1] == Vec3::ZERO
            && self.rotation.iter().all(|q| q.x == 0.0 && q.y == 0.0 && q.z == 0.0 && q.w.abs() == 1.0)
    }

    /// Whether points move over the shutter at all (the same pose at both ends): velocity is then
    /// zero everywhere, though the pose may differ from the rest pose.
    pub fn is_still(&self) -> bool {
        self.translation[0] == self.translation[1] && {
            let (a, b) = (self.rotation[0], self.rotation[1]);
            a == b || a == -b
        }
    }

    /// The per-time constants (see the module doc); scenes keep one per moving instance.
    pub fn prepare(&self) -> PreparedMotion {
        PreparedMotion::new(self)
    }

    /// The transform at time `t` (clamped to [−1, 1]).
    pub fn at(&self, t: f32) -> RigidTransform {
        self.prepare().at(t)
    }

    /// World-space velocity `dx/dt` (per unit `t`) of the point that is at `x_world` at time `t`.
    pub fn velocity(&self, t: f32, x_world: Vec3) -> Vec3 {
        self.prepare().velocity(t, x_world)
    }

    /// A conservative bound of `points` (rest pose) over the whole shutter `t ∈ [−1, 1]`.
    ///
    /// The shutter is split into `n` segments of equal `s`, each turning by `δ = 2θ/n` (n ≤ 16, so
    /// δ ≤ π/8 where the rotation allows). Within a segment `[t_a, t_b]`:
    /// - the translation moves linearly, so `T(t)` lies in the box of `T(t_a)` and `T(t_b)`;
    /// - slerp turns about one fixed axis at a monotone angle (`q(s) = Δq^s·q_open`; nlerp follows the
    ///   same great circle), so each `y = x_rest − p` travels on a circular arc of angle δ and radius
    ///   ρ ≤ |y| from `R(t_a)y` to `R(t_b)y`. For δ ≤ π every point of such an arc projects onto its
    ///   chord inside the chord and lies at most the sagitta `ρ(1 − cos(δ/2))` from it, so the arc lies
    ///   in the box of the chord's ends padded by `r(1 − cos(δ/2))`, `r = max |y|`;
    /// - `x(t) = p + T(t) + R(t)y` is then in the Minkowski sum of those two boxes, shifted by `p`.
    ///
    /// The union over segments and points bounds every point over the shutter; a point inside a
    /// triangle is a convex combination of its vertices at every `t` (the map is affine), so the box
    /// bounds the triangles too. Finally every side is padded by 1e-5 of the largest magnitude
    /// involved, far more than the f32 rounding of [`RigidTransform::point`] (a few ulps).
    /// `scene/tests/motion.rs` checks it against random times.
    pub fn swept_bounds(&self, points: &[Vec3]) -> Aabb {
        let m = self.prepare();
        let mut out = Aabb::empty();
        if points.is_empty() {
            return out;
        }
        let r = points.iter().map(|&x| (x - m.pivot).length()).fold(0.0f32, f32::max);
        let angle = 2.0 * m.theta as f64;
        let n = ((angle / (std::f64::consts::PI / 8.0)).ceil() as usize).clamp(1, 16);
        let delta = angle / n as f64;
        let sagitta = (r as f64 * (1.0 - (delta * 0.5).cos())) as f32;
        let at = |k: usize| m.at(-1.0 + 2.0 * k as f32 / n as f32);
        let mut ends = at(0);
        for k in 0..n {
            let next = at(k + 1);
            let (mut rot, mut tr) = (Aabb::empty(), Aabb::empty());
            for xf in [&ends, &next] {
                tr.grow(xf.translation);
                for &x in points {
                    rot.grow(xf.vector(x - m.pivot));
                }
            }
            out.grow(m.pivot + tr.min + rot.min - Vec3::splat(sagitta));
            out.grow(m.pivot + tr.max + rot.max + Vec3::splat(sagitta));
            ends = next;
        }
        let t_max = m.t[0].abs().max(m.t[1].abs()).max_element();
        let pad = 1e-5 * (m.pivot.abs().max_element() + t_max + r) + f32::MIN_POSITIVE;
        out.min -= Vec3::splat(pad);
        out.max += Vec3::splat(pad);
        out
    }

    /// [`RigidMotion::swept_bounds`] of a box's eight corners: bounds the whole box over the shutter.
    pub fn swept_box(&self, b: &Aabb) -> Aabb {
        let corners: Vec<Vec3> = (0..8)
            .map(|k| {
                Vec3::new(
                    if k & 1 == 0 { b.min.x } else { b.max.x },
                    if k & 2 == 0 { b.min.y } else { b.max.y },
                    if k & 4 == 0 { b.min.z } else { b.max.z },
                )
            })
            .collect();
        self.swept_bounds(&corners)
    }
}

/// A [`RigidMotion`] ready to evaluate at any time: the numbers `shaders/motion.wgsl` receives per
/// instance (`backends/src/gpu/scene.rs`), so both backends start from the same bits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreparedMotion {
    pub pivot: Vec3,
    /// Translation at open and close.
    pub t: [Vec3; 2],
    /// Unit rotations at open and close; `q[1]` is negated where needed so `q[0]·q[1] ≥ 0` (the
    /// short arc), which is the same rotation.
    pub q: [Quat; 2],
    /// Half-angle between `q[0]` and `q[1]` as 4-vectors, in [0, π/2]: the rotation turns by 2θ over
    /// the shutter. Computed in f64 as `2·atan2(|q1 − q0|, |q1 + q0|)`, accurate at small angles
    /// (acos is not).
    pub theta: f32,
    /// `1 / sin_poly(θ)`; 0 when θ < [`NLERP_BELOW`] (then nlerp is used).
    pub inv_sin_theta: f32,
    /// Angular velocity per unit `t` (world space): the axis of `q1·q0⁻¹` times θ.
    pub omega: Vec3,
}

impl PreparedMotion {
    fn new(m: &RigidMotion) -> PreparedMotion {
        // A quaternion unit to f32 precision keeps its bits (so the ends are exactly the given
        // rotations); others are renormalised in f64.
        let unit = |q: Quat| {
            if (q.length_squared() - 1.0).abs() <= 4.0 * f32::EPSILON {
                return q.as_dquat();
            }
            let d = q.as_dquat();
            let len = d.length();
            if len.is_finite() && len > 0.0 {
                d / len
            } else {
                DQuat::IDENTITY
            }
        };
        let q0 = unit(m.rotation[0]);
        let mut q1 = unit(m.rotation[1]);
        if q0.dot(q1) < 0.0 {
            q1 = -q1;
        }
        let theta = 2.0 * (q1 - q0).length().atan2((q1 + q0).length());
        // Δq = q1·q0⁻¹: its vector part is sin θ · axis (its scalar part q0·q1 = cos θ).
        let dq = q1 * q0.conjugate();
        let v = DVec3::new(dq.x, dq.y, dq.z);
        let sin = v.length();
        let omega = if sin > 0.0 { v * (theta / sin) } else { DVec3::ZERO };
        let theta32 = theta as f32;
        let inv_sin_theta = if theta32 < NLERP_BELOW { 0.0 } else { 1.0 / sin_poly(theta32) };
        PreparedMotion {
            pivot: m.pivot,
            t: m.translation,
            q: [q0.as_quat(), q1.as_quat()],
            theta: theta32,
            inv_sin_theta,
            omega: omega.as_vec3(),
        }
    }

    /// Whether rotation is interpolated by nlerp (see [`NLERP_BELOW`]).
    pub fn nlerp(&self) -> bool {
        self.inv_sin_theta == 0.0
    }

    /// The transform at time `t` (clamped to [−1, 1]); the ends are exact (`T_open`, `q_open` at −1),
    /// and so is a rotation that does not change (`q[0] == q[1]`).
    ///
    /// Mirrored by `instance_transform` in `shaders/motion.wgsl`, operation for operation.
    #[inline]
    pub fn at(&self, t: f32) -> RigidTransform {
        let s = (t + 1.0) * 0.5;
        // `s.is_nan() || s <= 0.0` is `!(s > 0.0)`, as the WGSL writes it: a NaN time holds the open pose.
        let (translation, q) = if s.is_nan() || s <= 0.0 {
            (self.t[0], self.q[0])
        } else if s >= 1.0 {
            (self.t[1], self.q[1])
        } else if self.q[0] == self.q[1] {
            // No rotation (or none that changes): the rotation stays exactly the given one, so a
            // pure translation rotates nothing, not even by rounding.
            (self.t[0] * (1.0 - s) + self.t[1] * s, self.q[0])
        } else {
            let (w0, w1) = if self.nlerp() {
                (1.0 - s, s)
            } else {
                (sin_poly((1.0 - s) * self.theta) * self.inv_sin_theta, sin_poly(s * self.theta) * self.inv_sin_theta)
            };
            let (a, b) = (self.q[0], self.q[1]);
            let q = [a.x * w0 + b.x * w1, a.y * w0 + b.y * w1, a.z * w0 + b.z * w1, a.w * w0 + b.w * w1];
            let inv_len = 1.0 / (((q[0] * q[0] + q[1] * q[1]) + q[2] * q[2]) + q[3] * q[3]).sqrt();
            let q = Quat::from_xyzw(q[0] * inv_len, q[1] * inv_len, q[2] * inv_len, q[3] * inv_len);
            (self.t[0] * (1.0 - s) + self.t[1] * s, q)
        };
        RigidTransform::new(self.pivot, translation, q)
    }

    /// `dT/dt + ω × (x − p − T(t))`: the world velocity per unit `t` of the point at `x_world` at `t`.
    /// Mirrored by `object_velocity` in `shaders/motion.wgsl`.
    #[inline]
    pub fn velocity(&self, t: f32, x_world: Vec3) -> Vec3 {
        let xf = self.at(t);
        (self.t[1] - self.t[0]) * 0.5 + self.omega.cross(x_world - self.pivot - xf.translation)
    }
}

/// `sin x` for `x ∈ [0, π/2]` as its Taylor polynomial to x¹³ (truncation error below 7e-10 there;
/// relative accuracy also near 0), evaluated by Horner in a fixed order so `shaders/motion.wgsl`'s
/// `sin_poly` computes the same number.
#[inline]
pub fn sin_poly(x: f32) -> f32 {
    let x2 = x * x;
    let mut p = 1.605_904_4e-10_f32; // 1/13!
    p = p * x2 - 2.505_210_8e-8; // 1/11!
    p = p * x2 + 2.755_731_9e-6; // 1/9!
    p = p * x2 - 1.984_127e-4; // 1/7!
    p = p * x2 + 8.333_334e-3; // 1/5!
    p = p * x2 - 1.666_666_7e-1; // 1/3!
    (x * x2) * p + x
}

/// A rigid transform at one time: `x_world = p + T + R·(x_rest − p)`, with `R` the rotation matrix
/// of a unit quaternion written out explicitly (rows `m`), so `shaders/motion.wgsl` builds the same
/// matrix. The inverse uses the transpose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidTransform {
    pub pivot: Vec3,
    pub translation: Vec3,
    pub rotation: Quat,
    /// Rows of the rotation matrix.
    pub m: [[f32; 3]; 3],
}

impl RigidTransform {
    /// The transform of pivot `pivot`, translation `translation` and unit rotation `q`.
    #[inline]
    pub fn new(pivot: Vec3, translation: Vec3, q: Quat) -> RigidTransform {
        let (x, y, z, w) = (q.x, q.y, q.z, q.w);
        let (x2, y2, z2) = (x + x, y + y, z + z);
        let (xx, xy, xz) = (x * x2, x * y2, x * z2);
        let (yy, yz, zz) = (y * y2, y * z2, z * z2);
        let (wx, wy, wz) = (w * x2, w * y2, w * z2);
        RigidTransform {
            pivot,
            translation,
            rotation: q,
            m: [
                [1.0 - (yy + zz), xy - wz, xz + wy],
                [xy + wz, 1.0 - (xx + zz), yz - wx],
                [xz - wy, yz + wx, 1.0 - (xx + yy)],
            ],
        }
    }

    /// `R·v` (directions, normals, edges).
    #[inline]
    pub fn vector(&self, v: Vec3) -> Vec3 {
        let m = &self.m;
        Vec3::new(
            (m[0][0] * v.x + m[0][1] * v.y) + m[0][2] * v.z,
            (m[1][0] * v.x + m[1][1] * v.y) + m[1][2] * v.z,
            (m[2][0] * v.x + m[2][1] * v.y) + m[2][2] * v.z,
        )
    }

    /// `Rᵀ·v`.
    #[inline]
    pub fn inverse_vector(&self, v: Vec3) -> Vec3 {
        let m = &self.m;
        Vec3::new(
            (m[0][0] * v.x + m[1][0] * v.y) + m[2][0] * v.z,
            (m[0][1] * v.x + m[1][1] * v.y) + m[2][1] * v.z,
            (m[0][2] * v.x + m[1][2] * v.y) + m[2][2] * v.z,
        )
    }

    /// Rest pose → world: `p + T + R·(x − p)`.
    #[inline]
    pub fn point(&self, x: Vec3) -> Vec3 {
        (self.pivot + self.translation) + self.vector(x - self.pivot)
    }

    /// World → rest pose: `p + Rᵀ·(x − p − T)`.
    #[inline]
    pub fn inverse_point(&self, x: Vec3) -> Vec3 {
        self.pivot + self.inverse_vector((x - self.pivot) - self.translation)
    }
}
