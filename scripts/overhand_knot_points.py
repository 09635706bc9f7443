#!/usr/bin/env python3
"""Points of a loose open overhand knot, for the polyline shape of config/scenes/overhand_knot.yaml.

The knot is the trefoil (sin t + 2 sin 2t, cos t - 2 cos 2t, -sin 3t) cut open at the tip of one
lobe: the arc within `delta` of the tip is removed and each cut end turns, along a cubic Hermite
blend, into a straight tail along the x axis (the start tail to -x, the end tail to +x). The tails
run at the heights of the two cut ends, so they pass each other one above the other; closed far
away, the curve is a trefoil (an overhand knot), not an unknot. The knot part is scaled to
`--knot-length` of rope, the tails share the rest of `--length`; the tails lie along y = 0.

    scripts/overhand_knot_points.py [--length 1.0] [--knot-length 0.4] [--delta 0.3]
                                    [--blend 0.04] [--points 240]

prints `points: [[x, y, z], ...]` (m), one point a line, for pasting into the scene. Needs numpy.
"""
import argparse

import numpy as np


def trefoil(t):
    return np.stack([np.sin(t) + 2 * np.sin(2 * t), np.cos(t) - 2 * np.cos(2 * t), -np.sin(3 * t)], -1)


def trefoil_tangent(t):
    return np.stack([np.cos(t) + 4 * np.cos(2 * t), -np.sin(t) + 4 * np.sin(2 * t), -3 * np.cos(3 * t)],
                    -1)


def hermite(a, ta, b, tb, n=60):
    """Cubic Hermite from a (unit tangent ta) to b (unit tangent tb), tangents scaled by |b - a|."""
    k = np.linalg.norm(b - a)
    u = np.linspace(0.0, 1.0, n)[:, None]
    return ((2 * u**3 - 3 * u**2 + 1) * a + (u**3 - 2 * u**2 + u) * k * ta +
            (-2 * u**3 + 3 * u**2) * b + (u**3 - u**2) * k * tb)


def knot_curve(length, knot_length, delta, blend):
    tip = np.pi / 3  # a lobe tip: farthest from the axis, z = 0
    t = np.linspace(tip + delta, tip + 2 * np.pi - delta, 4001)
    p = trefoil(t)
    scale = knot_length / np.linalg.norm(np.diff(p, axis=0), axis=1).sum()
    # Frame: x along the tip's tangent in the plane, y out of the lobe, z as in the trefoil.
    x = trefoil_tangent(tip)
    x[2] = 0.0
    x /= np.linalg.norm(x)
    y = trefoil(tip) / np.linalg.norm(trefoil(tip))
    rot = np.array([x, y, [0.0, 0.0, 1.0]])
    p = scale * p @ rot.T
    t1 = trefoil_tangent(tip + delta) @ rot.T
    t2 = trefoil_tangent(tip - delta) @ rot.T
    t1 /= np.linalg.norm(t1)
    t2 /= np.linalg.norm(t2)
    ex = np.array([1.0, 0.0, 0.0])
    q1 = p[0] - blend * ex
    q2 = p[-1] + blend * ex
    curve = np.vstack([hermite(q1, ex, p[0], t1)[:-1], p, hermite(p[-1], t2, q2, ex)[1:]])
    tail = (length - np.linalg.norm(np.diff(curve, axis=0), axis=1).sum()) / 2
    if tail <= 0:
        raise SystemExit("knot-length too long for the rope")
    curve = np.vstack([q1 - tail * ex, curve, q2 + tail * ex])
    curve[:, 1] -= curve[0, 1]  # tails on the line y = 0
    return curve


def resample(curve, count):
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(curve, axis=0), axis=1))])
    s = np.linspace(0.0, cum[-1], count)
    return np.stack([np.interp(s, cum, curve[:, k]) for k in range(3)], -1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--length", type=float, default=1.0)
    ap.add_argument("--knot-length", type=float, default=0.4)
    ap.add_argument("--delta", type=float, default=0.3)
    ap.add_argument("--blend", type=float, default=0.04)
    ap.add_argument("--points", type=int, default=240)
    a = ap.parse_args()
    # The straight tails need only their ends; the rest at equal arc length.
    curve = knot_curve(a.length, a.knot_length, a.delta, a.blend)
    inner = resample(curve[1:-1], a.points - 2)
    pts = np.round(np.vstack([curve[:1], inner, curve[-1:]]), 5) + 0.0  # no "-0.00000"
    print("points: [")
    print(",\n".join("  [%.5f, %.5f, %.5f]" % tuple(q) for q in pts))
    print("]")


if __name__ == "__main__":
    main()
