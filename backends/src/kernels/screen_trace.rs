//! Screen-space ray tracing against the real layer (thesis Sec. 6.5, "screen-space rays to
//! intersect only real geometry"; `wedge_scene::RealLayer`): a ray is marched over the camera image's
//! pixels, and the real surface a pixel shows is hit where the ray passes behind it. WGSL mirror:
//! `shaders/screen_trace.wgsl`, term by term in the same order.
//!
//! **The rule** (what [`ScreenTracer::trace_linear`] does, one step at a time — the definition of a
//! hit; [`ScreenTracer::trace`] gives exactly its answers faster, below):
//! - The ray `o + t d` is projected by the real layer's (pinhole) camera at both ends of the part in
//!   front of the near plane (`t_end`: where it reaches the near plane, else `FAR`), and that 2-D segment is clipped
//!   to the image. Depth along the optical axis is interpolated perspective-correctly (`1/z` is linear
//!   in screen space), so every step knows the ray's exact point.
//! - Steps of one pixel along the segment's longer axis, starting one step from the origin: step `k`
//!   (from 0) is at `u_k = u_first + k · du` along the segment (`du` = 1 / the segment's length in
//!   pixels, `u_first` = the larger of `du` and where the clipped segment starts), computed from `k`
//!   and never accumulated, so any step can be computed on its own; steps while `u_k` is before the
//!   clipped segment's end, at most `max_steps`.
//! - At each step the pixel's real surface (if the pixel is covered) is taken as its tangent plane
//!   (the pixel's position and normal), intersected with the line of sight of the step's exact screen
//!   point: the surface depth `z_s` there, free of the half-pixel depth error of a flat per-pixel depth.
//! - **Hit** where the ray is behind the surface, `z_ray ≥ z_s`, by at most the surface's assumed
//!   thickness: `max(thickness · z_s, |z_ray − z_prev|)` — a relative thickness (a fraction of the
//!   depth, default 0.05), and never less than the ray's own depth change over the step, so a ray that
//!   moves steeply in depth cannot step over a surface between two pixels. The pixel the ray starts
//!   in is never hit (it is the surface the ray leaves).
//! - **Left the screen** where the clipped segment ends at the image border with no hit (counted: real
//!   geometry off screen is invisible to these rays, the method's stated limitation); **miss** where it
//!   ends inside the image (the near plane or `FAR`), or after `max_steps`.
//!
//! **Hierarchical traversal** ([`ScreenTracer::trace`]; the thesis adapts a hierarchical screen-space
//! traversal, Sec. 6.5, in the spirit of Hi-Z tracing — a min-depth pyramid over the depth buffer,
//! with whole cells skipped where the ray stays in front of everything the cell shows). Here it is a
//! conservative skip over the steps above, never an approximation: the same steps are tested, with
//! the same `z_prev`, the same step count and the same end, so every hit, miss and offscreen answer is
//! the linear march's, bit for bit (tested on thousands of random rays per layer).
//! - [`DepthPyramid`]: per pixel a lower bound of every `z_s` any step inside the pixel can compute:
//!   the tangent plane's depth along a sight line `v(s)` is `((p − c)·n) / (v(s)·n)` with `v(s)·n`
//!   affine in the screen point `s`, so over the pixel square its extreme is at a corner; the bound is
//!   the smaller of that (the corners' largest `v·n` of the plane's sign, widened by the rounding of
//!   `v·n`, and none where no sight line passes the grazing test) and the pixel's own depth `z_p`
//!   (the grazing and behind-the-camera fallback), lowered by a relative 2⁻¹⁶ against the GPU's
//!   rounding; [`NO_SURFACE`] where the pixel is not covered. Level `l` holds the minimum over
//!   `2^l × 2^l` pixels (a min-pyramid of 2 × 2 minima, down to one cell). It depends on the camera,
//!   so it is built with the tracer ([`ScreenTracer::new`]) and uploaded with the layer
//!   (`real_layer.wgsl`).
//! - The ray's depth `z_k = 1 / (k0 + (k1 − k0) u_k)` is monotone in `k`, in floating point too
//!   (each operation rounds monotonically), and a step's pixel is monotone in `k` along each axis,
//!   so the steps inside a pyramid cell are one run of `k`, and their largest depth is at one end of
//!   the run. Where the cell's bound exceeds both ends' depths (or the cell shows no surface), no step
//!   of the run can pass `z_ray ≥ z_s`: the run is skipped, `z_prev` becomes its last step's depth
//!   and the step count advances by its length. Otherwise the next finer level is tried, and at
//!   level 0 the step is tested exactly. After a skip the next attempt starts one level coarser.
//! - The run's end (the first step whose pixel leaves the cell) is estimated from the segment and
//!   settled by evaluating the steps' pixels exactly (a binary search where the estimate is off).

use glam::{Vec2, Vec3};
use wedge_scene::{Camera, RealLayer};

/// Distance to the near plane along the optical axis (metres).
pub const NEAR: f32 = 1e-3;
/// Where a ray that moves away from the camera ends (metres).
pub const FAR: f32 = 1e5;

/// Sight lines with `|v·n|` below this meet a pixel's tangent plane too obliquely: the pixel's own
/// depth stands in (`surface_depth`).
const GRAZING: f32 = 1e-4;

/// The pyramid's bounds are lowered by this fraction of themselves: far more than the rounding
/// difference of the GPU's `z_s` and `z_ray` (FMA contraction, a 2.5-ulp division) from the CPU's.
pub const BOUND_MARGIN: f32 = 1.0 / 65536.0;

/// The pyramid's value where no pixel shows a real surface (no step there can hit): the largest
/// finite f32, so the GPU's copy holds no infinities.
pub const NO_SURFACE: f32 = f32::MAX;

/// Levels the GPU header has room for (a side of 2^15 pixels needs 16).
pub const PYRAMID_HEADER: usize = 16;

/// What a screen-space ray found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScreenHit {
    /// The real surface of pixel `(x, y)` at distance `t` along the ray.
    Hit { t: f32, x: u32, y: u32 },
    /// Ended inside the image (or after the step budget) without a hit.
    Miss,
    /// Left the image without a hit.
    Offscreen,
}

/// A min-pyramid of lower bounds of the real surface's depth (module doc, "Hierarchical
/// traversal"): level 0 one value per pixel, level `l` one per `2^l × 2^l` block (edge cells
/// smaller), down to a single cell.
#[derive(Clone, Debug, Default)]
pub struct DepthPyramid {
    /// Per level: first value in `data`, width, height.
    levels: Vec<(usize, u32, u32)>,
    data: Vec<f32>,
}

impl DepthPyramid {
    /// The pyramid of `layer` seen by `camera` (the camera [`ScreenTracer::new`] is given).
    pub fn of(layer: &RealLayer, camera: &Camera) -> DepthPyramid {
        ScreenTracer::new(layer, camera, 1.0, 0).pyramid
    }

    fn build(t: &ScreenTracer<'_>) -> DepthPyramid {
        let (w, h) = (t.layer.width(), t.layer.height());
        let mut data: Vec<f32> = Vec::with_capacity(w as usize * h as usize * 4 / 3 + 16);
        data.extend((0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| t.pixel_lower_bound(x, y)));
        let mut levels = vec![(0usize, w, h)];
        let (mut lw, mut lh) = (w, h);
        while lw > 1 || lh > 1 {
            let (first, pw, ph) = *levels.last().expect("level 0");
            (lw, lh) = (pw.div_ceil(2), ph.div_ceil(2));
            let start = data.len();
            for y in 0..lh {
                for x in 0..lw {
                    let mut m = NO_SURFACE;
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (cx, cy) = (2 * x + dx, 2 * y + dy);
                        if cx < pw && cy < ph {
                            m = m.min(data[first + (cy * pw + cx) as usize]);
                        }
                    }
                    data.push(m);
                }
            }
            levels.push((start, lw, lh));
        }
        DepthPyramid { levels, data }
    }

    /// How many levels (level 0 the pixels).
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// The bound of cell `(x, y)` of level `level` ([`NO_SURFACE`] outside the level).
    #[inline]
    pub fn get(&self, level: usize, x: i64, y: i64) -> f32 {
        let (first, w, h) = self.levels[level];
        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
            return NO_SURFACE;
        }
        self.data[first + (y as usize * w as usize + x as usize)]
    }

    /// The GPU's copy (`shaders/real_layer.wgsl`, after the four elements per pixel): a header of
    /// [`PYRAMID_HEADER`] elements, element `l` = level `l`'s first value (counted in values from the
    /// end of the header), width, height and the level count (zeros past the last level); then the
    /// values, four per 16-byte element, as f32 bits.
    pub fn gpu_elements(&self) -> Vec<[u32; 4]> {
        assert!(
            self.levels.len() <= PYRAMID_HEADER,
            "a pyramid of {} levels (at most {PYRAMID_HEADER})",
            self.levels.len()
        );
        let mut v = vec![[0u32; 4]; PYRAMID_HEADER];
        for (l, &(first, w, h)) in self.levels.iter().enumerate() {
            v[l] = [first as u32, w, h, self.levels.len() as u32];
        }
        v.extend(self.data.chunks(4).map(|c| {
            let mut e = [0u32; 4];
            for (k, x) in c.iter().enumerate() {
                e[k] = x.to_bits();
            }
            e
        }));
        v
    }
}

/// A pinhole view of the real layer, the march's settings and the layer's [`DepthPyramid`] for that
/// view.
#[derive(Clone, Debug)]
pub struct ScreenTracer<'a> {
    pub layer: &'a RealLayer,
    pub position: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    pub tan_half: f32,
    pub thickness: f32,
    pub max_steps: u32,
    pyramid: DepthPyramid,
}

/// `x.floor() as i64`, without a call to libm's `floorf` (x86-64's baseline has no rounding
/// instruction): the same value for every f32.
#[inline]
fn floor_i64(x: f32) -> i64 {
    let t = x as i64;
    if (t as f32) > x {
        t - 1
    } else {
        t
    }
}

/// One ray's march (the module doc's segment): what every step is computed from.
struct Segment {
    o: Vec3,
    e: Vec3,
    s0: Vec2,
    delta: Vec2,
    k0: f32,
    k1: f32,
    u_first: f32,
    du: f32,
    u_out: f32,
    clipped: bool,
    origin_pixel: (i64, i64),
    z0: f32,
    /// For guessing where a run of steps leaves a cell: `u_first / du`, and per axis the steps per
    /// pixel `1 / (delta · du)` (0 where the segment does not move along the axis).
    k_first: f32,
    inv_step: Vec2,
}

impl Segment {
    /// Where step `k` is along the segment.
    #[inline]
    fn u(&self, k: u32) -> f32 {
        self.u_first + k as f32 * self.du
    }

    /// The pixel step `k` is in (may be just outside the image).
    #[inline]
    fn pixel(&self, k: u32) -> (i64, i64) {
        let s = self.s0 + self.delta * self.u(k);
        (floor_i64(s.x), floor_i64(s.y))
    }

    /// Perspective-correct depth of the ray point that projects to step `k`'s screen point.
    #[inline]
    fn z(&self, k: u32) -> f32 {
        1.0 / (self.k0 + (self.k1 - self.k0) * self.u(k))
    }

    /// How the march ends after `k` steps without a hit.
    fn end(&self, k: u32) -> ScreenHit {
        if self.clipped && self.u(k) >= self.u_out {
            ScreenHit::Offscreen
        } else {
            ScreenHit::Miss
        }
    }
}

/// The first `k` in `lo..hi` where `out(k)` holds, else `hi`, for `out` false then true over
/// `lo..hi`; `guess` is tried first (with its neighbour), then a binary search.
#[inline]
fn first_out(lo: u32, hi: u32, guess: u32, out: impl Fn(u32) -> bool) -> u32 {
    let g = guess.clamp(lo, hi);
    let (mut a, mut b) = if g == hi || out(g) {
        // The answer is at most g.
        if g == lo || !out(g - 1) {
            return g;
        }
        (lo, g - 1)
    } else {
        // The answer is after g.
        if g + 1 == hi || out(g + 1) {
            return g + 1;
        }
        (g + 2, hi)
    };
    // out(b) holds or b == hi; out(a − 1) does not.
    while a < b {
        let m = a + (b - a) / 2;
        if out(m) {
            b = m;
        } else {
            a = m + 1;
        }
    }
    a
}

impl<'a> ScreenTracer<'a> {
    /// The tracer of `layer` seen by `camera`, with its [`DepthPyramid`] (built here: one pass over
    /// the layer's pixels, so build a tracer once per image, not per ray).
    pub fn new(layer: &'a RealLayer, camera: &Camera, thickness: f32, max_steps: u32) -> ScreenTracer<'a> {
        let (right, up, forward) = camera.basis();
        let tan_half = (camera.vfov_deg.to_radians() * 0.5).tan();
        let mut t = ScreenTracer {
            layer,
            position: camera.position,
            right,
            up,
            forward,
            tan_half,
            thickness,
            max_steps,
            pyramid: DepthPyramid::default(),
        };
        t.pyramid = DepthPyramid::build(&t);
        t
    }

    /// The pyramid the hierarchical march skips by.
    pub fn pyramid(&self) -> &DepthPyramid {
        &self.pyramid
    }

    /// Continuous pixel coordinates of a point at view depth `z > 0` (the inverse of the pinhole ray).
    #[inline]
    fn project(&self, p: Vec3, z: f32) -> Vec2 {
        let (w, h) = (self.layer.width() as f32, self.layer.height() as f32);
        let d = p - self.position;
        let sx = d.dot(self.right) / z;
        let sy = d.dot(self.up) / z;
        Vec2::new((sx / (self.tan_half * (w / h)) + 1.0) * 0.5 * w, (1.0 - sy / self.tan_half) * 0.5 * h)
    }

    /// The (unnormalised) line-of-sight direction through continuous pixel point `s`.
    #[inline]
    fn sight(&self, s: Vec2) -> Vec3 {
        let (w, h) = (self.layer.width() as f32, self.layer.height() as f32);
        let sx = (2.0 * s.x / w - 1.0) * self.tan_half * (w / h);
        let sy = (1.0 - 2.0 * s.y / h) * self.tan_half;
        self.forward + sx * self.right + sy * self.up
    }

    /// The view depth of pixel `(x, y)`'s real surface (its tangent plane) along the sight line
    /// through `s`; `None` where the pixel shows no real surface.
    #[inline]
    fn surface_depth(&self, x: u32, y: u32, s: Vec2) -> Option<f32> {
        let p = self.layer.position(x, y)?;
        let n = self.layer.normal(x, y);
        let v = self.sight(s);
        let vn = v.dot(n);
        let zp = (p - self.position).dot(self.forward);
        // Grazing sight lines: the pixel's own depth (the plane gives no stable answer).
        if vn.abs() < GRAZING {
            return Some(zp);
        }
        // The sight line `c + λ v` meets the plane at λ = ((p − c)·n)/(v·n); `v·forward` = 1, so λ is
        // the depth.
        let lambda = (p - self.position).dot(n) / vn;
        Some(if lambda > 0.0 { lambda } else { zp })
    }

    /// A lower bound of every `surface_depth(x, y, s)` with `s` in the pixel's square (module doc);
    /// [`NO_SURFACE`] where the pixel is not covered.
    fn pixel_lower_bound(&self, x: u32, y: u32) -> f32 {
        let Some(p) = self.layer.position(x, y) else {
            return NO_SURFACE;
        };
        let n = self.layer.normal(x, y);
        // The same expressions as surface_depth: the same bits.
        let zp = (p - self.position).dot(self.forward);
        let num = (p - self.position).dot(n);
        let (x0, y0) = (x as f32, y as f32);
        let mut g_min = f32::INFINITY;
        let mut g_max = f32::NEG_INFINITY;
        for s in [Vec2::new(x0, y0), Vec2::new(x0 + 1.0, y0), Vec2::new(x0, y0 + 1.0), Vec2::new(x0 + 1.0, y0 + 1.0)] {
            let g = self.sight(s).dot(n);
            g_min = g_min.min(g);
            g_max = g_max.max(g);
        }
        // Each component of `v` is at most 1 + |sx| + |sy| in size, so the rounding of `v·n` (a few
        // ulps of that) stays far below this.
        let (w, h) = (self.layer.width() as f32, self.layer.height() as f32);
        let slack = 1e-5 * (1.0 + self.tan_half * (w / h) + self.tan_half);
        let mut bound = zp;
        // λ > 0 needs `v·n` of `num`'s sign and at least GRAZING in size; λ is smallest where
        // `|v·n|` is largest.
        if num > 0.0 {
            let g = g_max + slack;
            if g >= GRAZING {
                bound = bound.min(num / g);
            }
        } else if num < 0.0 {
            let g = g_min - slack;
            if g <= -GRAZING {
                bound = bound.min(num / g);
            }
        }
        bound - bound.abs() * BOUND_MARGIN
    }

    /// The segment of the ray `o + t d`, or how it ends before any step (module doc).
    fn segment(&self, o: Vec3, d: Vec3) -> Result<Segment, ScreenHit> {
        let (w, h) = (self.layer.width() as f32, self.layer.height() as f32);
        let z0 = (o - self.position).dot(self.forward);
        if !(z0 > NEAR) {
            // Behind the camera: the image never saw where it starts.
            return Err(ScreenHit::Offscreen);
        }
        let dz = d.dot(self.forward);
        let t_end = if dz < 0.0 { ((z0 - NEAR) / -dz).min(FAR) } else { FAR };
        let e = o + d * t_end;
        let z1 = (z0 + dz * t_end).max(NEAR);
        let (s0, s1) = (self.project(o, z0), self.project(e, z1));
        let (k0, k1) = (1.0 / z0, 1.0 / z1);
        // Clip the segment s0 → s1 to the image (Liang–Barsky).
        let delta = s1 - s0;
        let (mut u_in, mut u_out) = (0.0f32, 1.0f32);
        for (p, q) in [(-delta.x, s0.x), (delta.x, w - s0.x), (-delta.y, s0.y), (delta.y, h - s0.y)] {
            if p == 0.0 {
                if q < 0.0 {
                    return Err(ScreenHit::Offscreen);
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    u_in = u_in.max(r);
                } else {
                    u_out = u_out.min(r);
                }
            }
        }
        if !(u_in < u_out) {
            return Err(ScreenHit::Offscreen);
        }
        let clipped = u_out < 1.0;
        let length = delta.x.abs().max(delta.y.abs());
        if !(length > 0.0) {
            // Along the line of sight through the origin's own pixel: nothing to march over.
            return Err(ScreenHit::Miss);
        }
        let du = 1.0 / length;
        let origin_pixel = (floor_i64(s0.x), floor_i64(s0.y));
        let u_first = u_in.max(du);
        let inv = |d: f32| if d != 0.0 { 1.0 / (d * du) } else { 0.0 };
        let inv_step = Vec2::new(inv(delta.x), inv(delta.y));
        Ok(Segment {
            o,
            e,
            s0,
            delta,
            k0,
            k1,
            u_first,
            du,
            u_out,
            clipped,
            origin_pixel,
            z0,
            k_first: u_first / du,
            inv_step,
        })
    }

    /// The exact test of step `k` (depth `z_ray`, the step before at `z_prev`).
    #[inline]
    fn step_hit(&self, g: &Segment, k: u32, z_ray: f32, z_prev: f32) -> Option<ScreenHit> {
        let (w, h) = (self.layer.width() as f32, self.layer.height() as f32);
        let u = g.u(k);
        let s = g.s0 + g.delta * u;
        let (px, py) = (floor_i64(s.x), floor_i64(s.y));
        if (px, py) != g.origin_pixel && px >= 0 && py >= 0 && (px as f32) < w && (py as f32) < h {
            let (x, y) = (px as u32, py as u32);
            if let Some(z_s) = self.surface_depth(x, y, s) {
                let allowed = (self.thickness * z_s).max((z_ray - z_prev).abs());
                if z_ray >= z_s && z_ray - z_s <= allowed {
                    // The ray's point: homogeneous interpolation of the end points.
                    let a = g.k0 * (1.0 - u);
                    let b = g.k1 * u;
                    let p = (g.o * a + g.e * b) / (a + b);
                    return Some(ScreenHit::Hit { t: (p - g.o).length(), x, y });
                }
            }
        }
        None
    }

    /// March the ray `o + t d` (`d` unit) over the real layer one step at a time: the rule of the
    /// module doc as written, kept as the reference [`ScreenTracer::trace`] is tested against.
    pub fn trace_linear(&self, o: Vec3, d: Vec3) -> ScreenHit {
        self.linear(o, d).0
    }

    /// [`ScreenTracer::trace_linear`] and the steps it took.
    fn linear(&self, o: Vec3, d: Vec3) -> (ScreenHit, u32) {
        let g = match self.segment(o, d) {
            Ok(g) => g,
            Err(end) => return (end, 0),
        };
        let mut z_prev = g.z0;
        let mut k = 0u32;
        while g.u(k) < g.u_out && k < self.max_steps {
            let z_ray = g.z(k);
            if let Some(hit) = self.step_hit(&g, k, z_ray, z_prev) {
                return (hit, k + 1);
            }
            z_prev = z_ray;
            k += 1;
        }
        (g.end(k), k)
    }

    /// March the ray `o + t d` (`d` unit) over the real layer (module doc): the linear march's
    /// answer exactly, skipping runs of steps the [`DepthPyramid`] shows cannot hit.
    pub fn trace(&self, o: Vec3, d: Vec3) -> ScreenHit {
        self.trace_counted(o, d).0
    }

    /// [`ScreenTracer::trace`] and how many steps it tested exactly and how many pyramid cells it
    /// looked at (for measurements).
    pub fn trace_counted(&self, o: Vec3, d: Vec3) -> (ScreenHit, u32, u32) {
        let g = match self.segment(o, d) {
            Ok(g) => g,
            Err(end) => return (end, 0, 0),
        };
        let (w, h) = (self.layer.width() as i64, self.layer.height() as i64);
        // Steps 0..n are the linear march's (u_k < u_out is a prefix of k: u_k is monotone).
        let n = {
            let steps = ((g.u_out - g.u_first) / g.du).ceil();
            let guess = if steps < self.max_steps as f32 { steps.max(0.0) as u32 } else { self.max_steps };
            first_out(0, self.max_steps, guess, |k| g.u(k) >= g.u_out)
        };
        let top = self.pyramid.levels() - 1;
        let (mut exact, mut looked) = (0u32, 0u32);
        let mut z_prev = g.z0;
        let mut k = 0u32;
        let mut level = 0usize;
        'march: while k < n {
            let (px, py) = g.pixel(k);
            let z_k = g.z(k);
            if px < 0 || py < 0 || px >= w || py >= h {
                // Outside the image (at its border, by rounding): no surface, no test.
                z_prev = z_k;
                k += 1;
                continue;
            }
            let mut l = level;
            loop {
                let (cx, cy) = (px >> l, py >> l);
                let bound = self.pyramid.get(l, cx, cy);
                looked += 1;
                if bound == NO_SURFACE || bound > z_k {
                    let end = self.cell_end(&g, k, n, l, cx, cy);
                    let z_last = g.z(end - 1);
                    if bound == NO_SURFACE || bound > z_last {
                        // No step of k..end can be behind its pixel's surface.
                        z_prev = z_last;
                        k = end;
                        level = (l + 1).min(top);
                        continue 'march;
                    }
                }
                if l == 0 {
                    break;
                }
                l -= 1;
            }
            exact += 1;
            if let Some(hit) = self.step_hit(&g, k, z_k, z_prev) {
                return (hit, exact, looked);
            }
            z_prev = z_k;
            k += 1;
            level = 0;
        }
        (g.end(k), exact, looked)
    }

    /// The first step after `k` (at most `n`) whose pixel is outside cell `(cx, cy)` of level `l`,
    /// step `k`'s cell: estimated where the segment crosses the cell's sides, then settled exactly.
    #[inline]
    fn cell_end(&self, g: &Segment, k: u32, n: u32, l: usize, cx: i64, cy: i64) -> u32 {
        if k + 1 >= n {
            return n;
        }
        // The step index where the segment crosses the cell's far side along each axis (only a guess:
        // first_out settles it).
        let cross = |s0: f32, inv: f32, c: i64| -> f32 {
            let side = if inv > 0.0 {
                ((c + 1) << l) as f32
            } else if inv < 0.0 {
                (c << l) as f32
            } else {
                return 3.0e38;
            };
            (side - s0) * inv - g.k_first
        };
        let at = cross(g.s0.x, g.inv_step.x, cx).min(cross(g.s0.y, g.inv_step.y, cy));
        // Rounded up (an integer-valued guess one high costs one more look).
        let at = at as i64 + 1;
        let guess = if at < n as i64 { at.max(k as i64 + 1) as u32 } else { n };
        first_out(k + 1, n, guess, |j| {
            let (x, y) = g.pixel(j);
            (x >> l, y >> l) != (cx, cy)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{hash4, to_unit};
    use wedge_scene::{Scene, SceneSource};

    /// A random stream for the tests (the crate's counter-based hash).
    struct Draw(u32, u32);
    impl Draw {
        fn next(&mut self) -> f32 {
            self.1 += 1;
            to_unit(hash4(self.0, self.1, 0x5eed, 7))
        }
        fn sphere(&mut self) -> Vec3 {
            let z = 2.0 * self.next() - 1.0;
            let phi = std::f32::consts::TAU * self.next();
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        }
    }

    /// The real layer a capture of `name` gives (the G-buffer of `wedge render --aov`: position,
    /// normal, coverage per pixel centre) at `w × h`, and the scene's camera.
    fn captured(name: &str, w: u32, h: u32) -> (RealLayer, Camera) {
        use crate::lone::LonePass;
        use crate::BufferData;
        let scene: Scene = wedge_scene::load(&SceneSource::Builtin(name.into())).expect("built-in scene");
        let inputs = std::collections::BTreeMap::<String, BufferData>::new();
        let pass = LonePass::new(
            std::sync::Arc::new(crate::kernels::primary::PrimaryGBuffer),
            std::collections::BTreeMap::new(),
            &inputs,
        )
        .expect("G-buffer pass");
        let (out, _) = pass.run_cpu(&scene, w, h, 0).expect("G-buffer");
        let (Some(BufferData::Vec4(pos)), Some(BufferData::Vec4(nor))) = (out.get("position"), out.get("normal"))
        else {
            panic!("G-buffer formats")
        };
        let covered = |k: usize| pos[k][3] > 0.0;
        let n = pos.len();
        let position =
            (0..n).map(|k| if covered(k) { [pos[k][0], pos[k][1], pos[k][2], 1.0] } else { [0.0; 4] }).collect();
        let normal = (0..n).map(|k| if covered(k) { [nor[k][0], nor[k][1], nor[k][2]] } else { [0.0; 3] }).collect();
        let layer = RealLayer::from_maps(w, h, vec![[0.5; 3]; n], position, normal, vec![[0.5; 3]; n]).expect("layer");
        (layer, scene.camera)
    }

    /// A layer made to be hard: a grazing floor, fronto-parallel and tilted slabs at several depths
    /// with sharp edges, one-pixel-thin rods in front, uncovered holes and sky, and a fifth of the
    /// pixels with a random normal (any direction, facing away too) — pixels whose tangent planes have
    /// nothing to do with their neighbours'.
    fn synthetic(camera: &Camera, w: u32, h: u32, seed: u32) -> RealLayer {
        let (right, up, forward) = camera.basis();
        let tan_half = (camera.vfov_deg.to_radians() * 0.5).tan();
        let mut r = Draw(seed, 0);
        let n = (w * h) as usize;
        let (mut position, mut normal) = (vec![[0.0f32; 4]; n], vec![[0.0f32; 3]; n]);
        for y in 0..h {
            for x in 0..w {
                let k = (y * w + x) as usize;
                let sx = (2.0 * (x as f32 + 0.5) / w as f32 - 1.0) * tan_half * (w as f32 / h as f32);
                let sy = (1.0 - 2.0 * (y as f32 + 0.5) / h as f32) * tan_half;
                let v = forward + sx * right + sy * up;
                let (fx, fy) = (x as f32 / w as f32, y as f32 / h as f32);
                // Depth along the optical axis and the surface's normal.
                let (z, nrm) = if x % 23 == 7 && fy > 0.2 {
                    (1.5, -forward) // thin rods, near
                } else if y % 17 == 3 && fx < 0.6 {
                    (2.5 + fx, (-forward + 0.3 * right).normalize()) // thin tilted bars
                } else if (0.2..0.45).contains(&fx) && (0.3..0.6).contains(&fy) {
                    (3.0, -forward) // a slab
                } else if (0.55..0.8).contains(&fx) && (0.25..0.7).contains(&fy) {
                    (5.0 + 4.0 * fx, (-forward - 0.8 * right).normalize()) // a steep wall
                } else if ((x / 9) * 7 + (y / 5) * 3) % 11 == 0 {
                    continue; // holes
                } else if sy < -0.02 {
                    // A floor 1 below the camera, seen at grazing angles near the horizon.
                    ((-1.0 / sy).min(500.0), up)
                } else {
                    continue; // sky
                };
                let p = camera.position + v * z;
                let nrm = if r.next() < 0.2 { r.sphere() } else { nrm };
                position[k] = [p.x, p.y, p.z, 1.0];
                normal[k] = nrm.to_array();
            }
        }
        RealLayer::from_maps(w, h, vec![[0.5; 3]; n], position, normal, vec![[0.5; 3]; n]).expect("layer")
    }

    fn same(a: ScreenHit, b: ScreenHit) -> bool {
        match (a, b) {
            (ScreenHit::Hit { t: ta, x: xa, y: ya }, ScreenHit::Hit { t: tb, x: xb, y: yb }) => {
                ta.to_bits() == tb.to_bits() && (xa, ya) == (xb, yb)
            }
            _ => a == b,
        }
    }

    /// `rays` random rays (half from covered pixels' surfaces, offset along the normal as mr.sample
    /// does, half from anywhere in a box around the camera's view) with directions over the whole
    /// sphere: `trace` must equal `trace_linear` for every one. Returns the counts of hits, misses and
    /// rays that left the image, linear steps, exact tests and pyramid look-ups.
    fn check(t: &ScreenTracer<'_>, rays: u32, seed: u32) -> [u64; 6] {
        let (w, h) = (t.layer.width(), t.layer.height());
        let mut r = Draw(seed, 1 << 20);
        let mut counts = [0u64; 6];
        let mut failures = Vec::new();
        for i in 0..rays {
            let o = if i % 2 == 0 {
                let (x, y) = (((r.next() * w as f32) as u32).min(w - 1), ((r.next() * h as f32) as u32).min(h - 1));
                match t.layer.position(x, y) {
                    Some(p) => p + t.layer.normal(x, y) * 1e-3,
                    None => t.position + t.forward * (0.5 + 20.0 * r.next()),
                }
            } else {
                t.position + Vec3::new(r.next() - 0.5, r.next() - 0.5, r.next() - 0.5) * 24.0 + t.forward * 8.0
            };
            let d = r.sphere();
            let (fast, exact, looked) = t.trace_counted(o, d);
            let (slow, steps) = t.linear(o, d);
            if !same(fast, slow) {
                failures.push(format!("ray {i}: o {o:?} d {d:?}: hierarchical {fast:?}, linear {slow:?}"));
            }
            match slow {
                ScreenHit::Hit { .. } => counts[0] += 1,
                ScreenHit::Miss => counts[1] += 1,
                ScreenHit::Offscreen => counts[2] += 1,
            }
            counts[3] += steps as u64;
            counts[4] += exact as u64;
            counts[5] += looked as u64;
        }
        assert!(
            failures.is_empty(),
            "{} of {rays} rays differ:\n{}",
            failures.len(),
            failures[..failures.len().min(20)].join("\n")
        );
        counts
    }

    #[test]
    fn hierarchical_march_equals_the_linear_one_on_a_capture() {
        let (layer, camera) = captured("envmap_real", 320, 240);
        for (thickness, max_steps) in [(0.05, 401), (0.5, 401), (0.002, 57)] {
            let t = ScreenTracer::new(&layer, &camera, thickness, max_steps);
            let c = check(&t, 20_000, 11);
            let n = 20_000.0;
            println!(
                "envmap_real 320x240, thickness {thickness}, max_steps {max_steps}: {} hits, {} misses, {} offscreen; \
                 per ray {:.1} linear steps, {:.2} exact tests + {:.2} pyramid look-ups",
                c[0],
                c[1],
                c[2],
                c[3] as f64 / n,
                c[4] as f64 / n,
                c[5] as f64 / n
            );
            assert!(c[0] > 1000 && c[1] + c[2] > 1000, "too few hits or ends to mean much: {c:?}");
        }
    }

    #[test]
    fn hierarchical_march_equals_the_linear_one_on_a_hard_layer() {
        for (k, (w, h, fov)) in [(160u32, 120u32, 60.0f32), (97, 61, 100.0), (64, 200, 25.0)].into_iter().enumerate() {
            let camera = Camera {
                position: Vec3::new(0.3, 0.0, 0.2),
                look_at: Vec3::new(0.5, -0.1, -4.0),
                vfov_deg: fov,
                ..Camera::default()
            };
            let layer = synthetic(&camera, w, h, k as u32);
            for (thickness, max_steps) in [(0.05, 1000), (0.3, 1000), (0.01, 23)] {
                let t = ScreenTracer::new(&layer, &camera, thickness, max_steps);
                let c = check(&t, 10_000, 100 + k as u32);
                println!(
                    "synthetic {w}x{h} at {fov}°, thickness {thickness}, max_steps {max_steps}: {} hits, {} misses, {} offscreen; \
                     per ray {:.1} linear steps, {:.2} exact tests + {:.2} look-ups",
                    c[0], c[1], c[2], c[3] as f64 / 10_000.0, c[4] as f64 / 10_000.0, c[5] as f64 / 10_000.0
                );
                assert!(c[0] > 500 && c[1] + c[2] > 500, "too few hits or ends to mean much: {c:?}");
            }
        }
    }

    /// What `mr.sample`'s screen-space rays cost, linear vs hierarchical, on the 640×480 capture of
    /// `envmap_real`: rays from every covered pixel's surface (offset as mr.sample offsets them),
    /// cosine-distributed about its normal (the indirect rays; the shadow rays toward the sky are
    /// like them). `cargo test --release -p wedge-backends --lib screen_trace -- --ignored --nocapture`
    #[test]
    #[ignore]
    fn measure_steps_per_ray() {
        let (layer, camera) = captured("envmap_real", 640, 480);
        let diagonal = 640f32.hypot(480.0).ceil() as u32 + 1;
        let start = std::time::Instant::now();
        let t = ScreenTracer::new(&layer, &camera, 0.05, diagonal);
        println!(
            "tracer and pyramid ({} levels) built in {:.1} ms",
            t.pyramid.levels(),
            start.elapsed().as_secs_f64() * 1e3
        );
        let eps = 1e-4 * wedge_scene::load(&SceneSource::Builtin("envmap_real".into())).unwrap().extent();
        let mut r = Draw(3, 0);
        let mut rays = Vec::new();
        for y in (0..480).step_by(2) {
            for x in (0..640).step_by(2) {
                let Some(p) = layer.position(x, y) else { continue };
                let n = layer.normal(x, y);
                let (u1, u2) = (r.next(), r.next());
                let (a, b) = (n.any_orthonormal_pair().0, n.any_orthonormal_pair().1);
                let (rad, phi) = (u1.sqrt(), std::f32::consts::TAU * u2);
                let d = (a * rad * phi.cos() + b * rad * phi.sin() + n * (1.0 - u1).max(0.0).sqrt()).normalize();
                rays.push((p + n * eps, d));
            }
        }
        let start = std::time::Instant::now();
        let (mut steps, mut hits) = (0u64, 0u64);
        for &(o, d) in &rays {
            let (h, k) = t.linear(o, d);
            steps += k as u64;
            hits += matches!(h, ScreenHit::Hit { .. }) as u64;
        }
        let linear = start.elapsed();
        let start = std::time::Instant::now();
        let (mut exact, mut looked) = (0u64, 0u64);
        for &(o, d) in &rays {
            let (_, e, l) = t.trace_counted(o, d);
            exact += e as u64;
            looked += l as u64;
        }
        let fast = start.elapsed();
        let n = rays.len() as f64;
        println!(
            "{} rays ({:.1}% hit): linear {:.1} steps per ray, {:.0} ns per ray; hierarchical {:.2} exact tests + {:.2} pyramid look-ups per ray, {:.0} ns per ray ({:.1}x)",
            rays.len(),
            100.0 * hits as f64 / n,
            steps as f64 / n,
            linear.as_nanos() as f64 / n,
            exact as f64 / n,
            looked as f64 / n,
            fast.as_nanos() as f64 / n,
            linear.as_secs_f64() / fast.as_secs_f64()
        );
    }

    /// Every step's surface depth is at least the pyramid's bound of its pixel (the property the
    /// skips rest on), probed at random points of random pixels and at their corners.
    #[test]
    fn pyramid_bounds_every_surface_depth_in_the_pixel() {
        let camera =
            Camera { position: Vec3::ZERO, look_at: Vec3::new(0.2, -0.3, -1.0), vfov_deg: 70.0, ..Camera::default() };
        let layer = synthetic(&camera, 120, 90, 9);
        let t = ScreenTracer::new(&layer, &camera, 0.05, 100);
        let mut r = Draw(5, 0);
        let (mut below, mut probes) = (0, 0);
        for y in 0..90 {
            for x in 0..120 {
                let bound = t.pyramid.get(0, x as i64, y as i64);
                for j in 0..12 {
                    let s = if j < 4 {
                        Vec2::new((x + j % 2) as f32, (y + j / 2) as f32)
                    } else {
                        Vec2::new(x as f32 + r.next(), y as f32 + r.next())
                    };
                    if let Some(z) = t.surface_depth(x, y, s) {
                        probes += 1;
                        below += (z < bound) as u32;
                    }
                }
                // Coarser levels are the minima of the finer.
                for l in 1..t.pyramid.levels() {
                    assert!(t.pyramid.get(l, (x >> l) as i64, (y >> l) as i64) <= bound);
                }
            }
        }
        assert!(probes > 50_000);
        assert_eq!(below, 0, "{below} of {probes} surface depths below their pixel's bound");
    }
}
