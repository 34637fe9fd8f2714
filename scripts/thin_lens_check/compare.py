#!/usr/bin/env python3
"""Compare a wedge reference EXR with a Mitsuba EXR (both linear): image means, per-region means,
RMSE, and an error image. Exits 1 when the image means differ by more than --tolerance (1%).

Regions come from the aux EXR of mitsuba_render.py (depth z along the optical axis and material of
the pinhole ray through each pixel centre) and the circle of confusion of thesis eq. 5.2,
r = A·H/(2 f tan(fov/2)) · |f/z − 1| pixels: in focus (r < 0.5 px), blurred foreground (z < f,
r >= 1.5 px), blurred background (z > f, r >= 1.5 px), and the same restricted to the pieces'
pixels (materials named `piece ...`), where a blurred silhouette mixes piece and board.
A noise floor is estimated from two Mitsuba renders with different seeds (--noise).
"""

import argparse
import json
import math
import os
import sys

import numpy as np


def load(mi, path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[:, :, :3]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("wedge")
    ap.add_argument("mitsuba")
    ap.add_argument("--scene-dir", required=True)
    ap.add_argument("--aux", required=True)
    ap.add_argument("--noise", help="a second Mitsuba render (other seed): RMSE between the two = its noise")
    ap.add_argument("--error-image", help="write |wedge - mitsuba| luminance (linear EXR) and a PNG")
    ap.add_argument("--figure", help="write wedge | Mitsuba | error side by side (sRGB PNG, exposure --exposure)")
    ap.add_argument("--exposure", type=float, default=1.0)
    ap.add_argument("--tolerance", type=float, default=0.01)
    ap.add_argument("--label", default="")
    a = ap.parse_args()

    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    meta = json.load(open(os.path.join(a.scene_dir, "scene.json")))
    cam = meta["camera"]
    w, m = load(mi, a.wedge), load(mi, a.mitsuba)
    aux = np.array(mi.Bitmap(a.aux), dtype=np.float64)
    z, mat = aux[:, :, 0], aux[:, :, 1].round().astype(int) - 1
    H = w.shape[0]
    f, A = cam["focus_distance"], cam["aperture_radius"]
    scale = A * H / (2 * f * math.tan(math.radians(cam["vfov_deg"]) / 2))
    with np.errstate(divide="ignore", invalid="ignore"):
        coc = np.where(np.isfinite(z), scale * np.abs(f / z - 1), np.inf)
    piece = np.isin(mat, [x["index"] for x in meta["materials"] if x["name"].startswith("piece")])
    regions = {
        "whole image": np.ones_like(z, bool),
        "in focus (r < 0.5 px)": coc < 0.5,
        "blurred foreground (z < f, r >= 1.5 px)": (z < f) & (coc >= 1.5),
        "blurred background (z > f, r >= 1.5 px)": (z > f) & (coc >= 1.5) & np.isfinite(z),
        "pieces in focus": piece & (coc < 0.5),
        "pieces, foreground": piece & (z < f) & (coc >= 1.5),
        "pieces, background": piece & (z > f) & (coc >= 1.5),
    }
    lum = lambda img: img @ np.array([0.2126, 0.7152, 0.0722])
    lw, lm = lum(w), lum(m)
    ln = lum(load(mi, a.noise)) if a.noise else None
    print(f"{a.label}: wedge {a.wedge} vs mitsuba {a.mitsuba}")
    print(f"{'region':42} {'pixels':>7} {'wedge mean':>11} {'mitsuba mean':>13} {'rel diff':>9} {'RMSE':>9} {'noise RMSE':>10}")
    ok = True
    for name, mask in regions.items():
        if not mask.any():
            continue
        mw, mm = lw[mask].mean(), lm[mask].mean()
        rmse = math.sqrt(((w - m)[mask] ** 2).mean())
        # Two renders' difference has twice the variance of one: RMSE(m1 - m2)/sqrt(2) is one render's noise.
        noise = math.sqrt(((lm - ln)[mask] ** 2).mean() / 2) if ln is not None else float("nan")
        rel = (mw - mm) / mm
        print(f"{name:42} {mask.sum():7d} {mw:11.5f} {mm:13.5f} {rel:+9.2%} {rmse:9.5f} {noise:10.5f}")
        if name == "whole image" and abs(rel) > a.tolerance:
            ok = False
    if a.error_image:
        err = np.abs(lw - lm).astype(np.float32)
        mi.Bitmap(np.repeat(err[:, :, None], 3, axis=2)).write(a.error_image)
        png = os.path.splitext(a.error_image)[0] + ".png"
        peak = max(float(np.percentile(err, 99.5)), 1e-6)
        img = np.clip(err / peak, 0, 1)
        mi.Bitmap((np.stack([img, img * 0.4, 1 - img], axis=2) * 255).astype(np.uint8)).write(png)
        print(f"wrote {a.error_image} and {png} (|Δ luminance|, blue 0 .. red {peak:.4f}, the 99.5th percentile)")
    if a.figure:
        srgb = lambda x: np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(np.clip(x, 0.0031308, None), 1 / 2.4) - 0.055)
        show = lambda img: srgb(np.clip(img * a.exposure, 0, 1))
        err = np.abs(lw - lm)
        peak = max(float(np.percentile(err, 99.5)), 1e-6)
        e = np.clip(err / peak, 0, 1)
        panel = np.concatenate([show(w), show(m), np.stack([e, e * 0.4, 1 - e], axis=2)], axis=1)
        mi.Bitmap((panel * 255 + 0.5).astype(np.uint8)).write(a.figure)
        print(f"wrote {a.figure} (wedge | Mitsuba | |Δ luminance| blue 0 .. red {peak:.4f})")
    print("image means within {:.0%}: {}".format(a.tolerance, "yes" if ok else "NO"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
