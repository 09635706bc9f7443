#!/usr/bin/env python3
"""The Python API (corde_sim) against corde_run: the validation suite's static cantilever (V1) and
pendulum (V5) give corde_run's numbers, bad input raises with corde_run's message.

ctest runs it with PYTHONPATH on the built package and CORDE_RUN naming the corde_run binary
(cmake/CordePython.cmake); by hand:
  source build/devel/setup.bash; CORDE_RUN=build/corde_run python3 test/python/api_test.py
"""
import csv
import math
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np

import corde_sim

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
CORDE_RUN = os.environ.get("CORDE_RUN", os.path.join(ROOT, "build", "corde_run"))


def scene(name):
    return os.path.join(ROOT, "config", "scenes", name + ".yaml")


def corde_run(args):
    """Runs corde_run; returns (status, stderr)."""
    p = subprocess.run([CORDE_RUN] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       text=True)
    return p.returncode, p.stderr


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def frames_by_time(rows):
    """{t: [row per segment]} of an --out CSV, times in order."""
    out = {}
    for r in rows:
        out.setdefault(r["t"], []).append(r)
    return out


def close_to_print(a, b):
    """corde_run prints %.9g: equal to within half a unit of the 9th digit."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.all(np.abs(a - b) <= 6e-9 * np.maximum(np.abs(b), 1e-300) + 1e-300)


class StaticCantilever(unittest.TestCase):
    """V1: the cantilever under a small tip load, solved as statics from Python and by
    corde_run --statics."""

    def test_statics_matches_corde_run(self):
        with tempfile.TemporaryDirectory() as d:
            out, reac, en = (os.path.join(d, n) for n in ("o.csv", "r.csv", "e.csv"))
            status, err = corde_run([scene("v1_cantilever_small_load"), "--statics", "--quiet",
                                     "--out", out, "--reactions", reac, "--energies", en])
            self.assertEqual(status, 0, err)
            rows = read_csv(out)
            reactions = read_csv(reac)
            energies = read_csv(en)
        sim = corde_sim.load(scene("v1_cantilever_small_load"))
        eq = sim.statics()
        self.assertTrue(eq["ok"])
        self.assertTrue(eq["rods"][0]["converged"])
        x = sim.positions("beam")
        q = sim.frames(0)
        self.assertEqual(x.shape, (51, 3))
        self.assertEqual(q.shape, (50, 4))
        self.assertEqual(len(rows), 50)
        for s, r in enumerate(rows):
            self.assertTrue(close_to_print(x[s], [r["x0"], r["y0"], r["z0"]]), (s, x[s], r))
            self.assertTrue(close_to_print(x[s + 1], [r["x1"], r["y1"], r["z1"]]))
            # frames are w, x, y, z; the CSV writes qx, qy, qz, qw
            self.assertTrue(close_to_print(q[s], [r["qw"], r["qx"], r["qy"], r["qz"]]))
        # The analytic reference of the validation (docs/validation_references.md, V1): tip
        # deflection P L^3 / (3 B) + P L / kappa = 1.66704e-2 m, within the discretisation's 0.5%.
        self.assertAlmostEqual(-x[-1, 2] / 1.66704e-2, 1.0, delta=5e-3)
        react = sim.reactions()
        self.assertEqual([r["support"] for r in react], [r["support"] for r in reactions])
        for mine, theirs in zip(react, reactions):
            for k, cols in (("force", "fx fy fz"), ("moment", "mx my mz"),
                            ("point", "px py pz")):
                want = [float(theirs[c]) for c in cols.split()]
                self.assertTrue(np.all(np.abs(mine[k] - want) <= 6e-9 * np.abs(want) + 1e-15),
                                (k, mine[k], want))
        # The clamp carries the tip load P = 3.926991e-3 N.
        self.assertAlmostEqual(react[0]["force"][2], 3.926991e-3, delta=1e-9)
        e = sim.energies(0)
        for k, v in e.items():
            self.assertTrue(close_to_print(v, float(energies[0][k])), (k, v, energies[0][k]))
        self.assertIn("converged", eq["summary"])


class Pendulum(unittest.TestCase):
    """V5: the stiff pendulum released horizontally, stepped from Python with frames every 250
    steps, against corde_run --every 250 (0.1 s of the 10 s run)."""

    def test_dynamics_matches_corde_run(self):
        duration, every = 0.1, 250
        with tempfile.TemporaryDirectory() as d:
            out, en, reac = (os.path.join(d, n) for n in ("o.csv", "e.csv", "r.csv"))
            status, err = corde_run([scene("v5_pendulum"), "--quiet", "--duration",
                                     repr(duration), "--every", str(every), "--out", out,
                                     "--energies", en, "--reactions", reac])
            self.assertEqual(status, 0, err)
            frames = frames_by_time(read_csv(out))
            energies = read_csv(en)
            reactions = read_csv(reac)
        sim = corde_sim.load(scene("v5_pendulum"), {"duration": duration})
        self.assertEqual(sim.time_step, 4e-6)
        steps = math.ceil(duration / sim.time_step - 1e-9)
        times = list(frames)
        self.assertEqual(len(times), steps // every + 1)
        for k, t in enumerate(times):
            if k > 0:
                sim.step(every)
            self.assertTrue(close_to_print(sim.time, float(t)), (sim.time, t))
            x = sim.positions("pendulum")
            q = sim.frames("pendulum")
            for s, r in enumerate(frames[t]):
                self.assertTrue(close_to_print(x[s + 1], [r["x1"], r["y1"], r["z1"]]),
                                (t, s, x[s + 1], r))
                self.assertTrue(close_to_print(q[s], [r["qw"], r["qx"], r["qy"], r["qz"]]))
            e = sim.energies(0)
            self.assertTrue(close_to_print(e["total"], float(energies[k]["total"])))
            if k > 0:  # reactions from the first step on
                f = sim.reactions()[0]["force"]
                want = [float(reactions[k - 1][c]) for c in ("fx", "fy", "fz")]
                self.assertTrue(np.all(np.abs(f - want) <= 6e-9 * np.abs(want) + 1e-12))
        self.assertEqual(sim.guard_events(), [])
        # It swings: the tip has fallen, the pin holds the rod's weight and more.
        self.assertLess(sim.positions()[-1, 2], -0.05)
        self.assertEqual(sim.steps, steps)

    def test_run_is_steps(self):
        """run(d) takes ceil(d / h) steps: the state of step(n) in one batch."""
        a = corde_sim.load(scene("v5_pendulum")).run(0.01)
        b = corde_sim.load(scene("v5_pendulum")).step(2500)
        self.assertEqual(a.time, b.time)
        np.testing.assert_array_equal(a.positions(), b.positions())
        np.testing.assert_array_equal(a.velocities(), b.velocities())
        np.testing.assert_array_equal(a.frames(), b.frames())


CANTILEVER = """gravity: [0, 0, -9.81]
rods:
  - name: cable
    elements: 16
    radius: 0.004
    material: {E: 2.0e7, G: 7.0e6, rho: 1500}
    shape: {type: straight, start: [0, 0, 1], direction: [1, 0, 0], length: 0.4}
    boundary:
      - {clamp: start, kind: ghost}
    masses:
      - {node: end, mass: 0.005}
"""


class StaticsSensitivity(unittest.TestCase):
    """Simulation.statics_sensitivity against central differences of re-solved equilibria."""

    def test_matches_differences(self):
        sim = corde_sim.parse(CANTILEVER)
        sim.statics()
        d, w = sim.statics_sensitivity(["E", "G", "density"], rod="cable", rotations=True)
        self.assertEqual(sorted(d), ["E", "G", "density"])
        self.assertEqual(d["E"].shape, (17, 3))
        self.assertEqual(w["G"].shape, (16, 3))
        for name, key, value in (("E", "E", 2.0e7), ("G", "G", 7.0e6), ("density", "rho", 1500)):
            h = 1e-4 * value
            x = []
            for v in (value + h, value - h):
                s = corde_sim.parse(CANTILEVER, {f"rods.0.material.{key}": v})
                s.statics()
                x.append(s.positions(0))
            fd = (x[0] - x[1]) / (2 * h)
            err = np.abs(d[name] - fd).max() / np.abs(fd).max()
            print(f"statics_sensitivity {name}: {err:.2e} relative to central differences")
            self.assertLess(err, 1e-5, name)

    def test_errors(self):
        sim = corde_sim.parse(CANTILEVER)
        with self.assertRaisesRegex(corde_sim.StaticsError, "call statics\\(\\) first"):
            sim.statics_sensitivity(["E"])
        sim.statics()
        with self.assertRaisesRegex(corde_sim.SceneError, "unknown parameter 'Q'"):
            sim.statics_sensitivity(["Q"])
        with self.assertRaisesRegex(corde_sim.SceneError, "derives nothing from C"):
            sim.statics_sensitivity(["C"])
        sim.step(1)
        with self.assertRaisesRegex(corde_sim.StaticsError, "no static equilibrium"):
            sim.statics_sensitivity(["E"])


class BadInput(unittest.TestCase):
    """Errors raise corde_sim exceptions with corde_run's messages."""

    def assert_same_message(self, args, overrides, exc=corde_sim.SceneError):
        status, err = corde_run(args)
        self.assertEqual(status, 1, err)
        self.assertTrue(err.startswith("corde_run: "), err)
        want = err[len("corde_run: "):].strip()
        with self.assertRaises(exc) as cm:
            corde_sim.load(args[0], overrides)
        self.assertEqual(str(cm.exception), want)
        return str(cm.exception)

    def test_bad_override(self):
        msg = self.assert_same_message([scene("v5_pendulum"), "--set", "rods.0.material.E=-5"],
                                       {"rods.0.material.E": -5})
        self.assertIn("rods[0].material.E", msg)

    def test_unknown_key(self):
        msg = self.assert_same_message([scene("v5_pendulum"), "--set", "rods.0.elemnts=4"],
                                       {"rods.0.elemnts": 4})
        self.assertIn("unknown key", msg)

    def test_missing_file(self):
        self.assert_same_message(["/nonexistent/scene.yaml"], None)

    def test_scene_error_is_value_error(self):
        with self.assertRaises(ValueError):
            corde_sim.load(scene("v5_pendulum"), {"rods.0.radius": "a"})
        with self.assertRaises(corde_sim.Error):
            corde_sim.load(scene("v5_pendulum"), {"rods.0.radius": -1.0})

    def test_bad_rod(self):
        sim = corde_sim.load(scene("v5_pendulum"))
        with self.assertRaisesRegex(IndexError, "no rod named 'cable' \\(rods: 'pendulum'\\)"):
            sim.positions("cable")
        with self.assertRaises(IndexError):
            sim.positions(3)
        with self.assertRaises(ValueError):
            sim.step(-1)

    def test_statics_unsupported(self):
        """A rod held nowhere under gravity has no equilibrium: the library's message."""
        sim = corde_sim.load(scene("v5_pendulum"), {"rods.0.boundary": []})
        with self.assertRaisesRegex(corde_sim.SceneError, "pendulum"):
            sim.statics()

    def test_runaway(self):
        """Without the guard a step far above the stability limit blows up: RunawayError with
        corde_run's problem text, the time of the last step."""
        args = [scene("v5_pendulum"), "--no-guard", "--dt", "4e-5", "--duration", "0.05"]
        status, err = corde_run(args + ["--quiet"])
        self.assertEqual(status, 3, err)
        sim = corde_sim.load(scene("v5_pendulum"), {"time_step": 4e-5}, guard=False)
        with self.assertRaises(corde_sim.RunawayError) as cm:
            for _ in range(1250 // 8):
                sim.step(8)
        problem = str(cm.exception).split("): ", 1)[1].split("; try")[0]
        self.assertIn(problem, err)


    def test_guard_gives_up(self):
        """The guard kept from the implicit method cannot cure a step 1000x above the explicit
        limit: GuardError, the state at the last good one (finite, at a snapshot's time)."""
        sim = corde_sim.load(scene("v5_pendulum"), {"time_step": 4e-3},
                             guard={"allow_implicit": False})
        with self.assertRaisesRegex(corde_sim.GuardError,
                                    "could not recover .* t = 0 s: .*unrecoverable"):
            sim.step(50)
        self.assertTrue(np.all(np.isfinite(sim.positions())))
        self.assertEqual(sim.time, 0.0)
        self.assertEqual(sim.guard_events()[-1]["kind"], "unrecoverable")
        with self.assertRaisesRegex(ValueError, "guard: unknown setting 'allow'"):
            corde_sim.load(scene("v5_pendulum"), guard={"allow": False})


class SceneInCode(unittest.TestCase):
    def test_dict_scene(self):
        """A scene built as a dict gives the same run as the same scene in a file."""
        d = {
            "name": "in_code",
            "time_step": 1e-4,
            "duration": 0.05,
            "rods": [{
                "name": "cable", "elements": 10, "radius": 0.003,
                "material": {"E": 1e7, "nu": 0.5, "rho": 1200},
                "shape": {"type": "straight", "start": [0, 0, 1], "direction": [1, 0, 0],
                          "length": 0.5},
                "boundary": [{"clamp": "start", "kind": "ghost"}],
            }],
        }
        a = corde_sim.load(d).run()
        with tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False) as f:
            import json
            f.write(json.dumps(d))
        try:
            b = corde_sim.load(f.name).run()
        finally:
            os.unlink(f.name)
        np.testing.assert_array_equal(a.positions("cable"), b.positions("cable"))
        self.assertLess(a.positions()[-1, 2], 1.0)  # it sags
        with self.assertRaisesRegex(corde_sim.SceneError, "^<dict>: rods\\[0\\]"):
            corde_sim.load(d, {"rods.0.radius": -1})

    def test_override_values(self):
        self.assertEqual(corde_sim.override_strings({"a.b": [0, 0.1, -1e-7], "c": True}),
                         ["a.b=[0, 0.1, -1e-07]", "c=true"])
        self.assertEqual(corde_sim.override_strings(["x=1", ("y", 2.5)]), ["x=1", "y=2.5"])
        self.assertEqual(corde_sim.yaml_value(np.float64(0.1) * 3), repr(0.1 * 3))


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]] + sys.argv[1:])
