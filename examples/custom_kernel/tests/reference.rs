//! A node written outside wedge gets a Monte Carlo reference from its declarations alone: `Exposure`
//! declares its stage (image-space) and keeps its default reference role, so the reference is
//! SoftShadows' unfiltered Monte Carlo estimate scaled by `2^stops`.
use wedge::backends::{cpu::CpuBackend, BufferData, Silent};
use wedge::graph::{ParamValue, Stage};
use wedge::Overrides;

fn colour(stops: f64) -> Vec<[f32; 3]> {
    let ov = Overrides {
        width: Some(24),
        height: Some(18),
        params: vec![("exposure".into(), "stops".into(), ParamValue::Float(stops))],
        ..Default::default()
    };
    let s = wedge_custom_kernel::reference(&ov, 16, "stratified").unwrap();
    let names: Vec<&str> = s.schedule.passes.iter().map(|p| p.name.as_str()).collect();
    assert!(names.contains(&"exposure.scale"), "{names:?}");
    assert!(s.schedule.passes.iter().all(|p| p.stage != Stage::Filter), "{names:?}");
    let run = s.run(&mut CpuBackend::new(), &Silent).unwrap();
    match run.output("color") {
        Some(BufferData::Vec3(v)) => v.clone(),
        other => panic!("color is {other:?}"),
    }
}

#[test]
fn custom_node_reference_is_the_scaled_monte_carlo_estimate() {
    let (plain, bright) = (colour(0.0), colour(1.5));
    let scale = 2f32.powf(1.5);
    let lit = plain.iter().filter(|p| p[0] > 0.0).count();
    assert!(lit > plain.len() / 4, "{lit} of {} pixels lit", plain.len());
    for (a, b) in plain.iter().zip(&bright) {
        for c in 0..3 {
            // Same graph, same streams: the only difference is the one multiply by 2^1.5.
            assert_eq!(b[c], a[c] * scale);
        }
    }
}
