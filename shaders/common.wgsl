// common.wgsl — prepended to every wedge kernel by the wgpu backend (backends/src/gpu/shaders.rs).
//
// Bind-group convention (the backend builds the layouts explicitly):
//   group(0) binding(0)  frame: Frame          (uniform, filled by the backend)
//   group(0) binding(1)  params: Params        (uniform; struct GENERATED from the fields
//                                                `WgslSource::uniforms` returns: read `params.NAME`)
//   group(0) binding(2)  counters              (atomic u32: primary, shadow, secondary, non-finite,
//                                                loops cut short by the driver; 8 slots)
//   group(1)             the buffers of `Kernel::bindings()`: GENERATED, never declared by a kernel
//                        (backends/src/gpu/shaders.rs). Per binding NAME the kernel calls
//                          NAME_at(i) -> T, NAME_put(i, v: T) (outputs), NAME_bound() -> bool
//                        with T = f32, vec2<f32>, vec3<f32>, vec4<f32> or u32 and i an element index
//                        (pixel_index / index_at below). Unbound optional bindings read 0 and ignore
//                        writes. How they are bound is the backend's plan, invisible here: one
//                        storage binding each (vec3 as packed array<f32>, 3 floats per pixel, the
//                        CPU's bytes), or — where the device allows fewer storage buffers per stage —
//                        all inputs packed in one array<u32> and all outputs in another, each binding
//                        a region of `frame.packed_pixels` elements.
//
// Bands: an image whose per-pixel bindings exceed the device's binding limit is dispatched as bands
// of rows [frame.row0, frame.row_end); each band binds its buffers from pixel `frame.first` on.
// So a kernel must
//   - index its buffers with `pixel_index(gid)` (its own pixel) or `index_at(x, y)` (a neighbour),
//   - key randomness with `pixel_id(gid)` and generate camera rays at `global_xy(gid)`: the pixel in
//     the full image, of which a tile (`--tile`, frame.x0/y0/full_width/full_height) is a window,
//   - declare how far it reads (`WgslSource::per_pixel` / `with_reach`); one that does not is never
//     split. Without bands row0 = 0, row_end = height, first = 0: indices equal ids.
//   group(2)             the scene (scene.wgsl), only for kernels that declare `scene: true`.
//
// Floating point: WGSL implementations may contract a*b+c into fma and need not round exp/sqrt/
// division correctly, so kernels mirror the Rust expression order but parity allows round-off.
// NaN handling never relies on builtin min/max: rmin/rmax reproduce Rust's f32::min/max and
// gmin/gmax glam's Vec3::min/max, both with bit tests for NaN.

struct Frame {
    width: u32,
    height: u32,
    seed: u32,
    bound: u32,
    inf_bits: u32,
    fma_probe_x: u32, // 1 + 2^-12: fma(x, x, -y) is 2^-24 when fma is fused, 0 when not
    fma_probe_y: u32, // 1 + 2^-11
    row0: u32,        // first row of this dispatch's band
    row_end: u32,     // one past its last row
    first: u32,       // the pixel (y * width + x) at element 0 of every bound per-pixel buffer
    chunk_begin: u32, // sampling kernels that resume (WgslSource::chunked): this dispatch takes the
    chunk_end: u32,   // pass's sample indices [chunk_begin, chunk_end); unchunked: [0, 2^32 - 1)
    packed_pixels: u32, // packed binding plan: elements per binding region (the band's end - first)
    frame_index: u32, // frames run before this one in its sequence (Job::frame; 0 for a single image)
    x0: u32,          // tiles (Job::window): this image of width x height lies at (x0, y0) of a full
    y0: u32,          // image of full_width x full_height; camera rays and random numbers use the
    full_width: u32,  // full image's pixels (global_xy, pixel_id). Without tiles x0 = y0 = 0 and the
    full_height: u32, // full size is the image's.
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(2) var<storage, read_write> counters: array<atomic<u32>, 8>;

const COUNTER_PRIMARY: u32 = 0u;
const COUNTER_SHADOW: u32 = 1u;
const COUNTER_SECONDARY: u32 = 2u;
const COUNTER_NON_FINITE: u32 = 3u;
// A loop that ended without reaching its exit: some drivers stop a shader loop after a fixed number
// of iterations (lavapipe: 65,535), which would otherwise lose work silently. Code after a loop that
// only exits by `return`/`break` counts it here; the backend reports the total.
const COUNTER_CUT_LOOPS: u32 = 4u;
// Pixels with samples left beyond frame.chunk_end: the backend dispatches the next chunk while > 0.
const COUNTER_REMAINING: u32 = 5u;

// Chunked sampling kernels: whether this dispatch continues the pass, and the end of its sample
// range [chunk_begin, min(count, chunk_end)). Between chunks a pixel that is not finished keeps
// its raw running sum and sample count in its output, so the final mean is computed once, from
// the same sum in the same order as one dispatch would: the result does not depend on chunking.
fn chunk_resumes() -> bool {
    return frame.chunk_begin > 0u;
}

fn chunk_end_of(count: u32) -> u32 {
    if (count > frame.chunk_end) {
        atomicAdd(&counters[COUNTER_REMAINING], 1u);
        return frame.chunk_end;
    }
    return count;
}

// One estimate's samples in this dispatch: the raw sum and count so far (carried from earlier
// chunks when resuming), the end of its sample range, and whether it has samples left at all.
struct Running {
    sum: vec3<f32>,
    valid: u32,
    end: u32,
    has_work: bool,
}

// `out`: the estimate's output as the earlier chunks left it (read only when resuming);
// `count`: the pass's samples for this pixel.
fn running_start(out: vec4<f32>, count: u32, resume: bool) -> Running {
    let end = chunk_end_of(count);
    let has_work = !resume || end > frame.chunk_begin;
    if (resume && has_work) {
        return Running(out.xyz, u32(out.w), end, true);
    }
    return Running(vec3<f32>(0.0), 0u, end, has_work);
}

// The estimate's output after this dispatch: the raw sum while samples remain; once all are taken,
// the mean continuing the previous pass's `prev` (rgb mean, w = its samples) with `weight` more
// samples' worth; unchanged (`out`) if it had nothing to do.
fn running_finish(r: Running, count: u32, prev: vec4<f32>, weight: f32, out: vec4<f32>) -> vec4<f32> {
    if (r.end < count) {
        return vec4<f32>(r.sum, f32(r.valid));
    }
    if (!r.has_work) {
        return out;
    }
    let total = prev.w + weight;
    var mean = vec3<f32>(0.0);
    if (total > 0.0) {
        mean = (prev.xyz * prev.w + r.sum) / total;
    }
    return vec4<f32>(mean, total);
}

// A sample loop that stopped at `reached` short of its `end` was cut by the driver.
fn count_cut_loop(reached: u32, end: u32) {
    if (reached < end) {
        atomicAdd(&counters[COUNTER_CUT_LOOPS], 1u);
    }
}

fn is_bound(k: u32) -> bool {
    return (frame.bound & (1u << k)) != 0u;
}

// +inf, read from the uniform so no compiler folds it away.
fn inf() -> f32 {
    return bitcast<f32>(frame.inf_bits);
}

fn is_nan(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u;
}

fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn is_finite3(v: vec3<f32>) -> bool {
    return is_finite(v.x) && is_finite(v.y) && is_finite(v.z);
}

// Rust f32::min / f32::max: a NaN operand is ignored.
fn rmin(a: f32, b: f32) -> f32 {
    if (is_nan(a)) { return b; }
    if (is_nan(b)) { return a; }
    return select(b, a, a < b);
}

fn rmax(a: f32, b: f32) -> f32 {
    if (is_nan(a)) { return b; }
    if (is_nan(b)) { return a; }
    return select(b, a, a > b);
}

// glam Vec3::min / max: `if a < b { a } else { b }` per component.
fn gmin(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return select(b, a, a < b);
}

fn gmax(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return select(b, a, a > b);
}

// glam's dot / cross / length, same operation order.
fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return (a.x * b.x) + (a.y * b.y) + (a.z * b.z);
}

fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}

fn length3(a: vec3<f32>) -> f32 {
    return sqrt(dot3(a, a));
}

fn normalize3(a: vec3<f32>) -> vec3<f32> {
    return a * (1.0 / length3(a));
}

fn normalize_or_zero3(a: vec3<f32>) -> vec3<f32> {
    let r = 1.0 / length3(a);
    if (is_finite(r) && r > 0.0) {
        return a * r;
    }
    return vec3<f32>(0.0);
}

fn is_zero3(a: vec3<f32>) -> bool {
    return a.x == 0.0 && a.y == 0.0 && a.z == 0.0;
}

// Whether an invocation has a pixel (workgroups of 8×8 tile the band); false outside it.
fn pixel_of(gid: vec3<u32>) -> bool {
    return gid.x < frame.width && gid.y + frame.row0 < frame.row_end;
}

// The invocation's pixel (x, y) in the image (its buffers' coordinates: index_at, bounds checks).
fn pixel_xy(gid: vec3<u32>) -> vec2<u32> {
    return vec2<u32>(gid.x, gid.y + frame.row0);
}

// The invocation's pixel (x, y) in the full image (a tile's pixels lie at (x0, y0) in it): what
// camera rays are generated for, with the full size (camera.wgsl).
fn global_xy(gid: vec3<u32>) -> vec2<u32> {
    return pixel_xy(gid) + vec2<u32>(frame.x0, frame.y0);
}

// The invocation's pixel as y * full_width + x of the full image: keys the RNG (the CPU uses the
// same number, KernelCtx::window.pixel_id), so a tile draws what the whole image draws there.
fn pixel_id(gid: vec3<u32>) -> u32 {
    let g = global_xy(gid);
    return g.y * frame.full_width + g.x;
}

// The invocation's own element in every bound per-pixel buffer.
fn pixel_index(gid: vec3<u32>) -> u32 {
    return (gid.y + frame.row0) * frame.width + gid.x - frame.first;
}

// The element of pixel (x, y) — inside the image and within the kernel's declared reach.
fn index_at(x: i32, y: i32) -> u32 {
    return u32(y) * frame.width + u32(x) - frame.first;
}
