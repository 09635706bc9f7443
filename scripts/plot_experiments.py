#!/usr/bin/python3
"""Helical buckling (config/scenes/helical_buckling.yaml) against the localized helix.

Reads the last frame of a corde_run CSV of the scene, prints the lateral displacement of the
settled rod against the analytical envelope rho0 sech(alpha (s - s_c) / 2) and the clamp's
tension and end moment against the analytical ones (docs/experiments.md), and draws both.

  corde_run config/scenes/helical_buckling.yaml --max-energy 0 --out hb.csv \\
      --reactions hb_r.csv --every 38760
  scripts/plot_experiments.py hb.csv hb_r.csv [docs/helical_buckling.png]

Needs python3-matplotlib (and its numpy).
"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

# The scene's rod: L = 100, r = 0.35, E = 1e6, nu = 0.5; 27 turns, slack 3.
L, RADIUS, E, NU, TURNS, SLACK = 100.0, 0.35, 1.0e6, 0.5, 27.0, 3.0
B = E * math.pi * RADIUS**4 / 4.0
C = E / (2.0 * (1.0 + NU)) * math.pi * RADIUS**4 / 2.0


def localized_helix(b, c, length, slack, angle):
    """End moment M, tension T and phi (half the largest tangent angle) of the localized helix:
    slack = 2 sqrt(4 T B - M^2) / T, angle = M L / C + 4 acos(M / (2 sqrt(T B)))."""

    def loads(phi):
        st = 4.0 * math.sqrt(b) * math.sin(phi) / slack
        return 2.0 * st * math.sqrt(b) * math.cos(phi), st * st

    def residual(phi):
        m, _ = loads(phi)
        return m * length / c + 4.0 * phi - angle

    lo, hi = 1e-6, math.pi / 4.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if residual(lo) * residual(mid) <= 0.0:
            hi = mid
        else:
            lo = mid
    phi = 0.5 * (lo + hi)
    m, t = loads(phi)
    return m, t, phi


def last_frame(path):
    rows, t_last = [], None
    with open(path) as f:
        for row in csv.DictReader(f):
            t = float(row["t"])
            if t != t_last:
                rows, t_last = [], t
            rows.append(row)
    x = [[float(r["x0"]), float(r["y0"]), float(r["z0"])] for r in rows]
    x.append([float(rows[-1]["x1"]), float(rows[-1]["y1"]), float(rows[-1]["z1"])])
    return t_last, np.array(x)


def main():
    traj = sys.argv[1] if len(sys.argv) > 1 else "hb.csv"
    reactions = sys.argv[2] if len(sys.argv) > 2 else "hb_r.csv"
    png = sys.argv[3] if len(sys.argv) > 3 else "docs/helical_buckling.png"
    t, x = last_frame(traj)
    n = len(x) - 1
    axis = (x[-1] - x[0]) / np.linalg.norm(x[-1] - x[0])
    d = x - x[0]
    rho = np.linalg.norm(d - np.outer(d @ axis, axis), axis=1)
    s = np.arange(n + 1) * L / n
    w = rho**4
    centre = float(np.sum(w * s) / np.sum(w))
    m, tension, phi = localized_helix(B, C, L, SLACK, 2.0 * math.pi * TURNS)
    q = math.sqrt(4.0 * tension * B - m * m)
    rho0, alpha = q / tension, q / B
    analytic = rho0 / np.cosh(0.5 * alpha * (s - centre))
    err = rho - analytic
    near = np.abs(s - centre) < 20.0
    tangents = np.diff(x, axis=0)
    tangents /= np.linalg.norm(tangents, axis=1)[:, None]
    angle = math.degrees(math.acos(float(np.min(tangents @ axis))))
    end = [r for r in csv.DictReader(open(reactions)) if r["support"].endswith("clamp end")][-1]
    f = np.array([float(end[k]) for k in ("fx", "fy", "fz")])
    mom = np.array([float(end[k]) for k in ("mx", "my", "mz")])
    print(f"t = {t:g} s, {n} elements, helix centred at s = {centre:.2f}")
    print(f"max lateral displacement {rho.max():.4f} against rho0 = {rho0:.4f} "
          f"({100 * (rho.max() / rho0 - 1):+.2f}%)")
    print(f"profile error: max {np.abs(err).max():.4f} ({100 * np.abs(err).max() / rho0:.2f}% of "
          f"rho0), rms within 20 of the centre {math.sqrt(np.mean(err[near] ** 2)):.4f}")
    print(f"largest tangent angle {angle:.2f} deg against {math.degrees(2 * phi):.2f} deg")
    print(f"tension {f @ axis:.1f} against {tension:.1f}, end moment {mom @ axis:.1f} "
          f"against {m:.1f}")

    fig, ax = plt.subplots(figsize=(7.5, 4.0))
    ax.plot(s - centre, analytic, "k-", lw=1.5,
            label=r"localized helix $\rho_0\,\mathrm{sech}(\alpha (s - s_c)/2)$")
    ax.plot(s - centre, rho, "o", ms=3, color="tab:red", label=f"corde_sim, {n} elements")
    ax.set_xlim(-25, 25)
    ax.set_xlabel("arc length from the centre of the helix $s - s_c$")
    ax.set_ylabel(r"lateral displacement $\rho$")
    ax.set_title(f"Helical buckling: L = 100, 27 turns, slack 3 (t = {t:.0f} s)")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    print("wrote", png)


if __name__ == "__main__":
    main()
