use glam::Vec3;
fn main() {
    let mode = std::env::args().nth(1).unwrap_or_default();
    let n: usize = std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(100_000);
    let mut seed = 1u64;
    let mut rnd = || { seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407); ((seed >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0 };
    if mode == "builtins" {
        for name in ["grids", "curved", "heavy", "cornell"] {
            let sc = wedge_scene::load(&wedge_scene::SceneSource::Builtin(name.into())).unwrap();
            let tris: Vec<[Vec3; 3]> = sc.triangles.iter().map(|t| t.vertices()).collect();
            let sub: Vec<[Vec3; 3]> = tris.iter().step_by((tris.len() / 16384).max(1)).copied().collect();
            let b = wedge_scene::bvh::build_with(&sub, obvhs::BvhBuildParams::medium_build());
            println!("{name}: {} tris depth {} ; probe {} depth {} warnings {:?}", tris.len(), wedge_scene::bvh::tree_depth(&sc.bvh), sub.len(), b.depth, sc.warnings);
        }
        return;
    }
    let tris: Vec<[Vec3; 3]> = (0..n)
        .map(|_| match mode.as_str() {
            "copies" => [Vec3::ZERO, Vec3::X, Vec3::Y],
            "tricentroid" => { let a = 1.0 + 0.5 * rnd(); let b = 1.0 + 0.5 * rnd(); let t = glam::Quat::from_rotation_z(3.0 * rnd()) * glam::Quat::from_rotation_x(3.0 * rnd()); [t * Vec3::new(a, 0.0, 0.0), t * Vec3::new(-a / 2.0, b, 0.0), t * Vec3::new(-a / 2.0, -b, 0.0)] }
            "sizes" => { let s = 1.0 + 0.5 * rnd(); [Vec3::splat(-s), Vec3::splat(s), Vec3::new(rnd(), rnd(), rnd()) * s] }
            "rot" => { let a = 3.0 * rnd(); let (c, si) = (a.cos(), a.sin()); let r = 1.0 + 0.5 * rnd(); [Vec3::new(c, si, 0.0) * r, Vec3::new(-c, -si, 0.0) * r, Vec3::new(0.0, 0.0, r)] }
            _ => [Vec3::splat(-1.0), Vec3::splat(1.0), Vec3::new(rnd(), rnd(), rnd())],
        })
        .collect();
    let t = std::time::Instant::now();
    let b = wedge_scene::bvh::build(&tris);
    println!("{mode} {n} tris: {:?}, {} nodes, depth {}", t.elapsed(), b.nodes.len(), b.depth);
}
#[allow(dead_code)]
fn probe_builtins() {}
