//! A node written outside wedge gets a Monte Carlo reference from its declarations alone: Fog
//! declares an image-space pass (kept in a reference) and no filter, so the reference is
//! SoftShadows' unfiltered Monte Carlo estimate seen through the fog.
use wedge::backends::{cpu::CpuBackend, BufferData, Silent};
use wedge::graph::{ParamValue, Stage};
use wedge::{Overrides, Session};

fn reference(density: f64) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let set = |p: &str, v: ParamValue| ("fog".to_string(), p.to_string(), v);
    let ov = Overrides {
        width: Some(24),
        height: Some(18),
        params: vec![set("density", ParamValue::Float(density)), set("colour", ParamValue::Vec3([0.0; 3]))],
        ..Default::default()
    };
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/fog.ron");
    let s = Session::reference_with(&wedge_fog::registries(), Some(&path), 16, "stratified", &ov).unwrap();
    let names: Vec<&str> = s.schedule.passes.iter().map(|p| p.name.as_str()).collect();
    assert!(names.contains(&"fog.apply"), "{names:?}");
    assert!(s.schedule.passes.iter().all(|p| p.stage != Stage::Filter), "{names:?}");
    let run = s.run(&mut CpuBackend::new(), &Silent).unwrap();
    let image = |name| match run.output(name) {
        Some(BufferData::Vec3(v)) => v.clone(),
        other => panic!("{name} is {other:?}"),
    };
    (image("color"), image("unfiltered"))
}

#[test]
fn the_users_node_gets_a_reference_from_its_declarations() {
    // No fog: the reference's colour is SoftShadows' Monte Carlo estimate, bit for bit.
    let (clear, unfiltered) = reference(0.0);
    assert_eq!(clear, unfiltered);
    let lit = clear.iter().filter(|p| p[0] > 0.0).count();
    assert!(lit > clear.len() / 4, "{lit} of {} pixels lit", clear.len());
    // Black fog of density 0.3/m: every lit pixel darker by exp(-0.3·distance), none brighter.
    let (foggy, _) = reference(0.3);
    assert!(foggy.iter().zip(&clear).all(|(f, c)| (0..3).all(|i| f[i] <= c[i])));
    assert!(foggy.iter().zip(&clear).filter(|(f, c)| f[0] < c[0]).count() >= lit * 9 / 10);
}
