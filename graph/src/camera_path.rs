//! A pipeline's `camera_path`: the one interpolation of its keys (what a sequence renders with) and
//! the check that every camera along it passes the camera rules ([`CameraSpec::problems`]), so a path
//! is refused where the same camera written as a `camera:` block would be.
//!
//! Between two keys position and look-at move linearly, so the view direction
//! `d(s) = look_at(s) − position(s) = d_a + s (d_b − d_a)`, `s ∈ [0, 1]`, is linear too. The rules a
//! path can break between valid keys are about `d`: it is zero (position meets look-at, e.g. keys
//! that swap the two) or parallel to `up` (the sine of their angle below the rule's threshold). Both
//! measures are smooth in `s` with few critical points: `|d(s)|²` is a quadratic (one minimum), and
//! `sin²(d(s), up) = |d(s) × û|² / |d(s)|²` is a ratio of quadratics whose derivative has a quadratic
//! numerator (two critical points at most). Between critical points a measure is monotone, so its
//! smallest value over the whole frames of a segment is at a key or at a whole frame next to a
//! critical point: checking those few frames with the camera rules checks every frame, however long
//! the segment. A critical point between two whole frames where the measure reaches the degenerate
//! value itself (the path passes through its target, or along `up`) is refused too: the image turns
//! around between two frames, and whether a frame lands on that point is an accident of the keys'
//! frame numbers.

use crate::pipeline::{CameraKey, CameraProblem, CameraSpec, MIN_UP_SINE};

type V3 = (f32, f32, f32);

/// Position and look-at of the path at `frame`: the keys' values linearly interpolated between
/// them (`a (1 − s) + b s` in f32, as the renderer has always computed it), held before the first
/// and after the last key; `None` without keys.
pub fn camera_path_at(keys: &[CameraKey], frame: u32) -> Option<(V3, V3)> {
    let first = keys.first()?;
    if frame <= first.frame {
        return Some((first.position, first.look_at));
    }
    for pair in keys.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        if frame <= b.frame {
            let s = (frame - a.frame) as f32 / (b.frame - a.frame) as f32;
            let lerp = |x: V3, y: V3| (x.0 * (1.0 - s) + y.0 * s, x.1 * (1.0 - s) + y.1 * s, x.2 * (1.0 - s) + y.2 * s);
            return Some((lerp(a.position, b.position), lerp(a.look_at, b.look_at)));
        }
    }
    keys.last().map(|k| (k.position, k.look_at))
}

/// One camera of the path that breaks a camera rule.
#[derive(Clone, Debug, PartialEq)]
pub struct PathProblem {
    /// Index of the segment's first key (the second is `key + 1`).
    pub key: usize,
    /// The frame where the rule breaks: a whole frame, or a point between two (`frame.fract() != 0`).
    pub frame: f64,
    pub problem: CameraProblem,
}

/// Relative size below which `|d(s)|` at a critical point between whole frames counts as zero: far
/// below f32's resolution (the keys are f32), far above f64's rounding of the root.
const THROUGH_TARGET: f64 = 1e-9;

/// Every segment of `keys` (in increasing frame order; order and finiteness are checked by the
/// validator) where a camera along it breaks a rule about its view, `camera` giving the rest (its
/// `up`; its own position and look-at are replaced). Without `check_up` (the scene's camera decides `up`,
/// and no scene is loaded yet) only the view direction is checked. At most one problem per segment.
pub fn camera_path_problems(keys: &[CameraKey], camera: &CameraSpec, check_up: bool) -> Vec<PathProblem> {
    // An `up` that is no direction at all is the camera block's problem, reported there once.
    let up = v(camera.up);
    let check_up = check_up && dot(up, up) > 0.0 && dot(up, up).is_finite();
    let view_rule = |p: &CameraProblem| matches!(p.field, "look_at" | "position") || (check_up && p.field == "up");
    let at_frame = |frame: u32| -> Option<CameraProblem> {
        let (position, look_at) = camera_path_at(keys, frame)?;
        CameraSpec { position, look_at, ..camera.clone() }.problems().into_iter().find(view_rule)
    };
    let mut out = Vec::new();
    for (k, pair) in keys.windows(2).enumerate() {
        let (a, b) = (&pair[0], &pair[1]);
        if b.frame <= a.frame {
            continue; // reported by the validator
        }
        let span = f64::from(b.frame - a.frame);
        let segment = Segment::new(a, b, camera.up);
        let mut frames = vec![a.frame, b.frame];
        for s in segment.critical_points(check_up) {
            let f = f64::from(a.frame) + s * span;
            frames.extend([f.floor() as u32, f.ceil() as u32]);
            if f.fract() != 0.0 {
                if let Some(problem) = segment.degenerate_at(s).into_iter().find(view_rule) {
                    out.push(PathProblem { key: k, frame: f, problem });
                    break;
                }
            }
        }
        frames.sort_unstable();
        frames.dedup();
        if out.last().is_some_and(|p| p.key == k) {
            continue;
        }
        let found = frames.iter().find_map(|&f| at_frame(f).map(|p| (f, p)));
        let found = found.or_else(|| segment.too_close_for_f32((a.frame, b.frame), &frames, check_up));
        if let Some((frame, problem)) = found {
            out.push(PathProblem { key: k, frame: f64::from(frame), problem });
        }
    }
    out
}

/// A bound on how far [`camera_path_at`]'s f32 arithmetic (and the renderer's `look_at − position`)
/// moves the view direction from its exact value, relative to the largest coordinate of the
/// segment: a few roundings of each coordinate (the fraction, `1 − s`, two products, a sum, the
/// difference), each at most half an f32 ulp of that coordinate, with room to spare, times √3.
const F32_DRIFT: f64 = 16.0 * 1.7320508 * f32::EPSILON as f64;

/// One segment's view direction `d(s) = d_a + s e` in f64 (exact for the keys' f32 values), with
/// `û`'s cross products for the up rule.
struct Segment {
    pos: ([f64; 3], [f64; 3]),
    at: ([f64; 3], [f64; 3]),
    d: [f64; 3],
    e: [f64; 3],
    up: [f64; 3],
}

fn v(t: V3) -> [f64; 3] {
    [f64::from(t.0), f64::from(t.1), f64::from(t.2)]
}
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
fn lerp(a: [f64; 3], b: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s, a[2] + (b[2] - a[2]) * s]
}

impl Segment {
    fn new(a: &CameraKey, b: &CameraKey, up: V3) -> Segment {
        let (pos, at) = ((v(a.position), v(b.position)), (v(a.look_at), v(b.look_at)));
        let d = sub(at.0, pos.0);
        let e = sub(sub(at.1, pos.1), d);
        Segment { pos, at, d, e, up: v(up) }
    }

    /// The `s ∈ (0, 1)` where `|d|²` has its minimum and where `sin²(d, up)` has a critical point.
    fn critical_points(&self, check_up: bool) -> Vec<f64> {
        let (d, e) = (self.d, self.e);
        let mut out = Vec::new();
        if dot(e, e) > 0.0 {
            out.push(-dot(d, e) / dot(e, e));
        }
        let up_len = dot(self.up, self.up).sqrt();
        if check_up {
            let u = self.up.map(|x| x / up_len);
            // sin² = (α + 2βs + γs²) / (a + 2bs + cs²); its derivative's numerator is
            // (γb − βc)s² + (γa − αc)s + (βa − αb) (the cubic terms cancel).
            let (c0, c1) = (cross(d, u), cross(e, u));
            let (alpha, beta, gamma) = (dot(c0, c0), dot(c0, c1), dot(c1, c1));
            let (qa, qb, qc) = (dot(d, d), dot(d, e), dot(e, e));
            out.extend(quadratic_roots(gamma * qb - beta * qc, gamma * qa - alpha * qc, beta * qa - alpha * qb));
        }
        out.retain(|s| s.is_finite() && *s > 0.0 && *s < 1.0);
        out
    }

    /// Between the frames checked, a measure is monotone in exact arithmetic, but the frames render
    /// with f32 interpolation, which moves the view direction by up to [`F32_DRIFT`] × the largest
    /// coordinate. Where the exact measures at the checked `frames` (which hold the smallest
    /// `|d|` and sine of every whole frame) come within that drift of a rule, a frame between them
    /// may break it in f32 although none checked does (e.g. a camera 0.06 from its target at
    /// x = 10⁶, where f32 steps are 0.06): refused as too close to call, at the closest frame.
    fn too_close_for_f32(
        &self,
        (first, last): (u32, u32),
        frames: &[u32],
        check_up: bool,
    ) -> Option<(u32, CameraProblem)> {
        let coords = [self.pos.0, self.pos.1, self.at.0, self.at.1];
        let largest = coords.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        let drift = F32_DRIFT * largest;
        let at = |f: u32| {
            let s = f64::from(f - first) / f64::from(last - first);
            sub(lerp(self.at.0, self.at.1, s), lerp(self.pos.0, self.pos.1, s))
        };
        let (near, d) = frames.iter().map(|&f| (f, at(f))).min_by(|x, y| dot(x.1, x.1).total_cmp(&dot(y.1, y.1)))?;
        let length = dot(d, d).sqrt();
        if length <= 2.0 * drift {
            let message = format!(
                "camera `look_at` comes within {length:.3e} of `position` at frame {near}, closer than single precision (what frames are rendered in) resolves at coordinates of magnitude {largest:.3e}: some frame could have no view direction"
            );
            return Some((near, CameraProblem { field: "look_at", message, help: String::new() }));
        }
        if !check_up {
            return None;
        }
        let up_len = dot(self.up, self.up).sqrt();
        let sine = |d: [f64; 3]| dot(cross(d, self.up), cross(d, self.up)).sqrt() / (dot(d, d).sqrt() * up_len);
        let (near, d) = frames.iter().map(|&f| (f, at(f))).min_by(|x, y| sine(x.1).total_cmp(&sine(y.1)))?;
        let margin = 2.0 * drift / length;
        (sine(d) < MIN_UP_SINE + margin).then(|| {
            let message = format!(
                "the view comes within sine {:.3e} of `up` at frame {near}, too close to the camera rule's {MIN_UP_SINE} for single precision (what frames are rendered in) at coordinates of magnitude {largest:.3e}: some frame could look along `up`",
                sine(d)
            );
            (near, CameraProblem { field: "up", message, help: String::new() })
        })
    }

    /// The camera rules at `s` between whole frames (f64 interpolation), the view direction taken as
    /// zero where it is within [`THROUGH_TARGET`] of it (f64 rounding at the root of `d(s) = 0`).
    fn degenerate_at(&self, s: f64) -> Vec<CameraProblem> {
        let (position, mut look_at) = (lerp(self.pos.0, self.pos.1, s), lerp(self.at.0, self.at.1, s));
        let d = sub(look_at, position);
        let d_b = sub(self.at.1, self.pos.1);
        let scale = dot(self.d, self.d).sqrt().max(dot(d_b, d_b).sqrt());
        if dot(d, d).sqrt() <= THROUGH_TARGET * scale {
            look_at = position;
        }
        CameraSpec::view_problems(position, look_at, self.up)
    }
}

/// Real roots of `a s² + b s + c = 0` (a linear equation where `a = 0`).
fn quadratic_roots(a: f64, b: f64, c: f64) -> Vec<f64> {
    if a == 0.0 {
        return if b == 0.0 { Vec::new() } else { vec![-c / b] };
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return Vec::new();
    }
    // The numerically stable pair (no cancellation between -b and the root).
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    let mut roots = vec![q / a];
    if q != 0.0 {
        roots.push(c / q);
    }
    roots
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(frame: u32, position: V3, look_at: V3) -> CameraKey {
        CameraKey { frame, position, look_at }
    }
    fn camera() -> CameraSpec {
        crate::validate::path_template()
    }

    #[test]
    fn interpolation_holds_the_ends_and_is_linear_between() {
        let keys = [key(2, (0.0, 0.0, 0.0), (0.0, 0.0, -1.0)), key(6, (4.0, 0.0, 0.0), (4.0, 0.0, -1.0))];
        assert_eq!(camera_path_at(&keys, 0).unwrap().0, (0.0, 0.0, 0.0));
        assert_eq!(camera_path_at(&keys, 3).unwrap().0, (1.0, 0.0, 0.0));
        assert_eq!(camera_path_at(&keys, 9).unwrap().0, (4.0, 0.0, 0.0));
        assert_eq!(camera_path_at(&[], 3), None);
    }

    #[test]
    fn swapped_keys_meet_at_a_whole_frame_or_between_two() {
        // Frames 0..10: the midpoint is frame 5, where position = look_at exactly.
        let keys = [key(0, (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)), key(10, (0.0, 0.0, -1.0), (0.0, 0.0, 1.0))];
        let p = camera_path_problems(&keys, &camera(), true);
        assert_eq!((p.len(), p[0].key, p[0].frame, p[0].problem.field), (1, 0, 5.0, "look_at"), "{p:?}");
        // Frames 0..9: the midpoint 4.5 is between frames; refused there too.
        let keys = [key(0, (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)), key(9, (0.0, 0.0, -1.0), (0.0, 0.0, 1.0))];
        let p = camera_path_problems(&keys, &camera(), true);
        assert_eq!((p.len(), p[0].frame, p[0].problem.field), (1, 4.5, "look_at"), "{p:?}");
    }

    #[test]
    fn a_view_turning_parallel_to_up_is_found_at_its_frame() {
        // Over the top: position (0,1,1) → (0,1,-1) looking at the origin; frame 50 looks straight down.
        let keys = [key(0, (0.0, 1.0, 1.0), (0.0, 0.0, 0.0)), key(100, (0.0, 1.0, -1.0), (0.0, 0.0, 0.0))];
        let p = camera_path_problems(&keys, &camera(), true);
        assert_eq!((p.len(), p[0].frame, p[0].problem.field), (1, 50.0, "up"), "{p:?}");
        // Without the up rule (no camera block: the scene decides `up`), nothing is wrong.
        assert!(camera_path_problems(&keys, &camera(), false).is_empty());
        // A path that stays well away from both is fine, however long.
        let keys = [key(0, (0.0, 1.0, 4.0), (0.0, 0.0, 0.0)), key(4_000_000_000, (4.0, 1.0, 0.0), (0.0, 0.0, 0.0))];
        assert!(camera_path_problems(&keys, &camera(), true).is_empty());
    }

    #[test]
    fn a_view_single_precision_cannot_hold_between_keys_is_refused() {
        // At x = 10^6 f32 steps are 0.0625: a camera one step from its target is a valid block, but
        // interpolated frames between two such keys round position and look_at onto each other.
        let (p, l) = ((1e6, 0.0, 0.0), (1e6 + 0.0625, 0.0, 0.0));
        let keys = [key(0, p, l), key(7, p, l)];
        let collapsed = (1..7).filter(|&f| camera_path_at(&keys, f).is_some_and(|(p, l)| p == l)).count();
        assert!(collapsed > 0, "the case no longer shows the rounding");
        let found = camera_path_problems(&keys, &camera(), false);
        assert_eq!((found.len(), found[0].problem.field), (1, "look_at"), "{found:?}");
        assert!(found[0].problem.message.contains("closer than single precision"), "{}", found[0].problem.message);
        // The same view near the origin is fine.
        let keys = [key(0, (1.0, 0.0, 0.0), (1.0625, 0.0, 0.0)), key(7, (1.0, 0.0, 0.0), (1.0625, 0.0, 0.0))];
        assert!(camera_path_problems(&keys, &camera(), false).is_empty());
    }

    #[test]
    fn quadratic_roots_are_stable() {
        let mut r = quadratic_roots(1.0, -3.0, 2.0);
        r.sort_by(f64::total_cmp);
        assert_eq!(r, vec![1.0, 2.0]);
        assert_eq!(quadratic_roots(0.0, 2.0, -1.0), vec![0.5]);
        assert!(quadratic_roots(1.0, 0.0, 1.0).is_empty());
    }
}
