#!/usr/bin/python3
"""Accuracy against cost chart (V8 of docs/validation_references.md) from corde_accuracy's CSV.

Left: RMS tip error over five periods of mode 1 (relative to the static deflection) against CPU
per simulated second, one line per clamp at h = 0.9 of the critical step, against both the
Euler-Bernoulli series (docs/validation_references.md) and the Timoshenko series (the model's
continuum limit); smaller steps as faded markers. Right: CPU per 2 ms frame against N, with the
peers of docs/peers.md measured on the same rod (L = 1 m, r = 1 cm, rho = 1000, E = 1e7,
G = E/3) for comparison.

Usage: scripts/plot_accuracy.py [CSV] [PNG]
  (defaults docs/accuracy_vs_cost.csv and docs/accuracy_vs_cost.png; needs python3-matplotlib)
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402

# docs/peers.md, "Accuracy against cost: MuJoCo chain and XPBD": N -> CPU per 2 ms frame
# (microseconds). Their errors come from a static sag test, not comparable with V8 (see
# docs/validation_dynamic.md).
PEERS = {
    "MuJoCo chain (clamp 2B/h)": ([10, 20, 40, 80], [12, 50, 300, 2000]),
    "XPBD, substeps to converge": ([10, 20, 40, 80], [120, 850, 6500, 47000]),
    "XPBD, default 60 substeps": ([10, 20, 40, 80], [500, 850, 1500, 2800]),
}
# RMS difference between the Euler-Bernoulli and Timoshenko series over five periods: the floor
# of the Euler-Bernoulli error that no N or h removes (docs/validation_dynamic.md).
EB_FLOOR = 5.05e-3


def load(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k in r:
            if k not in ("method", "clamp"):
                r[k] = float(r[k])
    return rows


def main():
    csv_path = sys.argv[1] if len(sys.argv) > 1 else "docs/accuracy_vs_cost.csv"
    png_path = sys.argv[2] if len(sys.argv) > 2 else "docs/accuracy_vs_cost.png"
    rows = load(csv_path)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 5.2))
    colors = {"natural": "tab:red", "ghost": "tab:blue"}
    best = max(r["step_fraction"] for r in rows)
    for clamp in ("natural", "ghost"):
        mine = [r for r in rows if r["clamp"] == clamp]
        if not mine:
            continue
        top = sorted((r for r in mine if r["step_fraction"] == best), key=lambda r: r["elements"])
        x = [r["cpu_per_sim_s"] for r in top]
        ax.loglog(x, [r["error_rms"] for r in top], "o-", color=colors[clamp],
                  label=f"{clamp} clamp, h = {best:g} crit, vs Euler-Bernoulli")
        ax.loglog(x, [r["error_rms_timoshenko"] for r in top], "s--", color=colors[clamp],
                  mfc="none", label=f"{clamp} clamp, h = {best:g} crit, vs Timoshenko")
        for r in top:
            ax.annotate(f"N={r['elements']:.0f}", (r["cpu_per_sim_s"], r["error_rms"]),
                        textcoords="offset points", xytext=(4, 4), fontsize=8)
        small = [r for r in mine if r["step_fraction"] != best]
        if small:
            ax.loglog([r["cpu_per_sim_s"] for r in small], [r["error_rms"] for r in small], ".",
                      color=colors[clamp], alpha=0.45,
                      label=f"{clamp} clamp, smaller h (same error, more CPU)")
        bx.loglog([r["elements"] for r in top], [r["cpu_per_frame_us"] for r in top], "o-",
                  color=colors[clamp], label=f"corde_sim, {clamp} clamp, h = {best:g} crit")
    ax.axhline(EB_FLOOR, color="gray", ls=":", lw=1)
    ax.text(ax.get_xlim()[0] * 1.1, EB_FLOOR * 1.1, "Timoshenko vs Euler-Bernoulli (floor)",
            fontsize=8, color="gray")
    ax.set_xlabel("CPU seconds per simulated second (one core)")
    ax.set_ylabel("RMS tip error / static deflection, 5 periods of mode 1")
    ax.set_title("V8: suddenly loaded cantilever (alpha = 0.01, undamped)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="lower left", framealpha=0.9)
    for (name, (n, cpu)), style in zip(PEERS.items(), ("^-", "v-", "x:")):
        bx.loglog(n, cpu, style, color="k", alpha=0.7, label=f"{name} (docs/peers.md)")
    bx.set_xticks([10, 20, 40, 80])
    bx.get_xaxis().set_major_formatter(matplotlib.ticker.ScalarFormatter())
    bx.get_xaxis().set_minor_formatter(matplotlib.ticker.NullFormatter())
    bx.set_xlabel("elements N")
    bx.set_ylabel("CPU per 2 ms of simulated time (microseconds)")
    bx.set_title("Cost per frame on the same rod")
    bx.grid(True, which="both", alpha=0.3)
    bx.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    print(f"wrote {png_path}")


if __name__ == "__main__":
    main()
