//! Pure formulas of mixed reality: differential compositing (eq. 6.2). WGSL mirror:
//! `shaders/mr_composite.wgsl`.

use glam::Vec3;

/// Eq. 6.2 at one pixel: `(1 − M) k_V (E_V^dir + E_V^ind) + M (E_RV / E_R) L_cam`, the ratio per
/// channel and 1 where `E_R` is not positive (a real point the real light does not reach: `L_cam`
/// holds no light to scale, so it is kept). `M = 1` gives exactly `ratio · L_cam` and `M = 0` exactly
/// the virtual radiance (nothing of the other term is evaluated).
pub fn composite(e: [[f32; 3]; 6], texture: [f32; 4], l_cam: Vec3) -> [f32; 3] {
    let v = |k: usize| Vec3::from(e[k]);
    let m = texture[3];
    let e_r = v(0) + v(1);
    let e_rv = v(2) + v(3);
    let ratio = |a: f32, b: f32| if b > 0.0 && (a / b).is_finite() { a / b } else { 1.0 };
    let real = l_cam * Vec3::new(ratio(e_rv.x, e_r.x), ratio(e_rv.y, e_r.y), ratio(e_rv.z, e_r.z));
    let virt = Vec3::new(texture[0], texture[1], texture[2]) * (v(4) + v(5));
    let out = if m >= 1.0 {
        real
    } else if m <= 0.0 {
        virt
    } else {
        virt * (1.0 - m) + real * m
    };
    out.to_array()
}
