// light_field.reconstruct — eq. 3 of seed 001: `rays` reconstruction rays per pixel shared among its
// `primaries` primary hits (RayShare), each at its hit's shutter time and resolved by RECONSTRUCT
// through the splat BVH the host pass built, the splats moved to that time (Secs. 2.3.2-2.5); mirrors
// effects/src/light_field/reconstruct.rs (collect, conflict, resolve, filter), kernels/reconstruct.rs
// (LightFieldReconstruct::run_cpu) and formulas.rs (RayShare): the same nodes visited in the same order, the same total
// order of hits, the same RNG calls and dimensions. Chunked over rays, the sum kept in the same order.
#include "common.wgsl"
#include "rng.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"
#include "hemisphere.wgsl"
#include "lobe_mixture.wgsl"
#include "indirect_path.wgsl"
#include "light_field_common.wgsl"

const LF_MAX_HITS: u32 = 32u;     // reconstruct.rs MAX_HITS
const LF_STACK_SIZE: u32 = 64u;   // reconstruct.rs STACK_SIZE (the host pass refuses deeper trees)
const LF_HALF_SPACE_TOLERANCE: f32 = 0.01;
const LF_PARALLEL: f32 = 1e-6;

// The nearest splats of the current ray, sorted by (t, splat).
var<private> hit_t: array<f32, 32>;
var<private> hit_splat: array<u32, 32>;
var<private> hit_count: u32;
var<private> stack: array<u32, 64>;

// The shutter time of the current ray (Splat::centre_at reads it).
var<private> ray_time: f32;

// Splat::centre_at: where the splat's centre is at `ray_time`.
fn lf_centre(s: Splat) -> vec3<f32> {
    return s.centre + s.velocity * (ray_time - s.time);
}

// disk_hit: the crossing of o + t d with splat s's disk (radius × scale) at `ray_time` in
// (t_min, t_max), or -1.
fn lf_disk_hit(s: Splat, o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, scale: f32) -> f32 {
    let denom = dot3(d, s.normal);
    if (abs(denom) < LF_PARALLEL) {
        return -1.0;
    }
    let c = lf_centre(s);
    let t = dot3(c - o, s.normal) / denom;
    if (!(t > t_min && t < t_max)) {
        return -1.0;
    }
    let r = s.radius * scale;
    let q = o + d * t - c;
    if (dot3(q, q) <= r * r) {
        return t;
    }
    return -1.0;
}

const LF_ORDER_DROP_BITS: u32 = 11u; // reconstruct.rs ORDER_DROP_BITS

// reconstruct.rs RayHit::before: by order_key(t), then splat index.
fn lf_before(t: f32, k: u32, u: f32, l: u32) -> bool {
    let a = bitcast<u32>(t) >> LF_ORDER_DROP_BITS;
    let b = bitcast<u32>(u) >> LF_ORDER_DROP_BITS;
    return a < b || (a == b && k < l);
}

fn lf_insert(t: f32, k: u32) {
    if (hit_count == LF_MAX_HITS && !lf_before(t, k, hit_t[LF_MAX_HITS - 1u], hit_splat[LF_MAX_HITS - 1u])) {
        return;
    }
    var at = hit_count;
    for (var j = 0u; j < hit_count; j = j + 1u) {
        if (lf_before(t, k, hit_t[j], hit_splat[j])) {
            at = j;
            break;
        }
    }
    var last = hit_count;
    if (hit_count == LF_MAX_HITS) {
        last = LF_MAX_HITS - 1u;
    } else {
        hit_count = hit_count + 1u;
    }
    for (var j = last; j > at; j = j - 1u) {
        hit_t[j] = hit_t[j - 1u];
        hit_splat[j] = hit_splat[j - 1u];
    }
    hit_t[at] = t;
    hit_splat[at] = k;
}

// collect: depth-first, left child first; a box is skipped once the list is full and it starts
// beyond the farthest kept hit.
fn lf_collect(o: vec3<f32>, d: vec3<f32>, t_min: f32) {
    hit_count = 0u;
    let inv_d = vec3<f32>(1.0) / d;
    stack[0] = 0u;
    var sp = 1u;
    loop {
        if (sp == 0u) {
            break;
        }
        sp = sp - 1u;
        let node = nodes_at(stack[sp]);
        var limit = inf();
        if (hit_count == LF_MAX_HITS) {
            limit = bitcast<f32>(bitcast<u32>(hit_t[LF_MAX_HITS - 1u]) | ((1u << LF_ORDER_DROP_BITS) - 1u));
        }
        let t0 = (node.min - o) * inv_d;
        let t1 = (node.max - o) * inv_d;
        let lo = min(t0, t1);
        let hi = max(t0, t1);
        let near = max(max(max(lo.x, lo.y), lo.z), t_min);
        let far = min(min(min(hi.x, hi.y), hi.z), limit);
        if (!(near <= far)) {
            continue;
        }
        if (node.count == 0u) {
            stack[sp] = node.index + 1u;
            stack[sp + 1u] = node.index;
            sp = sp + 2u;
            continue;
        }
        for (var k = node.index; k < node.index + node.count; k = k + 1u) {
            let t = lf_disk_hit(splats_at(k), o, d, t_min, inf(), 1.0);
            if (t >= 0.0) {
                lf_insert(t, k);
            }
        }
    }
}

// conflict (Sec. 2.3.2, Fig. 5).
fn lf_conflict(o: vec3<f32>, d: vec3<f32>, hi: vec3<f32>, ni: vec3<f32>, hj: vec3<f32>, nj: vec3<f32>) -> bool {
    let e = hj - hi;
    let along = dot3(e, d);
    let len = length3(e);
    if (abs(along) < LF_PARALLEL * len) {
        return false;
    }
    let u = dot3(o - hi, d) / along;
    let tol = LF_HALF_SPACE_TOLERANCE * len;
    var side_i = -dot3(e, ni);
    if (u >= 0.0) {
        side_i = dot3(e, ni);
    }
    var side_j = -dot3(e, nj);
    if (u >= 1.0) {
        side_j = dot3(e, nj);
    }
    return side_i > tol && side_j > tol;
}

fn lf_tent(s: Splat, q: vec3<f32>) -> f32 {
    if (s.radius > 0.0) {
        return max(1.0 - length3(q - lf_centre(s)) / s.radius, 0.0);
    }
    return 0.0;
}

struct Seen {
    radiance: vec3<f32>,
    found: bool,
    distance: f32,
}

// filter (Sec. 2.4) over the kept members [start, end) whose flag bit is set in `kept`.
fn lf_filter(start: u32, end: u32, kept: u32, o: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    var any_front = false;
    var glossy = false;
    for (var j = start; j < end; j = j + 1u) {
        if ((kept & (1u << (j - start))) == 0u) {
            continue;
        }
        let s = splats_at(hit_splat[j]);
        any_front = any_front || dot3(d, s.normal) < 0.0;
        glossy = glossy || s.kappa > 0.0;
    }
    var sum = vec3<f32>(0.0);
    var sum_w = 0.0;
    var best = vec3<f32>(0.0);
    var best_w = -1.0;
    var mean = vec3<f32>(0.0);
    var mean_n = 0u;
    for (var j = start; j < end; j = j + 1u) {
        if ((kept & (1u << (j - start))) == 0u) {
            continue;
        }
        let s = splats_at(hit_splat[j]);
        if (any_front && !(dot3(d, s.normal) < 0.0)) {
            continue;
        }
        let w = lf_tent(s, o + d * hit_t[j]);
        mean = mean + s.radiance;
        mean_n = mean_n + 1u;
        if (glossy) {
            let wg = w * exp(s.kappa * (dot3(s.direction, d) - 1.0));
            if (wg > best_w) {
                best = s.radiance;
                best_w = wg;
            }
        } else {
            sum = sum + s.radiance * w;
            sum_w = sum_w + w;
        }
    }
    if (glossy) {
        return best;
    }
    if (sum_w > 0.0) {
        return sum / sum_w;
    }
    return mean / f32(max(mean_n, 1u));
}

// resolve: the nearest apparent surface of the collected hits (steps 2-4).
fn lf_resolve(o: vec3<f32>, d: vec3<f32>, t_min: f32) -> Seen {
    var start = 0u;
    loop {
        if (start >= hit_count) {
            break;
        }
        var end = start + 1u;
        loop {
            if (end >= hit_count) {
                break;
            }
            let s = splats_at(hit_splat[end]);
            var clash = false;
            for (var m = start; m < end; m = m + 1u) {
                let q = splats_at(hit_splat[m]);
                if (lf_conflict(o, d, lf_centre(q), q.normal, lf_centre(s), s.normal)) {
                    clash = true;
                    break;
                }
            }
            if (clash) {
                break;
            }
            end = end + 1u;
        }
        let size = end - start;
        var scale = 1.0;
        if (size == 1u) {
            scale = 0.5;
        } else if (size == 2u) {
            scale = 2.0 / 3.0;
        }
        var kept = 0u;
        var first = -1.0;
        var any_front = false;
        for (var j = start; j < end; j = j + 1u) {
            let sj = splats_at(hit_splat[j]);
            if (scale == 1.0 || lf_disk_hit(sj, o, d, t_min, inf(), scale) >= 0.0) {
                kept = kept | (1u << (j - start));
                any_front = any_front || dot3(d, sj.normal) < 0.0;
                if (first < 0.0) {
                    first = hit_t[j];
                }
            }
        }
        // resolve's `two_sided`: a surface seen only from behind is passed through where it is off.
        if (kept == 0u || (params.two_sided == 0u && !any_front)) {
            start = end;
            continue;
        }
        return Seen(lf_filter(start, end, kept, o, d), true, first);
    }
    return Seen(vec3<f32>(0.0), false, 0.0);
}

// mod.rs RayShare: hit j of P takes rays r = k·P + j, ⌊N/P⌋ + [j < N mod P] of them.
fn lf_rays_of(j: u32) -> u32 {
    let p = max(params.primaries, 1u);
    return params.rays / p + select(0u, 1u, j < params.rays % p);
}

// mod.rs trace_gap (`gaps: trace`): a ray no splat answers, traced into the scene at `time` and its hit
// path-traced as an input ray's; 0 where it leaves the scene; for AO, occluded within max_distance.
fn lf_trace_gap(origin: vec3<f32>, dir: vec3<f32>, time: f32, key: u32, sample: u32) -> vec3<f32> {
    rays_secondary = rays_secondary + 1u;
    scene_time = time;
    let hit = scene_intersect(origin, dir, 0.0, inf());
    if (!hit.hit) {
        return vec3<f32>(0.0);
    }
    if (params.ao != 0u) {
        return vec3<f32>(select(0.0, 1.0, lf_ao_occluded(hit.t)));
    }
    return path_from_hit(hit, origin, dir, key, sample).value;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let hits = max(params.primaries, 1u);
    // Chunked (WgslSource::chunked_by): between dispatches `radiance` holds the running sum.
    var sum = vec3<f32>(0.0);
    if (chunk_resumes()) {
        sum = radiance_at(i);
    }
    let end = chunk_end_of(params.rays);
    var r = frame.chunk_begin;
    for (; r < end; r = r + 1u) {
        let j = r % hits;
        let k = r / hits;
        let prim = primary_at(i * params.primaries + j);
        if (prim.valid == 0u) {
            continue;
        }
        let n_j = lf_rays_of(j);
        let key = rng_key(frame.seed, pixel_id(gid), rng_substream(params.stream, j));
        let x = prim.position;
        let n = prim.normal;
        let wo = normalize_or_zero3(prim.eye - x);
        let l = lf_leave(n, prim.kd, prim.ks, prim.m, wo, key, k, n_j, true);
        if (all(l.weight == vec3<f32>(0.0))) {
            continue;
        }
        ray_time = prim.time;
        let side = select(-1.0, 1.0, dot3(l.wi, n) >= 0.0);
        let origin = x + n * (side * params.eps);
        lf_collect(origin, l.wi, params.eps);
        let seen = lf_resolve(origin, l.wi, params.eps);
        var value = seen.radiance;
        if (!seen.found && params.trace_gaps != 0u) {
            value = lf_trace_gap(origin, l.wi, prim.time, key, k);
        } else if (params.ao != 0u) {
            value = vec3<f32>(select(0.0, 1.0, seen.found && lf_ao_occluded(seen.distance)));
        }
        sum = sum + value * l.weight * (prim.weight / f32(max(n_j, 1u)));
    }
    count_cut_loop(r, end);
    atomicAdd(&counters[COUNTER_SHADOW], rays_shadow);
    atomicAdd(&counters[COUNTER_SECONDARY], rays_secondary);
    if (end < params.rays) {
        radiance_put(i, sum);
    } else {
        // RayShare::total_weight: Σ w_j over the hits that have rays (1 where that is 0).
        var total = 0.0;
        for (var j = 0u; j < hits; j = j + 1u) {
            if (lf_rays_of(j) > 0u) {
                total = total + primary_at(i * params.primaries + j).weight;
            }
        }
        if (!(total > 0.0)) {
            total = 1.0;
        }
        radiance_put(i, sum / total);
    }
}
