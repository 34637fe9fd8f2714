#!/usr/bin/env python3
"""Embree side of `cargo bench --bench throughput` (issue 12): trace the rays wedge traced, with Embree 4
through the `embreex` package, one thread, and print Mrays/s and hit counts as JSON on stdout.

Usage: embree_compare.py RAYS_FILE [MIN_SECONDS]

RAYS_FILE (written by benches/throughput.rs; little-endian, no padding):

    b"WEDGERAY"                     magic
    u32 version = 1
    u32 N                           triangles, in wedge's input order (Embree's primID = wedge's `source`)
    f32 [N][3][3]                   vertices
    u32 S                           ray sets
    S times:
        u8[16] name                 ASCII, NUL-padded ("primary", "shadow", "diffuse")
        u32 M                       rays
        f32 [M][3] origins
        f32 [M][3] directions       (not necessarily unit length; t is in units of the direction)
        f32 [M] tmax                (inf for closest-hit rays without a bound)
        u32 Q                       queries to run on these rays
        Q times:
            u32 kind                0 = closest hit (INTERSECT), 1 = any hit (OCCLUDED)
            i32 [M] wedge           wedge's result per ray: closest → input index of the hit triangle
                                    or -1; any hit → 0 if occluded, -1 if not (embreex's convention)

Output: {"embree": {...}, "build_seconds": s, "results": [{"set", "query", "rays", "mrays", "passes",
"seconds", "hits", "wedge_hits", "agree", "cpu_per_wall"}, ...]}. `agree` counts rays whose Embree
result equals wedge's (same triangle, or both miss / same occlusion), so a ratio of speeds is only read
together with proof that the same rays found the same answers.

What embreex 4.4 does, read from its source (embreex/rtcore_scene.pyx) and checked on a one-triangle
scene: `EmbreeScene.run(origins, dirs, dists, query)` loops over the rays in Cython calling
`rtcIntersect1` / `rtcOccluded1` one ray at a time on the calling thread (no ray streams, no threads), with
`tnear` fixed at 0 and `tfar` = `dists` (1e37 when None); INTERSECT returns primID or -1, OCCLUDED 0 or -1.
The scene is built with RTC_BUILD_QUALITY_HIGH, not robust, on `rtcCommitScene` at the first `run`,
which uses all cores (TBB; embreex exposes no device config to limit it) — so the build time printed
here is multi-threaded while the traversal timings are one thread. wedge's bench also traces with
tmin = 0 (shadow and bounce origins are offset along the normal instead), so the fixed tnear costs
Embree nothing and gives it nothing. The per-ray Cython overhead (filling an RTCRayHit, numpy indexing)
is counted against Embree; it is a few ns against the ~100+ ns of a traversal.
"""

import json
import os
import struct
import sys
import time

import numpy as np
import embreex
from embreex import mesh_construction, rtcore_scene

QUERIES = {0: ("closest", "INTERSECT"), 1: ("any", "OCCLUDED")}


class Reader:
    def __init__(self, data):
        self.data = data
        self.pos = 0

    def u32(self):
        (v,) = struct.unpack_from("<I", self.data, self.pos)
        self.pos += 4
        return v

    def array(self, dtype, shape):
        count = int(np.prod(shape))
        a = np.frombuffer(self.data, dtype=dtype, count=count, offset=self.pos).reshape(shape)
        self.pos += a.nbytes
        # embreex's typed buffers want C-contiguous, writable arrays.
        return np.array(a, copy=True)


def read_rays(path):
    with open(path, "rb") as f:
        data = f.read()
    r = Reader(data)
    if data[:8] != b"WEDGERAY":
        raise SystemExit(f"{path}: not a wedge ray file")
    r.pos = 8
    version = r.u32()
    if version != 1:
        raise SystemExit(f"{path}: version {version}, this script reads 1")
    n = r.u32()
    vertices = r.array("<f4", (n, 3, 3))
    sets = []
    for _ in range(r.u32()):
        name = data[r.pos : r.pos + 16].rstrip(b"\0").decode("ascii")
        r.pos += 16
        m = r.u32()
        origins = r.array("<f4", (m, 3))
        dirs = r.array("<f4", (m, 3))
        tmax = r.array("<f4", (m,))
        queries = []
        for _ in range(r.u32()):
            kind = r.u32()
            queries.append((kind, r.array("<i4", (m,))))
        sets.append((name, origins, dirs, tmax, queries))
    if r.pos != len(data):
        raise SystemExit(f"{path}: {len(data) - r.pos} trailing bytes")
    return vertices, sets


def main():
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    min_secs = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
    vertices, sets = read_rays(sys.argv[1])
    scene = rtcore_scene.EmbreeScene()
    mesh_construction.TriangleMesh(scene, vertices)
    # The first run commits (builds) the scene; time it apart from the traversal.
    t = time.perf_counter()
    scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))
    build = time.perf_counter() - t
    results = []
    for name, origins, dirs, tmax, queries in sets:
        for kind, wedge in queries:
            label, query = QUERIES[kind]
            passes, secs, cpu = 0, 0.0, 0.0
            while passes == 0 or secs < min_secs:
                c0, t0 = time.process_time(), time.perf_counter()
                out = scene.run(origins, dirs, dists=tmax, query=query)
                secs += time.perf_counter() - t0
                cpu += time.process_time() - c0
                passes += 1
            results.append(
                {
                    "set": name,
                    "query": label,
                    "rays": len(origins),
                    "mrays": len(origins) * passes / secs / 1e6,
                    "passes": passes,
                    "seconds": secs,
                    "hits": int((out != -1).sum()),
                    "wedge_hits": int((wedge != -1).sum()),
                    "agree": int((out == wedge).sum()),
                    # ≈ 1 when the traversal ran on one thread (process CPU time over wall time).
                    "cpu_per_wall": cpu / secs,
                }
            )
    info = {"embreex": embreex.__version__, "triangles": len(vertices), "cpus": os.cpu_count()}
    print(json.dumps({"embree": info, "build_seconds": build, "results": results}))


if __name__ == "__main__":
    main()
