#!/usr/bin/env python3
"""Render a `wedge export-scene` directory with Mitsuba 3 (PyPI `mitsuba`), independently of wedge.

Direct light only (Mitsuba's `path` integrator with max_depth 2: emitter sampling + BSDF sampling,
MIS) through Mitsuba's own `thinlens` sensor, from the exported OBJ + scene.json. What is matched to
wedge, and why (docs/DESIGN-NOTES.md "Independent thin-lens check"):

- camera: scene.json's look-at frame, vertical fov, aperture radius and focus distance. Mitsuba's
  thinlens samples a uniform disk (concentric map) and puts the focal plane perpendicular to the
  optical axis at `focus_distance` (focus point = d * focus_distance / d.z in camera space), which is
  wedge's convention (scene/src/camera.rs); the script asserts both readings on rays it generates.
- pixel sampling (`--pixel centre`, default): wedge's SoftShadows asks the sampler for `jitter` off,
  so every path goes through the pixel centre. Mitsuba's film jitters uniformly over the pixel (its
  `box` filter is that jitter), so this script generates the camera rays itself at the pixel
  centres (`sensor.sample_ray` with film position ((x + 0.5)/W, (y + 0.5)/H) and a fresh lens
  sample per path) and calls the integrator on them. `--pixel box` renders with `mi.render` and a
  box reconstruction filter instead (the jittered, box-filtered image) to show what the difference is.
- materials: every surface Lambertian, two-sided (wedge shades either side of a triangle).
  `--albedo white`: k_d = 1 everywhere (wedge: the path sampler with LENS_WHITE=1, run.sh step 2).
  `--albedo textured`: k_d = base_color x texture, the board texture as exported (linear EXR,
  bilinear, repeat, v = 0 the top row — the same as wedge's lookup, asserted below); the Phong
  lobes of the glossy pieces are left out (SoftShadows composes E x albedo: its direct light has no
  glossy term).
- light: the exported emissive triangles as a one-sided `area` emitter with the exported radiance
  (no vertex normals, so Mitsuba's geometric normal = the triangles' winding normal = wedge's
  emitting side).

Writes a linear RGB EXR (`--out`), and with `--aux` a depth/material EXR for region masks.
`--face-normals` drops the exported shading normals (the residual's diagnosis in DESIGN-NOTES).
"""

import argparse
import json
import os
import sys
import time

import numpy as np


def parse_obj(path):
    """The OBJ `wedge export-scene` writes: per `usemtl` group, triangle positions, normals, uvs."""
    v, vt, vn = [], [], []
    groups = {}
    current = None
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                v.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("vt "):
                vt.append([float(x) for x in line.split()[1:3]])
            elif line.startswith("vn "):
                vn.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("usemtl "):
                current = groups.setdefault(line.split(None, 1)[1].strip(), {"p": [], "n": [], "uv": []})
            elif line.startswith("f "):
                for corner in line.split()[1:4]:
                    i, t, n = (int(k) - 1 for k in corner.split("/"))
                    current["p"].append(v[i])
                    current["n"].append(vn[n])
                    # The OBJ stores vt = (u, 1 - v); scene.json's (and Mitsuba's) v = 0 is the top row.
                    current["uv"].append([vt[t][0], 1.0 - vt[t][1]])
    return {k: {kk: np.array(vv, dtype=np.float32) for kk, vv in g.items()} for k, g in groups.items()}


def build_mesh(mi, name, g, bsdf, emitter=None, normals=True):
    props = mi.Properties()
    props["bsdf"] = bsdf
    if emitter is not None:
        props["emitter"] = emitter
    nv = len(g["p"])
    mesh = mi.Mesh(name, nv, nv // 3, props, normals, True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = g["p"].ravel()
    params["faces"] = np.arange(nv, dtype=np.uint32)
    if normals:
        params["vertex_normals"] = g["n"].ravel()
    params["vertex_texcoords"] = g["uv"].ravel()
    params.update()
    return mesh


def wedge_bilinear(tex, uv):
    """scene/src/texture.rs Texture::sample, in numpy (for the lookup-convention assertion)."""
    h, w = tex.shape[:2]
    x = np.mod(uv[:, 0], 1.0) * w - 0.5
    y = np.mod(uv[:, 1], 1.0) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    xi, yi = x0.astype(int), y0.astype(int)
    t = lambda a, b: tex[np.mod(b, h), np.mod(a, w)]
    top = t(xi, yi) * (1 - fx) + t(xi + 1, yi) * fx
    bottom = t(xi, yi + 1) * (1 - fx) + t(xi + 1, yi + 1) * fx
    return top * (1 - fy) + bottom * fy


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene_dir")
    ap.add_argument("--out", required=True)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--albedo", choices=["white", "textured"], default="textured")
    ap.add_argument("--pixel", choices=["centre", "box"], default="centre")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--face-normals", action="store_true", help="drop the vertex normals (flat shading; see DESIGN-NOTES)")
    ap.add_argument("--chunk", type=int, default=16, help="paths per pixel per launch (memory)")
    ap.add_argument("--aux", help="also write depth along the optical axis (R), material index + 1 (G) at pixel centres")
    a = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    mi.set_variant(a.variant)
    meta = json.load(open(os.path.join(a.scene_dir, "scene.json")))
    W, H = meta["image"]["width"], meta["image"]["height"]
    cam = meta["camera"]
    groups = parse_obj(os.path.join(a.scene_dir, meta["obj"]))
    by_mtl = {m["mtl"]: m for m in meta["materials"]}

    # Texture lookup convention: Mitsuba's bitmap (bilinear, repeat) must equal wedge's lookup.
    textures = []
    for t in meta["textures"]:
        arr = np.array(mi.Bitmap(os.path.join(a.scene_dir, t["exr"])), dtype=np.float32)[:, :, :3]
        textures.append(arr)
        bm = mi.load_dict({"type": "bitmap", "bitmap": mi.Bitmap(arr), "raw": True, "filter_type": "bilinear",
                           "wrap_mode": "repeat"})
        uv = np.random.default_rng(0).uniform(-3, 3, size=(4096, 2)).astype(np.float32)
        si = dr.zeros(mi.SurfaceInteraction3f, len(uv))
        si.uv = mi.Point2f(uv[:, 0], uv[:, 1])
        got = np.array(bm.eval(si)).reshape(3, -1).T
        want = wedge_bilinear(arr, uv)
        err = np.abs(got - want).max()
        assert err < 1e-4, f"texture {t['index']}: Mitsuba's bilinear lookup differs from wedge's by {err}"
        print(f"texture {t['index']}: Mitsuba bilinear lookup = wedge's (max diff {err:.2e} over 4096 uvs)")

    scene_dict = {"type": "scene"}
    material_index = {}
    for k, (name, g) in enumerate(sorted(groups.items())):
        m = by_mtl[name]
        material_index[name] = material_index[f"mesh{k}"] = m["index"]
        if max(m["emission"]) > 0:
            black = mi.load_dict({"type": "diffuse", "reflectance": {"type": "rgb", "value": [0, 0, 0]}})
            emitter = mi.load_dict({"type": "area", "radiance": {"type": "rgb", "value": m["emission"]}})
            scene_dict[f"mesh{k}"] = build_mesh(mi, name, g, black, emitter, normals=False)
            continue
        if a.albedo == "white":
            refl = {"type": "rgb", "value": [1.0, 1.0, 1.0]}
        elif m["texture"] is not None:
            baked = textures[m["texture"]] * np.array(m["base_color"], dtype=np.float32)
            refl = {"type": "bitmap", "bitmap": mi.Bitmap(baked), "raw": True, "filter_type": "bilinear", "wrap_mode": "repeat"}
        else:
            refl = {"type": "rgb", "value": m["base_color"]}
        bsdf = mi.load_dict({"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": refl}})
        scene_dict[f"mesh{k}"] = build_mesh(mi, name, g, bsdf, normals=not a.face_normals)
    for light in meta["lights"]:
        assert not light["two_sided"], "a two-sided light needs two emitters here"

    to_world = mi.ScalarTransform4f().look_at(origin=cam["position"], target=cam["look_at"], up=cam["up"])
    sensor_dict = {
        "type": "thinlens" if cam["aperture_radius"] > 0 else "perspective",
        "to_world": to_world,
        "fov": cam["vfov_deg"],
        "fov_axis": "y",
        "film": {"type": "hdrfilm", "width": W, "height": H, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        "sampler": {"type": "independent", "sample_count": a.spp, "seed": a.seed},
    }
    if cam["aperture_radius"] > 0:
        sensor_dict["aperture_radius"] = cam["aperture_radius"]
        sensor_dict["focus_distance"] = cam["focus_distance"]
    scene_dict["sensor"] = sensor_dict
    scene_dict["integrator"] = {"type": "path", "max_depth": 2, "hide_emitters": False}
    scene = mi.load_dict(scene_dict)
    sensor = scene.sensors()[0]
    integrator = scene.integrator()

    # Camera conventions, checked on Mitsuba's own rays: origins on a disk of the aperture radius
    # around the position in the plane perpendicular to forward; all rays of one film point meet
    # on the plane perpendicular to forward at focus_distance, where the pinhole ray meets it.
    pos, fwd = np.array(cam["position"]), np.array(cam["forward"])
    n = 4096
    rng = np.random.default_rng(1)
    film = mi.Point2f(np.full(n, 0.3, np.float32), np.full(n, 0.7, np.float32))
    lens = rng.uniform(size=(n, 2)).astype(np.float32)
    ray, _ = sensor.sample_ray(0.0, 0.5, film, mi.Point2f(lens[:, 0], lens[:, 1]))
    o = np.array(ray.o).reshape(3, -1).T
    d = np.array(ray.d).reshape(3, -1).T
    # Mitsuba starts camera rays at the near clip plane: move them back to the lens plane.
    o = o - d * (((o - pos) @ fwd) / (d @ fwd))[:, None]
    rel = o - pos
    radial = np.linalg.norm(rel - np.outer(rel @ fwd, fwd), axis=1)
    assert np.abs(rel @ fwd).max() < 1e-5 and radial.max() <= cam["aperture_radius"] * (1 + 1e-4), "lens not a disk at position"
    t = (cam["focus_distance"] - rel @ fwd) / (d @ fwd)
    hit = o + d * t[:, None]
    spread = np.linalg.norm(hit - hit.mean(axis=0), axis=1).max()
    assert spread < 1e-4, f"rays of one film point do not meet on the focal plane (spread {spread})"
    # Mean radius of uniform disk samples is 2/3 of the radius.
    print(f"thin lens: origins on a disk (max radius {radial.max():.5f}, mean {radial.mean() / cam['aperture_radius']:.3f} R, "
          f"uniform disk 0.667 R); one film point's rays meet on the plane at focus_distance along forward (spread {spread:.1e} m)")

    t0 = time.time()
    if a.pixel == "box":
        img = np.array(mi.render(scene, spp=a.spp, seed=a.seed))[:, :, :3]
    else:
        acc = np.zeros((H * W, 3), np.float64)
        done = 0
        launch = 0
        while done < a.spp:
            c = min(a.chunk, a.spp - done)
            lanes = W * H * c
            sampler = mi.load_dict({"type": "independent"})
            sampler.seed(a.seed * 100003 + launch, lanes)
            idx = dr.arange(mi.UInt32, lanes)
            pix = idx // c
            x, y = pix % W, pix // W
            film = mi.Point2f((mi.Float(x) + 0.5) / W, (mi.Float(y) + 0.5) / H)
            ray, weight = sensor.sample_ray(0.0, sampler.next_1d(), film, sampler.next_2d())
            L, valid, _ = integrator.sample(scene, sampler, ray, None, True)
            L = L * weight
            out = dr.zeros(mi.Float, W * H * 3)
            for ch in range(3):
                dr.scatter_reduce(dr.ReduceOp.Add, out, L[ch], pix * 3 + ch)
            acc += np.array(out, dtype=np.float64).reshape(-1, 3)
            done += c
            launch += 1
        img = (acc / a.spp).reshape(H, W, 3).astype(np.float32)
    print(f"mitsuba {a.variant} {a.albedo} {a.pixel}: {W}x{H}, {a.spp} spp in {time.time() - t0:.1f} s")
    mi.Bitmap(img).write(a.out)

    if a.aux:
        idx = dr.arange(mi.UInt32, W * H)
        film = mi.Point2f((mi.Float(idx % W) + 0.5) / W, (mi.Float(idx // W) + 0.5) / H)
        ray, _ = sensor.sample_ray(0.0, 0.5, film, mi.Point2f(0.5, 0.5))  # lens centre: the pinhole ray
        si = scene.ray_intersect(ray)
        p = np.array(si.p).reshape(3, -1).T
        depth = np.where(np.array(si.is_valid()), (p - pos) @ fwd, np.inf)
        mat = np.zeros(W * H, np.float32)
        for s in scene.shapes():
            hit_s = np.array((si.shape == mi.ShapePtr(s)) & si.is_valid())
            mat[hit_s] = material_index[s.id()] + 1
        aux = np.stack([depth.astype(np.float32), mat, np.zeros_like(mat)], axis=1).reshape(H, W, 3)
        mi.Bitmap(aux).write(a.aux)
    return 0


if __name__ == "__main__":
    sys.exit(main())
