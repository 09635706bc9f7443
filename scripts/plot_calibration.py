#!/usr/bin/env python3
"""Draws docs/calibration.png, the calibration example of docs/calibration.md: a synthetic
recording of config/scenes/calibration_cable.yaml (15 points, 1 mm noise, seed 1) fitted from
starts 0.6x to 1.5x off. Left: three tracked points' heights, recorded (dots), the cable at the
starting values (dashed) and fitted (lines); right: the residual per frame.

    PYTHONPATH=build/devel/lib/python3/dist-packages python3 scripts/plot_calibration.py [OUT.png]
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from corde_sim import fit as F  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, "config", "scenes", "calibration_cable.yaml")
START = {"E": 4.2e7, "G": 0.7e7, "damping_time": 0.03, "drag": 0.03}


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "docs", "calibration.png")
    times = np.arange(0.0, 1.6 + 1e-9, 0.05)
    length = F.rod_length(SCENE, {}, "cable", None)
    s = np.linspace(0.0, length, 17)[1:-1]
    rec = F.synthesize(SCENE, {}, "cable", times, s, 1e-3, 1)
    params = [F.Parameter(n, F.PARAMETERS[n][0].format(rod="cable", obstacle="0"), v)
              for n, v in START.items()]
    res = F.fit(SCENE, rec, params, "cable")
    print(F.report_text(res, params))
    fine = np.linspace(0.0, 1.6, 321)

    def points(values):
        ov = {p.key: values[p.name] for p in params}
        nodes, _ = F.simulate(F.Job(SCENE, ov, "cable", fine))
        return F.markers(nodes, F.node_arc_lengths(nodes[0]), s)

    start, fitted = points(START), points(res.values)
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [1.6, 1]})
    for i, c in zip((4, 9, 14), ("C0", "C1", "C2")):
        a.plot(rec.times, rec.points[:, i, 2], ".", color=c, ms=5)
        a.plot(fine, start[:, i, 2], "--", color=c, lw=1)
        a.plot(fine, fitted[:, i, 2], "-", color=c, lw=1.3,
               label=f"point at s = {s[i]:.2f} m")
    a.plot([], [], "k.", label="recorded (1 mm noise)")
    a.plot([], [], "k--", lw=1, label="starting values")
    a.plot([], [], "k-", label="fitted")
    a.set_xlabel("t (s)")
    a.set_ylabel("height z (m)")
    a.legend(fontsize=8, loc="lower left")
    a.set_title("tracked points: recorded, start and fit", fontsize=10)
    b.plot(res.times, res.frame_rms * 1e3, "o-", ms=3, label="fitted")
    b.axhline(np.sqrt(3), color="k", ls=":", lw=1, label="noise alone: sqrt(3) x 1 mm")
    b.set_xlabel("t (s)")
    b.set_ylabel("RMS distance of the 15 points (mm)")
    b.set_ylim(0, None)
    b.legend(fontsize=8, loc="center left")
    txt = "\n".join(f"{n}: {res.values[n]:.4g} [{res.ci[n][0]:.4g}, {res.ci[n][1]:.4g}]"
                    for n in START)
    b.text(0.02, 0.04, txt, transform=b.transAxes, fontsize=7.5, family="monospace")
    b.set_title("residual per frame", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("wrote", out)


if __name__ == "__main__":
    main()
