// motion.wgsl — wedge_scene::motion on the GPU: a moving instance's rigid transform at a time of the
// shutter (t ∈ [−1, 1]: −1 open, +1 close, 0 the centre). Pure math on the `Instance` record that
// backends/src/gpu/scene.rs packs from `PreparedMotion` (so both backends start from the same θ,
// 1/sin θ and short-arc quaternions); scene.wgsl reads the records and includes this file.
//
// Operation for operation the Rust of scene/src/motion.rs (`PreparedMotion::at`, `sin_poly`,
// `RigidTransform`): no platform sin/acos, a fixed evaluation order, so the two agree bit for bit
// unless the GPU contracts a·b + c into an FMA (see common.wgsl).

// `Instance::root` etc.: `NO_INSTANCE` marks an object or light at rest.
const NO_INSTANCE: u32 = 0xffffffffu;

// wedge_scene::Instance + PreparedMotion (backends/src/gpu/scene.rs `GpuInstance`, 128 bytes).
struct Instance {
    swept_min: vec3<f32>,
    root: u32,           // its tree's root node in the scene's node array
    swept_max: vec3<f32>,
    pivot: vec3<f32>,
    theta: f32,          // half-angle between q0 and q1
    t0: vec3<f32>,       // translation at open
    inv_sin_theta: f32,  // 1 / sin_poly(θ); 0 = nlerp (θ tiny)
    t1: vec3<f32>,       // translation at close
    q0: vec4<f32>,       // rotation at open (x, y, z, w)
    q1: vec4<f32>,       // rotation at close, on the short arc from q0
    omega: vec3<f32>,    // angular velocity per unit t
}

// x_world = pivot + translation + R·(x_rest − pivot); m0..m2 the rows of R.
struct RigidTransform {
    pivot: vec3<f32>,
    translation: vec3<f32>,
    m0: vec3<f32>,
    m1: vec3<f32>,
    m2: vec3<f32>,
}

// motion::sin_poly: sin x on [0, π/2], Taylor to x^13 by Horner.
fn sin_poly(x: f32) -> f32 {
    let x2 = x * x;
    var p = 1.6059044e-10;
    p = p * x2 - 2.5052108e-8;
    p = p * x2 + 2.7557319e-6;
    p = p * x2 - 1.984127e-4;
    p = p * x2 + 8.333334e-3;
    p = p * x2 - 1.6666667e-1;
    return (x * x2) * p + x;
}

// RigidTransform::new: the rotation matrix of a unit quaternion, written out.
fn rigid_transform(pivot: vec3<f32>, translation: vec3<f32>, q: vec4<f32>) -> RigidTransform {
    let x2 = q.x + q.x;
    let y2 = q.y + q.y;
    let z2 = q.z + q.z;
    let xx = q.x * x2;
    let xy = q.x * y2;
    let xz = q.x * z2;
    let yy = q.y * y2;
    let yz = q.y * z2;
    let zz = q.z * z2;
    let wx = q.w * x2;
    let wy = q.w * y2;
    let wz = q.w * z2;
    return RigidTransform(
        pivot,
        translation,
        vec3<f32>(1.0 - (yy + zz), xy - wz, xz + wy),
        vec3<f32>(xy + wz, 1.0 - (xx + zz), yz - wx),
        vec3<f32>(xz - wy, yz + wx, 1.0 - (xx + yy)),
    );
}

// PreparedMotion::at: the ends exact, a rotation that does not change exact, slerp by sin_poly
// (nlerp below θ = 1e-5), renormalised.
fn instance_transform(inst: Instance, t: f32) -> RigidTransform {
    let s = (t + 1.0) * 0.5;
    if (!(s > 0.0)) {
        return rigid_transform(inst.pivot, inst.t0, inst.q0);
    }
    if (s >= 1.0) {
        return rigid_transform(inst.pivot, inst.t1, inst.q1);
    }
    let translation = inst.t0 * (1.0 - s) + inst.t1 * s;
    if (all(inst.q0 == inst.q1)) {
        return rigid_transform(inst.pivot, translation, inst.q0);
    }
    var w0 = 1.0 - s;
    var w1 = s;
    if (inst.inv_sin_theta != 0.0) {
        w0 = sin_poly((1.0 - s) * inst.theta) * inst.inv_sin_theta;
        w1 = sin_poly(s * inst.theta) * inst.inv_sin_theta;
    }
    let a = inst.q0;
    let b = inst.q1;
    let q = vec4<f32>(a.x * w0 + b.x * w1, a.y * w0 + b.y * w1, a.z * w0 + b.z * w1, a.w * w0 + b.w * w1);
    let inv_len = 1.0 / sqrt(((q.x * q.x + q.y * q.y) + q.z * q.z) + q.w * q.w);
    return rigid_transform(inst.pivot, translation, q * inv_len);
}

// R·v
fn xf_vector(xf: RigidTransform, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        (xf.m0.x * v.x + xf.m0.y * v.y) + xf.m0.z * v.z,
        (xf.m1.x * v.x + xf.m1.y * v.y) + xf.m1.z * v.z,
        (xf.m2.x * v.x + xf.m2.y * v.y) + xf.m2.z * v.z,
    );
}

// Rᵀ·v
fn xf_inverse_vector(xf: RigidTransform, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        (xf.m0.x * v.x + xf.m1.x * v.y) + xf.m2.x * v.z,
        (xf.m0.y * v.x + xf.m1.y * v.y) + xf.m2.y * v.z,
        (xf.m0.z * v.x + xf.m1.z * v.y) + xf.m2.z * v.z,
    );
}

// Rest pose → world.
fn xf_point(xf: RigidTransform, x: vec3<f32>) -> vec3<f32> {
    return (xf.pivot + xf.translation) + xf_vector(xf, x - xf.pivot);
}

// World → rest pose.
fn xf_inverse_point(xf: RigidTransform, x: vec3<f32>) -> vec3<f32> {
    return xf.pivot + xf_inverse_vector(xf, (x - xf.pivot) - xf.translation);
}

// PreparedMotion::velocity: dT/dt + ω × (x − p − T(t)), per unit t.
fn instance_velocity(inst: Instance, t: f32, x: vec3<f32>) -> vec3<f32> {
    let xf = instance_transform(inst, t);
    return (inst.t1 - inst.t0) * 0.5 + cross3(inst.omega, (x - inst.pivot) - xf.translation);
}
