//! Progressive refinement by plain frame averaging: while nothing changes the viewer renders frame
//! after frame with new seeds and keeps the running mean of every output buffer, so the image
//! converges. The mean of one frame is that frame, bit for bit (what `wedge render` writes).

use wedge_backends::{BufferData, RunResult};

/// The running mean of the runs since the last change.
#[derive(Default)]
pub struct Accumulator {
    /// The mean run: the last run's timings, rays and sinks, the mean of every output.
    mean: Option<RunResult>,
    frames: u32,
}

impl Accumulator {
    /// Forget everything (a parameter, the camera or the pipeline changed).
    pub fn reset(&mut self) {
        self.mean = None;
        self.frames = 0;
    }

    /// Frames averaged so far.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// The mean so far (`None` before the first frame).
    pub fn mean(&self) -> Option<&RunResult> {
        self.mean.as_ref()
    }

    /// Add one frame's run.
    pub fn add(&mut self, run: RunResult) {
        self.frames += 1;
        let Some(mean) = self.mean.as_mut() else {
            self.mean = Some(run);
            return;
        };
        // Running mean m += (x − m) / n: stays exact for n = 1 and needs no second buffer.
        let weight = 1.0 / self.frames as f32;
        for (key, x) in &run.outputs {
            if let Some(m) = mean.outputs.get_mut(key) {
                blend(m, x, weight);
            }
        }
        mean.timings = run.timings;
        mean.rays = run.rays;
        mean.sinks = run.sinks;
    }
}

/// `m += (x − m) · weight` component-wise for float buffers; integer and struct buffers (ids,
/// packed records) have no meaningful mean and keep the latest frame's contents.
fn blend(m: &mut BufferData, x: &BufferData, weight: f32) {
    fn mix<const N: usize>(m: &mut [[f32; N]], x: &[[f32; N]], w: f32) {
        for (a, b) in m.iter_mut().zip(x) {
            for c in 0..N {
                a[c] += (b[c] - a[c]) * w;
            }
        }
    }
    match (m, x) {
        (BufferData::F32(m), BufferData::F32(x)) => m.iter_mut().zip(x).for_each(|(a, b)| *a += (b - *a) * weight),
        (BufferData::Vec2(m), BufferData::Vec2(x)) => mix(m, x, weight),
        (BufferData::Vec3(m), BufferData::Vec3(x)) => mix(m, x, weight),
        (BufferData::Vec4(m), BufferData::Vec4(x)) => mix(m, x, weight),
        (m, x) => *m = x.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(v: f32) -> RunResult {
        RunResult {
            outputs: [(("out".into(), "color".into()), BufferData::Vec3(vec![[v, 2.0 * v, 0.1]; 4]))].into(),
            sinks: Default::default(),
            timings: Vec::new(),
            rays: Default::default(),
            allocations: 0,
            history: Default::default(),
        }
    }

    #[test]
    fn one_frame_is_itself_and_more_frames_average() {
        let mut acc = Accumulator::default();
        acc.add(run(0.3));
        assert_eq!(acc.mean().and_then(|m| m.output("color")), run(0.3).output("color"));
        acc.add(run(0.5));
        acc.add(run(0.7));
        let BufferData::Vec3(px) = acc.mean().and_then(|m| m.output("color")).expect("color") else { panic!("vec3") };
        assert!((px[0][0] - 0.5).abs() < 1e-6 && (px[0][1] - 1.0).abs() < 1e-6, "{:?}", px[0]);
        assert_eq!(acc.frames(), 3);
        acc.reset();
        assert!(acc.mean().is_none());
    }
}
