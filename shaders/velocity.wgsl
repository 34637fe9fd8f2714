// velocity.wgsl — when two image-space velocities are one motion; mirrors `velocity_tolerance` and
// `same_velocity` of effects/src/motion/kernels/filter.rs (the constants are its
// VELOCITY_TOLERANCE_PX and VELOCITY_TOLERANCE_REL). Included by filter_motion.wgsl and
// motion_formulas.wgsl.

const VELOCITY_TOLERANCE_PX: f32 = 0.5;
const VELOCITY_TOLERANCE_REL: f32 = 0.25;

fn velocity_length(v: vec2<f32>) -> f32 {
    return sqrt(v.x * v.x + v.y * v.y);
}

fn velocity_tolerance(speed: f32) -> f32 {
    return VELOCITY_TOLERANCE_PX + VELOCITY_TOLERANCE_REL * speed;
}

fn same_velocity(a: vec2<f32>, b: vec2<f32>) -> bool {
    let tol = velocity_tolerance(max(velocity_length(a), velocity_length(b)));
    let d = a - b;
    return d.x * d.x + d.y * d.y <= tol * tol;
}
