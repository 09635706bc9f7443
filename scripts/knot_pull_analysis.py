#!/usr/bin/env python3
"""Pull force against end shortening of config/scenes/overhand_knot.yaml, and its B/R^2 scale.

    corde_run config/scenes/overhand_knot.yaml --out knot.csv --reactions knot_r.csv --every 292
    scripts/knot_pull_analysis.py knot.csv knot_r.csv [--times 5,10,...] [--support right]

For each time: the end shortening e = l - |x_N - x_0| (l the rope's current length: the rope in
the knot; it stretches by 0.4% at 5 mN), the pull force F (the x reaction of the
grasp, averaged over +-1 s), the loop radius R (the loop is the longest run of segments touching no
non-neighbour; R = its arc length / its turning angle, the mean radius of curvature), the
prefactor F R^2 / B, the closest approach of non-neighbouring axes (/ r) and the segments in
contact. An elastic loop alone (no friction) gives F R^2 / B = 1/2. Needs numpy.
"""
import argparse
import collections
import csv

import numpy as np


def segment_distance(a0, a1, b0, b1):
    d1, d2, r = a1 - a0, b1 - b0, a0 - b0
    a, e, f, c, b = d1 @ d1, d2 @ d2, d2 @ r, d1 @ r, d1 @ d2
    den = a * e - b * b
    s = np.clip((b * f - c * e) / den, 0, 1) if den > 1e-20 else 0.0
    t = np.clip((b * s + f) / e, 0, 1)
    s = np.clip((b * t - c) / a, 0, 1)
    return np.linalg.norm(a0 + s * d1 - b0 - t * d2)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("trajectory")
    ap.add_argument("reactions")
    ap.add_argument("--times", default="5,10,15,20,25,30,35,40,45,49")
    ap.add_argument("--support", default="right")
    ap.add_argument("--radius", type=float, default=0.0016)
    ap.add_argument("--E", type=float, default=1.8e5)
    a = ap.parse_args()
    r = a.radius
    bend = a.E * np.pi * r**4 / 4
    frames = collections.OrderedDict()
    for row in csv.DictReader(open(a.trajectory)):
        frames.setdefault(float(row["t"]), []).append(
            [float(row[k]) for k in ("x0", "y0", "z0", "x1", "y1", "z1")])
    ft, fx = [], []
    for row in csv.DictReader(open(a.reactions)):
        if row["support"] == a.support:
            ft.append(float(row["t"]))
            fx.append(float(row["fx"]))
    ft, fx = np.array(ft), np.array(fx)
    times = np.array(list(frames))
    print("t_s  e_m    F_N      F_sd_N   R_m     FR2/B  closest/r  in_contact")
    for query in (float(q) for q in a.times.split(",")):
        t = times[np.abs(times - query).argmin()]
        seg = np.array(frames[t])
        x = np.vstack([seg[:, :3], seg[-1:, 3:]])
        n = len(seg)
        length = np.linalg.norm(np.diff(x, axis=0), axis=1).sum()
        touching, closest = set(), np.inf
        for i in range(n):
            for j in range(i + 3, n):
                d = segment_distance(x[i], x[i + 1], x[j], x[j + 1])
                closest = min(closest, d)
                if d < 2.2 * r:
                    touching.update([i, j])
        if len(touching) < 2:
            print("%5.1f no strands in contact" % t)
            continue
        c = sorted(touching)
        k = int(np.diff(c).argmax())
        lo, hi = c[k], c[k + 1]
        tan = np.diff(x, axis=0)
        tan /= np.linalg.norm(tan, axis=1)[:, None]
        turn = sum(np.arccos(np.clip(tan[i] @ tan[i + 1], -1, 1)) for i in range(lo, hi))
        radius = (hi - lo) * length / n / turn
        w = (ft > t - 1) & (ft <= t + 1)
        force = fx[w].mean()
        e = length - np.linalg.norm(x[-1] - x[0])
        print("%5.1f %.3f %.5f %.5f %.4f %.2f   %.4f     %d" %
              (t, e, force, fx[w].std(), radius, force * radius**2 / bend, closest / r, len(touching)))


if __name__ == "__main__":
    main()
