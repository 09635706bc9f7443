#!/usr/bin/env python3
"""corde_fit's analytic Jacobian in statics mode (python/corde_sim/fit_jacobian.py): its columns
against finite differences of the residual, mixed with finite-difference columns, and a statics
fit with it against the same fit by finite differences (same values, fewer runs).

    PYTHONPATH=build/devel/lib/python3/dist-packages python3 test/python/fit_jacobian_test.py
"""

import os
import sys
import time
import unittest

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
try:
    from corde_sim import fit as F
    from corde_sim import fit_jacobian as FJ
except ImportError:
    sys.path.insert(0, os.path.join(ROOT, "python"))
    from corde_sim import fit as F
    from corde_sim import fit_jacobian as FJ

SCENE = os.path.join(ROOT, "config", "scenes", "calibration_cable.yaml")
TRUTH = {"E": 3.0e7, "G": 1.0e7}
START = {"E": 4.2e7, "G": 0.7e7, "rho": 1100.0}
TIMES = np.arange(0.0, 1.1 + 1e-9, 0.05)  # the gripper's poses: the cable at rest in each
NOISE = 1e-3


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def arc_lengths(points=15):
    length = F.rod_length(SCENE, {}, "cable", None)
    return np.linspace(0.0, length, points + 2)[1:-1]


def params(names):
    return [F.Parameter(n, F.PARAMETERS[n][0].format(rod="cable", obstacle="0"), START[n])
            for n in names]


class Keys(unittest.TestCase):
    def test_which_keys_are_analytic(self):
        self.assertEqual(FJ.analytic_key("rods.cable.material.E", "cable"), "E")
        self.assertEqual(FJ.analytic_key("rods[0].material.rho", "0"), "rho")
        self.assertIsNone(FJ.analytic_key("rods.cable.material.damping_time", "cable"))
        self.assertIsNone(FJ.analytic_key("rods.other.material.E", "cable"))
        self.assertIsNone(FJ.analytic_key("rods.cable.drag.linear_normal", "cable"))
        ps = params(["E", "G"]) + [F.Parameter("r", "rods.cable.radius", 0.004)]
        self.assertEqual(FJ.analytic_columns(ps, "cable", True, "auto"), {0: "E", 1: "G"})
        self.assertEqual(FJ.analytic_columns(ps, "cable", False, "auto"), {})
        self.assertEqual(FJ.analytic_columns(ps, "cable", True, "fd"), {})
        with self.assertRaises(F.FitError):
            FJ.analytic_columns(ps, "cable", True, "exact")


class Columns(unittest.TestCase):
    def test_columns_match_central_differences(self):
        # E, G and rho analytic, the radius (no sensitivity) by forward differences in the same
        # Jacobian; every column against central differences of the residual (step 1e-4 in log p).
        rec = F.synthesize(SCENE, {}, "cable", TIMES[::4], arc_lengths(), NOISE, 7, statics=True)
        ps = params(["E", "G", "rho"]) + [F.Parameter("radius", "rods.cable.radius", 0.0045)]
        prob = F.Problem(SCENE, rec, ps, "cable", {}, statics=True)
        self.assertEqual(sorted(prob.columns), [0, 1, 2])
        theta = np.log([p.initial for p in ps])
        J = prob.jacobian(theta)
        self.assertEqual(prob.runs, 2)  # the point and the radius column
        h = 1e-4
        for j, p in enumerate(ps):
            tp, tm = theta.copy(), theta.copy()
            tp[j] += h
            tm[j] -= h
            fd = (prob.residuals(tp) - prob.residuals(tm)) / (2 * h)
            err = np.abs(J[:, j] - fd).max() / np.abs(fd).max()
            log(f"column {p.name}: {'analytic' if j in prob.columns else 'forward'}, "
                f"{err:.2e} relative to central differences (|column| {np.abs(fd).max():.3g})")
            self.assertLess(err, 1e-6 if j in prob.columns else 2e-2, p.name)


class StaticsFit(unittest.TestCase):
    def test_analytic_fit_equals_finite_differences_with_fewer_runs(self):
        rec = F.synthesize(SCENE, {}, "cable", TIMES, arc_lengths(), NOISE, 5, statics=True)
        res = {}
        for mode in ("fd", "auto"):
            c0 = time.process_time()
            r = F.fit(SCENE, rec, params(["E", "G"]), "cable", statics=True, jacobian=mode)
            cpu = time.process_time() - c0
            res[mode] = r
            log(f"statics fit, jacobian {mode}: " + ", ".join(
                f"{n} {r.values[n] / TRUTH[n] - 1:+.3%} [{r.ci[n][0] / TRUTH[n] - 1:+.2%}, "
                f"{r.ci[n][1] / TRUTH[n] - 1:+.2%}]" for n in ("E", "G"))
                + f"; rms {r.rms * 1e3:.3f} mm, {r.runs} runs, {r.iterations} evaluations, "
                f"{cpu:.2f} s CPU, {r.wall_time:.2f} s wall")
        fd, an = res["fd"], res["auto"]
        for n in ("E", "G"):
            self.assertTrue(fd.ci[n][0] <= an.values[n] <= fd.ci[n][1], n)
            self.assertTrue(an.ci[n][0] <= fd.values[n] <= an.ci[n][1], n)
            self.assertLess(abs(an.values[n] / fd.values[n] - 1), 2e-3, n)
            self.assertTrue(an.ci[n][0] <= TRUTH[n] <= an.ci[n][1], n)
            # the same intervals: the Jacobians agree
            self.assertLess(abs(np.log(an.ci[n][1] / an.ci[n][0])
                                / np.log(fd.ci[n][1] / fd.ci[n][0]) - 1), 0.02, n)
        self.assertLess(an.runs, fd.runs)


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]] + [a for a in sys.argv[1:] if a != "--long"])
