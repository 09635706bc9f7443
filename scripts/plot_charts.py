#!/usr/bin/python3
"""The integrator charts from corde_charts' CSV files (docs/charts/): work-precision on three
scenes with the peers of docs/peers.md, the stability map, the cost per step against N, and the
implicit method's numerical damping. Also prints the issue's target figures from the same run.

Usage: scripts/plot_charts.py [DIR]   (default docs/charts; needs python3-matplotlib)
       scripts/plot_charts.py --targets [DIR]   (the target figures only, no matplotlib needed)
"""
import csv
import math
import os
import sys

COLORS = {"semi_implicit_euler": "tab:blue", "split_rotation": "tab:orange",
          "implicit_euler": "tab:green", "bdf2": "tab:red", "split_rotation_scaled": "tab:purple"}
METHODS = list(COLORS)
IMPLICIT = ("implicit_euler", "bdf2")
# split_rotation_scaled: split_rotation with rotational_inertia_scale: auto (docs/model.md).
LABELS = {"implicit_euler": "", "bdf2": "",
          "split_rotation_scaled": ", tilt inertia scaled (auto), h = 0.9"}

# docs/peers.md, the sagging cantilever (w = 5): (N, tip error / L, CPU per 2 ms frame in us).
PEERS_SAG = {
    "MuJoCo chain (clamp 2B/h)": [(10, 4.4e-3, 12), (20, 1.1e-3, 50), (40, 2.8e-4, 300),
                                  (80, 6.9e-5, 2000)],
    "XPBD, substeps to converge": [(10, 5.5e-3, 120), (20, 1.6e-3, 850), (40, 5.1e-4, 6500),
                                   (80, 1.7e-4, 47000)],
    "XPBD, default 60 substeps": [(10, 5.5e-3, 500), (40, 2.6e-3, 1500), (80, 1.8e-2, 2800)],
}
XPBD_CABLE_US = 1460  # docs/peers.md: 40 segments, 60 substeps, CPU per 2 ms frame (error unknown)
PAPER_US_PER_STEP = [(50, 69), (100, 131), (1000, 1240)]  # CoRdE paper, 2007 Xeon

SCENES = {
    "sag": ("(a) cantilever sagging under its own weight, w = 5\n"
            "(L = 1 m, r = 1 cm, E = 10 MPa; static equilibrium)",
            "tip error / L (against the elastica)"),
    "v8": ("(b) suddenly loaded cantilever (V8), 5 periods of mode 1\n"
           "(same rod, tip step load, undamped)",
           "RMS tip error / static deflection (vs modal series)"),
    "cable": ("(c) steel cable swinging under gravity, 0.5 s\n"
              "(E = 200 GPa, r = 1 mm, L = 1 m, pinned)",
              "RMS tip distance / L (vs converged run)"),
}


def read(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k, v in r.items():
            try:
                r[k] = float(v)
            except ValueError:
                pass
    return rows


def pareto(points):
    """Points (cost, error, ...) not beaten by a cheaper point with a smaller error."""
    front, best = [], math.inf
    for p in sorted(points, key=lambda p: (p[0], p[1])):
        if p[1] < best:
            front.append(p)
            best = p[1]
    return front


def cheapest(points, error):
    """Least cost of the points with an error <= `error` (inf if none)."""
    costs = [c for c, e, *_ in points if e <= error]
    return min(costs) if costs else math.inf


def plot_work_precision(plt, rows, path):
    fig, axes = plt.subplots(1, 3, figsize=(19, 7.5))
    for ax, (scene, (title, ylabel)) in zip(axes, SCENES.items()):
        for m in METHODS:
            pts = [(r["cpu_per_frame_us"], r["error"], int(r["elements"]), r["h"]) for r in rows
                   if r["scene"] == scene and r["method"] == m and math.isfinite(r["error"])]
            if not pts:
                continue
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o", color=COLORS[m], alpha=0.35,
                      ms=5)
            front = pareto(pts)
            ax.loglog([p[0] for p in front], [p[1] for p in front], "-o", color=COLORS[m], ms=6,
                      label=f"{m} (Pareto front)" + LABELS.get(m, ", h = 0.9 or 0.45 of its limit"))
            if m == "semi_implicit_euler":
                continue  # same N and errors as split_rotation: one set of labels
            for c, e, n, h in front:
                left = m != "implicit_euler"
                text = f"N={n}" if left else f"N={n}, h={h * 1e3:.2g} ms"
                ax.annotate(text, (c, e), textcoords="offset points", fontsize=6.5,
                            xytext=(-6, -10) if left else (4, 3), ha="right" if left else "left",
                            color=COLORS[m])
        if scene == "sag":
            for (name, pts), style in zip(PEERS_SAG.items(), ("k^--", "kv:", "kx:")):
                ax.loglog([p[2] for p in pts], [p[1] for p in pts], style, ms=7, alpha=0.8,
                          label=f"{name} (docs/peers.md)")
        if scene == "cable":
            ax.axvline(XPBD_CABLE_US, color="k", ls=":", lw=1.2,
                       label="XPBD, 40 segments, 60 substeps (docs/peers.md; error not measured)")
        ax.axvline(2000, color="gray", ls="--", lw=0.8)
        ax.text(2000 * 1.05, ax.get_ylim()[0] * 1.5, "real time", fontsize=7, color="gray",
                rotation=90)
        ax.set_title(title, fontsize=9.5)
        ax.set_xlabel("CPU per 2 ms of simulated time (microseconds, one core)")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="lower left" if scene == "v8" else "best", framealpha=0.9)
    fig.suptitle("Work-precision: lower left is better; faded points are off the Pareto front",
                 fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    print(f"wrote {path}")


def plot_stability(plt, rows, path):
    fig, ax = plt.subplots(figsize=(9, 6.2))
    ns = sorted({int(r["elements"]) for r in rows})
    markers = dict(zip(ns, "os^dv"))
    styles = dict(zip(ns, ["-", "--", ":", "-."]))
    for m in METHODS:
        for n in ns:
            sel = sorted((r for r in rows if r["method"] == m and int(r["elements"]) == n),
                         key=lambda r: r["youngs"])
            if not sel:
                continue
            ax.loglog([r["youngs"] for r in sel], [r["measured_h"] for r in sel],
                      styles[n], marker=markers[n], color=COLORS[m], ms=5,
                      label=f"{m}, N = {n} (measured)")
    for n in ns:
        sel = sorted((r for r in rows if r["method"] == METHODS[0] and int(r["elements"]) == n),
                     key=lambda r: r["youngs"])
        ax.loglog([r["youngs"] for r in sel], [r["predicted_h"] for r in sel], styles[n],
                  color="k", lw=1, alpha=0.6, label=f"predicted explicit limit, N = {n}")
    ax.axhline(0.02, color="gray", ls="--", lw=0.8)
    ax.text(ax.get_xlim()[0] * 2, 0.022, "search cap 20 ms", fontsize=8, color="gray")
    ax.axhline(0.002, color="gray", ls=":", lw=0.8)
    ax.text(ax.get_xlim()[1] / 2, 0.0022, "2 ms robot frame", fontsize=8, color="gray",
            ha="right")
    ax.set_xlabel("Young's modulus E (Pa)  (E_s = E, G = E/3, kappa = G A)")
    ax.set_ylabel("largest stable time step (s)")
    ax.set_title("Stability map: cantilever L = 1 m, r = 1 cm, rho = 1000, released under gravity\n"
                 "(bisected: finite, converged, energy not growing; the two explicit methods "
                 "coincide)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2, loc="lower left", framealpha=0.9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    print(f"wrote {path}")


def plot_scaling(plt, rows, path):
    fig, ax = plt.subplots(figsize=(8, 5.8))
    for m in METHODS:
        sel = sorted((r for r in rows if r["method"] == m), key=lambda r: r["elements"])
        if not sel:
            continue
        lab = m + (" (h = 1 ms)" if m in IMPLICIT else " (h = 0.9 of its limit)")
        ax.loglog([r["elements"] for r in sel], [r["us_per_step"] for r in sel], "-o",
                  color=COLORS[m], label=lab)
    imp = sorted((r for r in rows if r["method"] == "implicit_euler" and r["newton_per_step"] > 0),
                 key=lambda r: r["elements"])
    ax.loglog([r["elements"] for r in imp], [r["us_per_step"] / r["newton_per_step"] for r in imp],
              ":", marker=".", color=COLORS["implicit_euler"],
              label="implicit_euler, per Newton iteration")
    for r in imp:
        ax.annotate(f"{r['newton_per_step']:.1f} it.", (r["elements"], r["us_per_step"]),
                    textcoords="offset points", xytext=(-8, 6), fontsize=7,
                    color=COLORS["implicit_euler"])
    ax.loglog([p[0] for p in PAPER_US_PER_STEP], [p[1] for p in PAPER_US_PER_STEP], "k^--",
              alpha=0.7, label="CoRdE paper, explicit (2007 Xeon, docs/peers.md)")
    ax.set_xlabel("elements N")
    ax.set_ylabel("CPU per time step (microseconds, one core)")
    ax.set_title("Scaling: cost of one step against N\n(steel cable, r = 1 mm, 2.5 cm elements, "
                 "pinned, swinging under gravity)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    print(f"wrote {path}")


def plot_contact_solve(plt, rows, path):
    fig, ax = plt.subplots(figsize=(8, 5.8))
    styles = {"rounds": ("tab:red", "rounds (lumped-mass sweeps + true response)"),
              "delassus": ("tab:blue", "Delassus APGD (exact contact blocks)")}
    scenes = {"steel_rod": ("o", "-", "steel rod dropped on a floor"),
              "rope_coil": ("s", "--", "rope spiral on a floor, self contact")}
    for scene, (marker, line, title) in scenes.items():
        for solver, (color, label) in styles.items():
            sel = sorted((r for r in rows if r["scene"] == scene and r["solver"] == solver),
                         key=lambda r: r["contacts"])
            if not sel:
                continue
            ax.loglog([r["contacts"] for r in sel], [r["cpu_per_second"] for r in sel],
                      line + marker, color=color, label=f"{label}: {title}")
            for r in sel:
                ax.annotate(f"{r['iterations_per_step']:.1f}", (r["contacts"], r["cpu_per_second"]),
                            textcoords="offset points", xytext=(4, -10), fontsize=7, color=color)
    ax.axhline(1.0, color="k", lw=0.8, alpha=0.5)
    ax.set_xlabel("contacts carrying an impulse (mean per step)")
    ax.set_ylabel("CPU per simulated second (s, one core; 1 = real time)")
    ax.set_title("Implicit contact solves: implicit_euler at 2 ms\n"
                 "(numbers: rounds or iterations per step)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    print(f"wrote {path}")


def bdf2_factor(hw):
    """|principal root| of BDF2 on y' = i w y: (3/2 - i h w) r^2 - 2 r + 1/2 = 0."""
    a, b, c = complex(1.5, -hw), -2.0, 0.5
    d = (b * b - 4 * a * c) ** 0.5
    return max(abs((-b + d) / (2 * a)), abs((-b - d) / (2 * a)))


def plot_damping(plt, rows, path):
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 5.5))
    imp = [r for r in rows if r["method"] == "implicit_euler"]
    xs = sorted({r["h_omega"] for r in imp})
    lo, hi = min(xs) / 1.5, max(xs) * 1.5
    grid = [lo * (hi / lo) ** (k / 200) for k in range(201)]
    ax.semilogx(grid, [(1 + x * x) ** -0.5 for x in grid], "k-", lw=1,
                label="backward Euler theory: 1 / sqrt(1 + (h w)^2)")
    bx.loglog(grid, [math.log(1 + x * x) / (2 * x) for x in grid], "k-", lw=1,
              label="theory: ln(1 + (h w)^2) / (2 h w)")
    for mode, mk in zip(sorted({int(r["mode"]) for r in imp}), "os^"):
        sel = sorted((r for r in imp if int(r["mode"]) == mode), key=lambda r: r["h_omega"])
        w = sel[0]["omega"]
        ax.semilogx([r["h_omega"] for r in sel], [r["factor_per_step"] for r in sel], mk,
                    color="tab:green", ms=7, mfc="none" if mode > 1 else "tab:green",
                    label=f"implicit_euler, bending mode {mode} (w = {w:.3g} rad/s), measured")
        bx.loglog([r["h_omega"] for r in sel], [r["damping_ratio"] for r in sel], mk,
                  color="tab:green", ms=7, mfc="none" if mode > 1 else "tab:green",
                  label=f"mode {mode}, measured")
    bdf = sorted((r for r in rows if r["method"] == "bdf2"), key=lambda r: r["h_omega"])
    if bdf:
        ax.semilogx(grid, [bdf2_factor(x) for x in grid], "k--", lw=1,
                    label="BDF2 theory: |principal root| (1 - (h w)^4 / 4 for small h w)")
        bx.loglog(grid, [-math.log(bdf2_factor(x)) / x for x in grid], "k--", lw=1,
                  label="BDF2 theory: -ln|root| / (h w) (about (h w)^3 / 4)")
        for mode, mk in zip(sorted({int(r["mode"]) for r in bdf}), "os^"):
            sel = [r for r in bdf if int(r["mode"]) == mode]
            ax.semilogx([r["h_omega"] for r in sel], [r["factor_per_step"] for r in sel], mk,
                        color=COLORS["bdf2"], ms=7, mfc="none" if mode > 1 else COLORS["bdf2"],
                        label=f"bdf2, bending mode {mode}, measured")
            bx.loglog([r["h_omega"] for r in sel], [max(r["damping_ratio"], 1e-12) for r in sel],
                      mk, color=COLORS["bdf2"], ms=7, mfc="none" if mode > 1 else COLORS["bdf2"],
                      label=f"bdf2, mode {mode}, measured")
    for r in rows:
        if r["method"] not in IMPLICIT:
            ax.semilogx([r["h_omega"]], [r["factor_per_step"]], "*", color=COLORS[r["method"]],
                        ms=10, label=f"{r['method']} at 0.9 of its limit, mode {int(r['mode'])}")
    ax.set_xlabel("h * omega (time step times the mode's angular frequency)")
    ax.set_ylabel("amplitude factor per time step")
    ax.set_ylim(-0.03, 1.05)
    ax.set_title("Numerical damping of a bending mode (cantilever, N = 40): amplitude kept per step",
                 fontsize=10)
    bx.set_xlabel("h * omega")
    bx.set_ylabel("equivalent damping ratio zeta")
    bx.set_title("Numerical damping as a damping ratio (about h w / 2 for small h w)",
                 fontsize=10)
    for a in (ax, bx):
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=7.5)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    print(f"wrote {path}")


def targets(d):
    wp = read(os.path.join(d, "work_precision.csv"))
    out = []

    def pts(scene, method):
        return [(r["cpu_per_frame_us"], r["error"], int(r["elements"]), r["h"]) for r in wp
                if r["scene"] == scene and r["method"] == method and math.isfinite(r["error"])]

    for r in wp:
        if (r["scene"] == "cable" and r["method"] in IMPLICIT
                and int(r["elements"]) == 40 and abs(r["h"] - 2e-3) < 1e-9):
            out.append(f"steel cable N=40, {r['method']}, h = 2 ms: {r['cpu_per_frame_us']:.1f} us "
                       f"per 2 ms frame (target <= 100), error {r['error']:.3e} L, "
                       f"{r['newton_per_step']:.2f} Newton iterations per step")
    # Explicit against the best implicit method (the cheaper of implicit_euler and bdf2) at each
    # explicit Pareto point's error, with each implicit method's own cost.
    for scene in ("cable", "v8", "sag"):
        exp = pts(scene, "semi_implicit_euler") + pts(scene, "split_rotation")
        for c, e, n, h in pareto(exp):
            costs = {m: cheapest(pts(scene, m), e) for m in IMPLICIT}
            best = min(costs, key=costs.get)
            ci = costs[best]
            ratio = (f"explicit/implicit = {c / ci:.3g} ({best})" if ci < math.inf
                     else "implicit: none")
            each = ", ".join(f"{m} {v:.1f} us" for m, v in costs.items())
            out.append(f"{scene}: explicit N={n} h={h:.3g}: error {e:.3e} at {c:.1f} us; implicit "
                       f"at <= that error: {each} -> {ratio}")
    for scene in ("cable", "sag"):
        exp = pts(scene, "semi_implicit_euler") + pts(scene, "split_rotation")
        imp = pts(scene, "implicit_euler") + pts(scene, "bdf2")
        for c, e, n, h in pareto(pts(scene, "split_rotation_scaled")):
            out.append(f"{scene}: scaled split_rotation N={n} h={h:.3g}: error {e:.3e} at {c:.2f} "
                       f"us; at <= that error: physical explicit {cheapest(exp, e):.1f} us, "
                       f"implicit {cheapest(imp, e):.1f} us")
    # The stiff-scene target (implicit >= 10x cheaper at equal accuracy) at fixed errors.
    exp = pts("cable", "semi_implicit_euler") + pts("cable", "split_rotation")
    for a in (3.7e-3, 9.2e-4, 2.3e-4, 1e-4, 5e-5):
        ce = cheapest(exp, a)
        costs = {m: cheapest(pts("cable", m), a) for m in IMPLICIT}
        best = min(costs, key=costs.get)
        if ce < math.inf and costs[best] < math.inf:
            each = ", ".join(f"{m} {v:.1f} us ({ce / v:.3g}x)" if v < math.inf else f"{m} none"
                             for m, v in costs.items())
            out.append(f"stiff cable at error <= {a:g} L: explicit {ce:.1f} us; {each}; best "
                       f"{best}: {ce / costs[best]:.3g}x (target >= 10)")
    ours = [p for m in METHODS for p in pts("sag", m)]
    peers = [(c, e) for v in PEERS_SAG.values() for (_, e, c) in v]
    # The target read strictly: at each accuracy (the peers' own errors included), the cheapest
    # point of each side with an error <= it.
    tagged = [(c, e, n, m) for m in METHODS for c, e, n, _ in pts("sag", m)]
    for a in (1e-2, 4.4e-3, 3e-3, 1.1e-3, 1e-3, 3e-4, 2.8e-4, 1e-4, 6.9e-5):
        cp = cheapest(peers, a)
        best = min((p for p in tagged if p[1] <= a), default=None)
        if best:
            out.append(f"sag at error <= {a:g} L: best peer {cp:.1f} us, best corde_sim "
                       f"{best[0]:.2f} us ({best[3]} N={best[2]}), ratio {cp / best[0]:.3g}")
    try:
        sm = read(os.path.join(d, "stability_map.csv"))
        for lo, hi in ((1e5, math.inf), (0, 1e5)):
            ratios = [r["ratio"] for r in sm
                      if r["method"] != "implicit_euler" and lo <= r["youngs"] < hi]
            if ratios:
                out.append(f"explicit measured/predicted stable step, E in [{lo:g}, {hi:g}): "
                           f"{min(ratios):.3f} .. {max(ratios):.3f} (target 0.7 .. 1.05)")
        capped = [r for r in sm if r["method"] == "implicit_euler"]
        out.append(f"implicit: stable at the 20 ms cap in {sum(int(r['capped']) for r in capped)}"
                   f" of {len(capped)} (E, N) cases")
    except FileNotFoundError:
        pass
    return out


def main():
    args = [a for a in sys.argv[1:] if a != "--targets"]
    d = args[0] if args else "docs/charts"
    if "--targets" in sys.argv:
        print("\n".join(targets(d)))
        return
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    plot_work_precision(plt, read(os.path.join(d, "work_precision.csv")),
                        os.path.join(d, "work_precision.png"))
    plot_stability(plt, read(os.path.join(d, "stability_map.csv")),
                   os.path.join(d, "stability_map.png"))
    plot_scaling(plt, read(os.path.join(d, "scaling.csv")), os.path.join(d, "scaling.png"))
    plot_damping(plt, read(os.path.join(d, "damping.csv")), os.path.join(d, "damping.png"))
    if os.path.exists(os.path.join(d, "contact_solve.csv")):
        plot_contact_solve(plt, read(os.path.join(d, "contact_solve.csv")),
                           os.path.join(d, "contact_solve.png"))
    print("\n".join(targets(d)))


if __name__ == "__main__":
    main()
