#!/usr/bin/env python3
"""Keyframes of the working end that ties config/scenes/tie_overhand_knot.yaml's overhand knot.

The rope starts straight along x, its ends held by grasps. The grasp `right` (the working end)
follows a smooth curve through hand-placed waypoints: it turns back over the rope to form a
bight, runs left, crosses over the standing part (the loop is made), dives under the standing
part, comes up through the loop and leaves to the right over the bight. The end segment's
tangent d3 follows the curve's direction (the end leads, the rope trails) and its frame is
carried along the curve by parallel transport, so the holder puts no twist into the rope.

    scripts/tie_knot_path.py > config/scenes/tie_overhand_knot_right.csv
    scripts/tie_knot_path.py --control > config/scenes/tie_overhand_knot_control.csv
    options: [--speed 0.04] [--every 0.25] [--settle 2] [--pull 40]

prints the keyframe CSV (time, x, y, z, qx, qy, qz, qw) for the grasp `right`: the path at
constant speed, a rest of --settle s, then --pull s along +x at 3 mm/s. --control
misses the loop: the end comes up beside the loop instead of through it (an unknot). Plain
python3, no numpy.
"""
import argparse
import math

START = (0.495, 0.0, 0.0)  # the end segment's midpoint at t = 0 (100 elements of 1 cm)

# Waypoints (m) after the start; the loop lies in z = 0 between y = 0 (standing part) and y = D.
THROUGH = [
    (0.44, 0.06, 0.0), (0.35, 0.10, 0.0), (0.15, 0.10, 0.0), (0.0, 0.10, 0.01),
    (-0.10, 0.08, 0.03), (-0.13, 0.0, 0.03), (-0.12, -0.07, 0.0), (-0.08, -0.08, -0.03),
    (-0.03, -0.04, -0.035), (-0.01, 0.0, -0.035), (0.0, 0.01, -0.02), (0.0, 0.01, 0.04),
    (0.08, 0.0, 0.05), (0.20, 0.0, 0.02), (0.30, 0.0, 0.0),
]
# The control: the end comes up outside the loop (y > D) instead of inside it.
BESIDE = THROUGH[:10] + [(0.0, 0.05, -0.03), (0.0, 0.16, -0.02), (0.01, 0.17, 0.03),
                         (0.08, 0.15, 0.04), (0.20, 0.06, 0.02), (0.30, 0.0, 0.0)]


def sub(a, b): return tuple(x - y for x, y in zip(a, b))
def add(a, b): return tuple(x + y for x, y in zip(a, b))
def mul(a, s): return tuple(x * s for x in a)
def dot(a, b): return sum(x * y for x, y in zip(a, b))
def norm(a): return math.sqrt(dot(a, a))
def unit(a): return mul(a, 1.0 / norm(a))
def cross(a, b): return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def catmull_rom(points, samples=40):
    """Uniform Catmull-Rom spline through the points (the end tangents from mirrored points)."""
    p = [add(points[0], sub(points[0], points[1]))] + list(points) + [add(points[-1], sub(points[-1], points[-2]))]
    out = []
    for i in range(1, len(p) - 2):
        p0, p1, p2, p3 = p[i - 1], p[i], p[i + 1], p[i + 2]
        for k in range(samples):
            u = k / samples
            c = [(-u**3 + 2 * u**2 - u) / 2, (3 * u**3 - 5 * u**2 + 2) / 2,
                 (-3 * u**3 + 4 * u**2 + u) / 2, (u**3 - u**2) / 2]
            out.append(tuple(c[0] * a + c[1] * b + c[2] * d + c[3] * e for a, b, d, e in zip(p0, p1, p2, p3)))
    out.append(points[-1])
    return out


def quat_from_matrix(d1, d2, d3):
    """[qx, qy, qz, qw] of the rotation with columns d1, d2, d3."""
    m = [[d1[0], d2[0], d3[0]], [d1[1], d2[1], d3[1]], [d1[2], d2[2], d3[2]]]
    tr = m[0][0] + m[1][1] + m[2][2]
    if tr > 0:
        s = 2 * math.sqrt(tr + 1)
        q = ((m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, s / 4)
    else:
        i = max(range(3), key=lambda k: m[k][k])
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2 * math.sqrt(1 + m[i][i] - m[j][j] - m[k][k])
        q = [0.0] * 4
        q[i] = s / 4
        q[j] = (m[j][i] + m[i][j]) / s
        q[k] = (m[k][i] + m[i][k]) / s
        q[3] = (m[k][j] - m[j][k]) / s
    q = list(q)
    return mul(q, 1.0 / norm(q))


def keyframes(waypoints, speed, every, start_time):
    curve = catmull_rom([START] + waypoints)
    # Arc length along the curve, sampled every `every` seconds at constant speed.
    cum = [0.0]
    for a, b in zip(curve, curve[1:]):
        cum.append(cum[-1] + norm(sub(b, a)))
    total = cum[-1]
    n = max(2, int(math.ceil(total / speed / every)))
    d3 = (1.0, 0.0, 0.0)  # the rope's tangent at the end at t = 0
    d1 = (0.0, 0.0, 1.0)
    rows, seg = [], 0
    # d1, d2 start as the straight rod's frame (d1 = z, d2 = -y, d3 = x) and are carried along the
    # curve by parallel transport, so the holder never turns the end about its tangent.
    for k in range(1, n + 1):
        s = total * k / n
        while seg < len(cum) - 2 and cum[seg + 1] < s:
            seg += 1
        u = (s - cum[seg]) / (cum[seg + 1] - cum[seg])
        pos = add(curve[seg], mul(sub(curve[seg + 1], curve[seg]), u))
        t_new = unit(sub(curve[seg + 1], curve[seg]))
        # Parallel transport of d1 from d3 to t_new.
        axis = cross(d3, t_new)
        sa, ca = norm(axis), dot(d3, t_new)
        if sa > 1e-12:
            kx = mul(axis, 1.0 / sa)
            ang = math.atan2(sa, ca)
            d1 = add(add(mul(d1, math.cos(ang)), mul(cross(kx, d1), math.sin(ang))),
                     mul(kx, dot(kx, d1) * (1 - math.cos(ang))))
        d3 = t_new
        d1 = unit(sub(d1, mul(d3, dot(d1, d3))))
        d2 = cross(d3, d1)
        rows.append((start_time + s / speed, pos, quat_from_matrix(d1, d2, d3)))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--speed", type=float, default=0.04, help="m/s along the path")
    ap.add_argument("--every", type=float, default=0.25, help="s between keyframes")
    ap.add_argument("--control", action="store_true", help="come up beside the loop")
    ap.add_argument("--settle", type=float, default=2.0, help="s held after tying")
    ap.add_argument("--pull", type=float, default=40.0, help="s of pulling at 3 mm/s (+x)")
    a = ap.parse_args()
    rows = keyframes(BESIDE if a.control else THROUGH, a.speed, a.every, 0.0)
    t, p, q = rows[-1]
    rows.append((t + a.settle, p, q))
    rows.append((t + a.settle + a.pull, add(p, (0.003 * a.pull, 0.0, 0.0)), q))
    print("# time,x,y,z,qx,qy,qz,qw: the working end's holder (scripts/tie_knot_path.py%s)"
          % (" --control" if a.control else ""))
    print("time,x,y,z,qx,qy,qz,qw")
    for t, p, q in rows:
        print("%.3f,%.5f,%.5f,%.5f,%.6f,%.6f,%.6f,%.6f" % ((t,) + tuple(p) + tuple(q)))


if __name__ == "__main__":
    main()
