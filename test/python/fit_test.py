#!/usr/bin/env python3
"""corde_fit (python/corde_sim/fit.py): material parameters recovered from synthetic recordings.

Recordings are made with known parameters from config/scenes/calibration_cable.yaml (a cable
clamped at one end, the other end moved and turned by a gripper through three poses), 15 tracked
points with 1 mm Gaussian noise. Short mode (ctest): 2 seeded repetitions; `--long` (or
CORDE_FIT_LONG=1): 10, with the confidence intervals' coverage counted (docs/calibration.md).

    PYTHONPATH=build/devel/lib/python3/dist-packages python3 test/python/fit_test.py [--long]
"""

import os
import sys
import time
import unittest

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
try:
    from corde_sim import fit as F
except ImportError:  # the source tree's package (corde_run as the simulator)
    sys.path.insert(0, os.path.join(ROOT, "python"))
    from corde_sim import fit as F

SCENE = os.path.join(ROOT, "config", "scenes", "calibration_cable.yaml")
TRUTH = {"E": 3.0e7, "G": 1.0e7, "damping_time": 0.05, "drag": 0.02}
START = {"E": 4.2e7, "G": 0.7e7, "damping_time": 0.03, "drag": 0.03}  # 0.6x to 1.5x off
TIMES = np.arange(0.0, 1.6 + 1e-9, 0.05)
LONG = "--long" in sys.argv or os.environ.get("CORDE_FIT_LONG") == "1"
NOISE = 1e-3
# the gripper's path in calibration_cable.yaml
TURNING = ("[{time: 0.3, displacement: [-0.15, 0, 0.05]}, {time: 0.7, displacement: [-0.2, 0.1, "
           "-0.05], turns: 1.0}, {time: 1.1, displacement: [-0.1, -0.05, 0.0], turns: 0.4}]")
# in-plane gripper motion without turns: nothing twists
PLANAR = ("[{time: 0.3, displacement: [-0.15, 0, 0.05]}, {time: 0.7, displacement: [-0.2, 0, "
          "-0.05]}, {time: 1.1, displacement: [-0.1, 0, 0.0]}]")


def arc_lengths(scene=SCENE, overrides=None, points=15):
    length = F.rod_length(scene, overrides or {}, "cable", None)
    return np.linspace(0.0, length, points + 2)[1:-1]


def params(names):
    return [F.Parameter(n, F.PARAMETERS[n][0].format(rod="cable", obstacle="0"), START[n])
            for n in names]


def log(msg):
    print(msg, file=sys.stderr, flush=True)


class Recovery(unittest.TestCase):
    def test_recovery_and_coverage(self):
        seeds = range(1, 11) if LONG else range(1, 3)
        names = ["E", "G", "damping_time", "drag"]
        s = arc_lengths()
        covered = {n: 0 for n in names}
        for seed in seeds:
            rec = F.synthesize(SCENE, {}, "cable", TIMES, s, NOISE, seed)
            t0 = time.perf_counter()
            res = F.fit(SCENE, rec, params(names), "cable")
            wall = time.perf_counter() - t0
            log(f"seed {seed}: " + ", ".join(
                f"{n} {res.values[n] / TRUTH[n] - 1:+.2%} [{res.ci[n][0] / TRUTH[n] - 1:+.2%}, "
                f"{res.ci[n][1] / TRUTH[n] - 1:+.2%}]" for n in names)
                + f"; rms {res.rms * 1e3:.3f} mm, {res.runs} runs, {wall:.1f} s")
            self.assertEqual(res.undetermined, {})
            for n in ("E", "G"):
                self.assertLess(abs(res.values[n] / TRUTH[n] - 1), 0.02, (seed, n))
            self.assertLess(abs(res.values["damping_time"] / TRUTH["damping_time"] - 1), 0.10)
            self.assertLess(abs(res.rms / NOISE - 1), 0.1)
            for n in names:
                lo, hi = res.ci[n]
                covered[n] += lo <= TRUTH[n] <= hi
        log(f"coverage of the 95% intervals over {len(seeds)} seeds: {covered}")
        for n in names:  # >= 9 of 10 (long); short: >= 1 of 2
            self.assertGreaterEqual(covered[n], len(seeds) - 1, n)


class Undetermined(unittest.TestCase):
    def test_twist_stiffness_undetermined_when_nothing_twists(self):
        ov = {"grasps.gripper.keyframes": PLANAR}
        rec = F.synthesize(SCENE, ov, "cable", TIMES, arc_lengths(), NOISE, 7)
        res = F.fit(SCENE, rec, params(["E", "G", "damping_time"]), "cable", ov)
        log(f"planar: {res.undetermined}; E {res.values['E']:.4g} {res.ci['E']}, tau "
            f"{res.values['damping_time']:.4g} {res.ci['damping_time']}")
        self.assertIn("G", res.undetermined)
        self.assertRegex(res.undetermined["G"], "does not depend on it|more than a factor 1e6")
        self.assertNotIn("G", res.ci)
        self.assertEqual(res.values["G"], START["G"])  # kept at its start, not a number made up
        self.assertLess(abs(res.values["E"] / TRUTH["E"] - 1), 0.02)
        self.assertLess(abs(res.values["damping_time"] / TRUTH["damping_time"] - 1), 0.10)
        text = F.report_text(res, params(["E", "G", "damping_time"]))
        self.assertRegex(text, r"G\s+undetermined")

    def test_density_with_all_stiffnesses_and_drag_is_refused(self):
        # Without a measured force the motion sees only ratios to the mass: (E, G, drag, rho)
        # scaled together give the same recording, so one of them cannot be determined.
        rec = F.synthesize(SCENE, {}, "cable", TIMES[::2], arc_lengths(), NOISE, 3)
        p = [F.Parameter(n, F.PARAMETERS[n][0].format(rod="cable", obstacle="0"), TRUTH[n])
             for n in ("E", "G", "drag")] + [F.Parameter("rho", "rods.cable.material.rho", 2500.0)]
        res = F.fit(SCENE, rec, p, "cable", max_iterations=6)
        log(f"E, G, drag with rho: undetermined {res.undetermined}")
        self.assertEqual(len(res.undetermined), 1)
        (name, why), = res.undetermined.items()
        self.assertRegex(why, "trades off against (E|G|drag|rho)|more than a factor 1e6")


class Forces(unittest.TestCase):
    """The gripper's measured wrench (force and torque on the gripper, 1 % of the cable's weight
    as force noise, that times 5 cm as torque noise) with the points: the force fixes the scale
    that positions alone cannot see, so density is fitted with the stiffnesses, friction and
    drag. Short mode 2 seeds, --long 10 (docs/calibration.md, "Forces")."""

    def test_density_recovered_with_forces(self):
        weight = 2000 * np.pi * 0.003 ** 2 * 0.5 * 9.81
        fn, tn = 0.01 * weight, 0.01 * weight * 0.05
        truth = {**TRUTH, "rho": 2000.0}
        names = ["E", "G", "damping_time", "drag", "rho"]
        start = {**START, "rho": 2600.0}
        seeds = range(1, 11) if LONG else range(1, 3)
        s = arc_lengths()
        covered = {n: 0 for n in names}
        for seed in seeds:
            rec = F.synthesize_wrenches(SCENE, {}, "cable", TIMES, s, NOISE, seed, "gripper",
                                        fn, tn)
            spec = F.wrench_spec(rec, "gripper", 11, fn, tn)
            p = [F.Parameter(n, F.PARAMETERS[n][0].format(rod="cable", obstacle="0"), start[n])
                 for n in names]
            res = F.fit(SCENE, rec, p, "cable", wrench=spec)
            log(f"forces seed {seed}: " + ", ".join(
                f"{n} {res.values[n] / truth[n] - 1:+.2%} [{res.ci[n][0] / truth[n] - 1:+.2%}, "
                f"{res.ci[n][1] / truth[n] - 1:+.2%}]" for n in names)
                + f"; rms {res.rms * 1e3:.3f} mm, force {res.force_rms * 1e3:.3f} mN, torque "
                f"{res.torque_rms * 1e3:.4f} mN m, {res.runs} runs, {res.wall_time:.1f} s")
            self.assertEqual(res.undetermined, {})
            self.assertLess(abs(res.values["rho"] / truth["rho"] - 1), 0.02, seed)
            for n in ("E", "G"):
                self.assertLess(abs(res.values[n] / truth[n] - 1), 0.02, (seed, n))
            self.assertLess(abs(res.rms / NOISE - 1), 0.1)
            # the residuals per frame of both kinds, at their noise
            self.assertEqual(res.frame_force.shape, (len(TIMES),))
            self.assertEqual(res.frame_torque.shape, (len(TIMES),))
            self.assertLess(abs(res.force_rms / fn - 1), 0.25)
            self.assertLess(abs(res.torque_rms / tn - 1), 0.25)
            self.assertRegex(F.report_text(res, p), r"force residual\s+RMS .* N per component")
            for n in names:
                lo, hi = res.ci[n]
                covered[n] += lo <= truth[n] <= hi
        log(f"forces: coverage of the 95% intervals over {len(seeds)} seeds: {covered}")
        for n in names:
            self.assertGreaterEqual(covered[n], len(seeds) - 1, n)

    def test_density_alone_refused_without_forces_determined_with_them(self):
        # The same recording, with and without its wrench columns: E, drag and rho together.
        weight = 2000 * np.pi * 0.003 ** 2 * 0.5 * 9.81
        rec = F.synthesize_wrenches(SCENE, {}, "cable", TIMES[::2], arc_lengths(), NOISE, 3,
                                    "gripper", 0.01 * weight)
        p = [F.Parameter(n, F.PARAMETERS[n][0].format(rod="cable", obstacle="0"), TRUTH[n])
             for n in ("E", "G", "drag")] + [F.Parameter("rho", "rods.cable.material.rho", 2500.0)]
        spec = F.wrench_spec(rec, "gripper", 11, 0.01 * weight, 1.0)
        self.assertEqual(spec.columns, 3)  # forces only
        with_forces = F.fit(SCENE, rec, p, "cable", wrench=spec)
        log(f"E, G, drag, rho with forces: rho {with_forces.values['rho']:.2f} "
            f"{with_forces.ci.get('rho')}, undetermined {with_forces.undetermined}")
        self.assertEqual(with_forces.undetermined, {})
        self.assertLess(abs(with_forces.values["rho"] / 2000 - 1), 0.02)
        rec.wrenches = None
        without = F.fit(SCENE, rec, p, "cable", max_iterations=6)
        self.assertEqual(len(without.undetermined), 1)
        (name, why), = without.undetermined.items()
        self.assertRegex(why, "trades off against|more than a factor 1e6")


class Mismatch(unittest.TestCase):
    def test_finer_rod_other_integrator_fitted_at_the_noise(self):
        # Recorded with 4x the elements and implicit Euler at a quarter of the step, fitted with
        # 24 elements and BDF2. The moved end is a ghost clamp, which acts at the end node at any
        # resolution (a grasp holds the end segment, whose midpoint moves with the element
        # length), and the internal friction is weak: both keep the two discretisations of one
        # and the same cable (docs/calibration.md, "Model mismatch").
        setup = {"grasps": "[]", "rods.cable.boundary": "[{clamp: start, kind: ghost}, "
                 "{clamp: end, kind: ghost, keyframes: %s}]" % TURNING,
                 "rods.cable.material.damping_time": 0.01, "rods.cable.drag.linear_normal": 0.05}
        fine = {**setup, "rods.cable.elements": 96, "integrator": "implicit_euler",
                "time_step": 0.0005}
        coarse = {**setup, "rods.cable.elements": 24, "integrator": "bdf2"}
        rec = F.synthesize(SCENE, fine, "cable", TIMES, arc_lengths(SCENE, fine), NOISE, 11)
        names = ["E", "G", "damping_time", "drag"]
        start = {"E": 3e7, "G": 1e7, "damping_time": 0.01, "drag": 0.05}
        p = [F.Parameter(n, F.PARAMETERS[n][0].format(rod="cable", obstacle="0"), start[n])
             for n in names]
        res = F.fit(SCENE, rec, p, "cable", coarse)
        log(f"mismatch: rms {res.rms * 1e3:.3f} mm per coordinate (noise 1 mm), RMS distance "
            f"per frame {res.frame_rms.min() * 1e3:.2f}..{res.frame_rms.max() * 1e3:.2f} mm; "
            + ", ".join(f"{n} {res.values[n] / start[n] - 1:+.2%}" for n in names))
        self.assertEqual(res.undetermined, {})
        self.assertLess(res.rms, 1.1 * NOISE)
        # a point's 3-D distance has RMS sqrt(3) sigma from the noise alone
        self.assertLess(res.frame_rms.max(), 1.6 * np.sqrt(3) * NOISE)


class Statics(unittest.TestCase):
    def test_cable_at_rest_in_each_pose(self):
        # The gripper stops at 23 poses along its path and the cable comes to rest in each: the
        # frames are static equilibria (corde_fit --statics), no run, no damping to fit.
        times = np.arange(0.0, 1.1 + 1e-9, 0.05)
        rec = F.synthesize(SCENE, {}, "cable", times, arc_lengths(), NOISE, 5, statics=True)
        res = F.fit(SCENE, rec, params(["E", "G"]), "cable", statics=True)
        log("statics: " + ", ".join(
            f"{n} {res.values[n] / TRUTH[n] - 1:+.2%} [{res.ci[n][0] / TRUTH[n] - 1:+.2%}, "
            f"{res.ci[n][1] / TRUTH[n] - 1:+.2%}]" for n in ("E", "G"))
            + f"; rms {res.rms * 1e3:.3f} mm, {res.runs} runs, {res.wall_time:.2f} s")
        self.assertLess(abs(res.values["E"] / TRUTH["E"] - 1), 0.02)
        self.assertLess(abs(res.values["G"] / TRUTH["G"] - 1), 0.05)
        self.assertLess(abs(res.rms / NOISE - 1), 0.1)
        for n in ("E", "G"):
            self.assertTrue(res.ci[n][0] <= TRUTH[n] <= res.ci[n][1], n)


class ContactFriction(unittest.TestCase):
    def test_table_friction_recovered(self):
        # A cable lying on a table (friction 0.4), one end pulled sideways along it: the way the
        # rest follows gives the Coulomb coefficient.
        scene = os.path.join(ROOT, "test", "python", "fit_table_scene.yaml")
        rec = F.synthesize(scene, {}, "cable", TIMES, arc_lengths(scene), NOISE, 2)
        p = [F.Parameter("friction", "obstacles.0.friction", 0.6),
             F.Parameter("E", "rods.cable.material.E", 4.2e7)]
        res = F.fit(scene, rec, p, "cable")
        log(f"table: friction {res.values['friction']:.4f} {res.ci['friction']}, E "
            f"{res.values['E']:.4g} {res.ci['E']}, rms {res.rms * 1e3:.3f} mm, {res.runs} runs")
        self.assertEqual(res.undetermined, {})
        self.assertLess(abs(res.values["friction"] / 0.4 - 1), 0.05)
        self.assertLess(abs(res.values["E"] / 3e7 - 1), 0.05)
        self.assertLess(abs(res.rms / NOISE - 1), 0.1)


class Executors(unittest.TestCase):
    def test_dask_workers_give_the_serial_fit(self):
        # The runs of each Jacobian on a local Dask cluster of 2 workers: the same runs, so the
        # same fit to the last bit.
        rec = F.synthesize(SCENE, {}, "cable", TIMES[::2], arc_lengths(), NOISE, 4)
        names = ["E", "damping_time"]
        t0 = time.perf_counter()
        serial = F.fit(SCENE, rec, params(names), "cable")
        t1 = time.perf_counter()
        ex = F.DaskExecutor(workers=2)
        try:
            t2 = time.perf_counter()
            dask = F.fit(SCENE, rec, params(names), "cable", executor=ex)
            t3 = time.perf_counter()
        finally:
            ex.close()
        log(f"serial {t1 - t0:.1f} s, 2 Dask workers {t3 - t2:.1f} s ({serial.runs} runs)")
        self.assertEqual(dask.workers, 2)
        self.assertEqual(serial.runs, dask.runs)
        for n in names:
            self.assertEqual(serial.values[n], dask.values[n], n)
            self.assertEqual(serial.ci[n], dask.ci[n], n)


if __name__ == "__main__":
    argv = [a for a in sys.argv if a != "--long"]
    unittest.main(argv=argv, verbosity=2)
