#!/usr/bin/python3
"""ctest corde_charts_short: runs `corde_charts --short` into a temporary folder, checks that each
CSV has its columns, the expected rows and sane values, then draws the charts with
scripts/plot_charts.py (python3-matplotlib is required: the test fails with the install hint
when it is missing).

Usage: charts_short_check.py CORDE_CHARTS SOURCE_DIR
"""
import csv
import math
import os
import subprocess
import sys
import tempfile

METHODS = {"semi_implicit_euler", "split_rotation", "implicit_euler", "bdf2",
           "split_rotation_scaled"}
COLUMNS = {
    "work_precision.csv": ["scene", "method", "elements", "h", "cpu_per_frame_us", "error",
                           "newton_per_step", "failures"],
    "stability_map.csv": ["method", "youngs", "elements", "predicted_h", "measured_h", "capped",
                          "ratio"],
    "scaling.csv": ["method", "elements", "h", "us_per_step", "newton_per_step"],
    "damping.csv": ["method", "mode", "elements", "h_omega", "omega", "h", "steps",
                    "factor_per_step", "theory_per_step", "decay_per_period",
                    "theory_decay_per_period", "damping_ratio", "theory_damping_ratio"],
}
# --short: 3 scenes x 5 methods (bdf2 and split_rotation_scaled in the work-precision runs only),
# 3 methods x 2 moduli, 3 methods x 2 N, 2 backward Euler + 2 BDF2 + 1 explicit.
ROWS = {"work_precision.csv": 15, "stability_map.csv": 6, "scaling.csv": 6, "damping.csv": 5}

failures = []


def check(cond, msg):
    if not cond:
        failures.append(msg)


def read(path):
    with open(path) as f:
        reader = csv.DictReader(f)
        return reader.fieldnames, list(reader)


def main():
    tool, src = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory() as d:
        run = subprocess.run([tool, "--short", "--out", d], capture_output=True, text=True,
                             timeout=120)
        check(run.returncode == 0, f"corde_charts --short exited {run.returncode}:\n{run.stderr}")
        data = {}
        for name, cols in COLUMNS.items():
            path = os.path.join(d, name)
            if not os.path.exists(path):
                failures.append(f"{name} not written")
                continue
            header, rows = read(path)
            check(header == cols, f"{name}: columns {header}, expected {cols}")
            check(len(rows) == ROWS[name], f"{name}: {len(rows)} rows, expected {ROWS[name]}")
            check({r["method"] for r in rows} <= METHODS, f"{name}: unknown method")
            data[name] = rows
        for r in data.get("work_precision.csv", []):
            err, cpu = float(r["error"]), float(r["cpu_per_frame_us"])
            check(math.isfinite(err) and 0 < err < 0.05,
                  f"work_precision {r['scene']} {r['method']}: error {err} not in (0, 0.05)")
            check(0 < cpu < 1e6, f"work_precision {r['scene']} {r['method']}: CPU {cpu}")
            check(int(r["failures"]) == 0, f"work_precision {r['scene']}: Newton failures")
        for r in data.get("stability_map.csv", []):
            ratio = float(r["ratio"])
            if r["method"] != "implicit_euler":
                # The bisection's answer against stability.h's prediction (the target).
                check(0.7 <= ratio <= 1.05, f"stability_map {r['method']} E={r['youngs']}: "
                      f"measured/predicted {ratio}")
            else:
                check(float(r["measured_h"]) > 10 * float(r["predicted_h"]),
                      f"stability_map implicit E={r['youngs']}: not above 10x the explicit limit")
        for r in data.get("scaling.csv", []):
            check(0 < float(r["us_per_step"]) < 1e5, f"scaling {r['method']}: {r['us_per_step']}")
        for r in data.get("damping.csv", []):
            got, want = float(r["factor_per_step"]), float(r["theory_per_step"])
            # Backward Euler's amplitude factor per step on one mode, 1/sqrt(1 + (h w)^2), BDF2's
            # the modulus of its principal root; the explicit point keeps the amplitude (theory
            # 1). N = 10 shifts w by about 1%.
            check(abs(got - want) < 0.01, f"damping {r['method']} h*w={r['h_omega']}: per step "
                  f"{got}, theory {want}")
        if failures:
            print("\n".join(["FAILED:"] + failures))
            return 1
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            print("FAILED: python3-matplotlib is missing (apt-get install python3-matplotlib, or "
                  "scripts/install_deps.sh); the charts cannot be drawn")
            return 1
        plot = subprocess.run([sys.executable, os.path.join(src, "scripts", "plot_charts.py"), d],
                              capture_output=True, text=True, timeout=120)
        print(plot.stdout)
        if plot.returncode != 0:
            print(f"FAILED: plot_charts.py exited {plot.returncode}:\n{plot.stderr}")
            return 1
        for png in ("work_precision.png", "stability_map.png", "scaling.png", "damping.png"):
            path = os.path.join(d, png)
            if not os.path.exists(path) or os.path.getsize(path) < 10000:
                print(f"FAILED: {png} missing or nearly empty")
                return 1
    print("corde_charts --short: CSV and charts OK")
    return 0


if __name__ == "__main__":
    sys.exit(main())
