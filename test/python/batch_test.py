#!/usr/bin/env python3
"""corde_batch's engine (corde_sim.batch) on a local Dask cluster of 2 workers: 40 variants give
the same files as serial runs (and corde_run's numbers), finished runs are skipped, failures are
reported without stopping the others, a worker killed mid-run loses nothing.

ctest runs it with PYTHONPATH on the built package and CORDE_RUN naming corde_run; by hand:
  source build/devel/setup.bash; CORDE_RUN=build/corde_run python3 test/python/batch_test.py
"""
import csv
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import numpy as np

import corde_sim
from corde_sim import batch

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
CORDE_RUN = os.environ.get("CORDE_RUN", os.path.join(ROOT, "build", "corde_run"))
SCENE = os.path.join(ROOT, "test", "python", "batch_scene.yaml")

SWEEP = {
    "fixed": {"rods.cable.material.nu": 0.4},
    "grid": {"rods.cable.elements": [8, 12]},
    "random": {
        "count": 20,
        "seed": 11,
        "keys": {
            "rods.cable.material.E": {"log_uniform": [1.0e6, 1.0e8]},
            "rods.cable.initial.velocity": {"normal": [[0, 0, 0], [0.1, 0.1, 0.1]]},
            "grasps.gripper.keyframes.0.position": {
                "uniform": [[0.45, -0.05, 1.0], [0.55, 0.05, 1.1]]},
        },
    },
}


def assert_same_file(test, a, b):
    """Two run_variant files hold bitwise the same results."""
    ra, rb = batch.read_result(a), batch.read_result(b)
    test.assertEqual(ra["attrs"]["status"], rb["attrs"]["status"])
    test.assertEqual(ra["attrs"]["overrides"], rb["attrs"]["overrides"])
    np.testing.assert_array_equal(ra["time"], rb["time"])
    for x, y in zip(ra["rods"], rb["rods"]):
        for k in ("positions", "frames", "energies"):
            np.testing.assert_array_equal(x[k], y[k], err_msg="%s %s" % (a, k))
    for k in ("force", "moment", "point"):
        np.testing.assert_array_equal(ra["reactions"][k], rb["reactions"][k])
    test.assertEqual(ra["guard_events"], rb["guard_events"])


class Batch(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        from distributed import Client, LocalCluster

        cls.tmp = tempfile.mkdtemp(prefix="corde_batch_test_")
        cls.cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                   dashboard_address=None)
        cls.client = Client(cls.cluster)
        cls.variants = {"v%04d" % i: v for i, v in enumerate(batch.expand_sweep(SWEEP))}

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        cls.cluster.close()
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def cluster_dir(self):
        d = os.path.join(self.tmp, "cluster")
        if not os.path.exists(os.path.join(d, batch.SUMMARY_NAME)):
            batch.run_batch(SCENE, self.variants, d, out_rate=100, client=self.client,
                            progress=False)
        return d

    def test_a_cluster_equals_serial(self):
        self.assertEqual(len(self.variants), 40)
        d = self.cluster_dir()
        serial = os.path.join(self.tmp, "serial")
        os.makedirs(serial)
        for vid, ov in self.variants.items():
            row = batch.run_variant(SCENE, ov, 100, os.path.join(serial, vid + ".h5"))
            self.assertEqual(row["status"], "ok", row)
            self.assertEqual(row["frames"], 31)
        for vid in self.variants:
            assert_same_file(self, os.path.join(d, vid + ".h5"), os.path.join(serial, vid + ".h5"))
        # collect=True returns the same frames without a file.
        data = batch.run_variant(SCENE, self.variants["v0009"], 100, collect=True)["data"]
        ref = batch.read_result(os.path.join(d, "v0009.h5"))
        np.testing.assert_array_equal(data["time"], ref["time"])
        np.testing.assert_array_equal(data["rods"][0]["positions"], ref["rods"][0]["positions"])
        np.testing.assert_array_equal(data["reactions"]["force"], ref["reactions"]["force"])
        with open(os.path.join(d, batch.SUMMARY_NAME)) as f:
            rows = list(csv.DictReader(f))
        self.assertEqual([r["id"] for r in rows], list(self.variants))
        self.assertTrue(all(r["status"] == "ok" for r in rows))
        # The swept values are in the table as their override text.
        self.assertEqual(rows[3]["rods.cable.material.E"],
                         corde_sim.yaml_value(self.variants["v0003"]["rods.cable.material.E"]))
        # The variants differ (the draws reach the runs).
        a = batch.read_result(os.path.join(d, "v0000.h5"))["rods"][0]["positions"]
        b = batch.read_result(os.path.join(d, "v0001.h5"))["rods"][0]["positions"]
        self.assertGreater(np.abs(a[-1] - b[-1]).max(), 1e-4)

    def test_a_same_as_corde_run(self):
        """A variant's frames are corde_run's with the same --set strings and --every."""
        d = self.cluster_dir()
        for vid in ("v0005", "v0030"):
            r = batch.read_result(os.path.join(d, vid + ".h5"))
            out = os.path.join(self.tmp, vid + ".csv")
            args = [CORDE_RUN, SCENE, "--quiet", "--every", "10", "--out", out]
            for s in corde_sim.override_strings(self.variants[vid]):
                args += ["--set", s]
            subprocess.run(args, check=True)
            with open(out) as f:
                rows = list(csv.DictReader(f))
            x = r["rods"][0]["positions"]
            n = x.shape[1] - 1
            self.assertEqual(len(rows), len(r["time"]) * n)
            for k, row in enumerate(rows):
                f, s = divmod(k, n)
                want = np.array([float(row[c]) for c in ("x1", "y1", "z1")])
                self.assertTrue(np.all(np.abs(x[f, s + 1] - want) <= 6e-9 * np.abs(want) + 1e-300),
                                (vid, f, s, x[f, s + 1], want))

    def test_b_skip_finished(self):
        d = self.cluster_dir()
        mtimes = {v: os.path.getmtime(os.path.join(d, v + ".h5")) for v in self.variants}

        class NoClient:
            def submit(self, *a, **k):
                raise AssertionError("a finished variant was submitted")

        rows = batch.run_batch(SCENE, self.variants, d, out_rate=100, client=NoClient(),
                               progress=False)
        self.assertTrue(all(r["status"] == "ok" for r in rows.values()))
        # A changed setting is another result: not skipped.
        changed = batch.variant_key(SCENE, self.variants["v0002"], 50)
        self.assertNotEqual(changed, batch.read_marker(os.path.join(d, "v0002.h5"))["key"])
        # Without its marker a run counts as not done and runs again, the others stay.
        os.unlink(batch.marker_path(os.path.join(d, "v0007.h5")))
        rows = batch.run_batch(SCENE, self.variants, d, out_rate=100, client=self.client,
                               progress=False)
        self.assertEqual(rows["v0007"]["status"], "ok")
        for v in self.variants:
            changed = os.path.getmtime(os.path.join(d, v + ".h5")) != mtimes[v]
            self.assertEqual(changed, v == "v0007", v)

    def test_b_failures_reported(self):
        """A bad variant and one that blows up are rows with their message; the others run."""
        variants = {
            "good": {"rods.cable.material.E": 2e7},
            "bad": {"rods.cable.material.E": -5},
            "blows_up": {"integrator": "split_rotation", "time_step": 1e-3},
        }
        d = os.path.join(self.tmp, "failures")
        rows = batch.run_batch(SCENE, variants, d, out_rate=100, guard=False, client=self.client,
                               progress=False)
        self.assertEqual(rows["good"]["status"], "ok")
        self.assertEqual(rows["bad"]["status"], "scene_error")
        with self.assertRaises(corde_sim.SceneError) as cm:
            corde_sim.load(SCENE, variants["bad"])
        self.assertEqual(rows["bad"]["message"], str(cm.exception))
        self.assertEqual(rows["blows_up"]["status"], "failed")
        self.assertIn("blew up", rows["blows_up"]["message"])
        with open(os.path.join(d, batch.SUMMARY_NAME)) as f:
            table = {r["id"]: r for r in csv.DictReader(f)}
        self.assertEqual(table["bad"]["rods.cable.material.E"], "-5")
        self.assertIn("rods[0].material.E", table["bad"]["message"])
        self.assertEqual(table["blows_up"]["integrator"], "split_rotation")
        # The file of a failed run holds its status, message and the frames before the failure.
        r = batch.read_result(os.path.join(d, "blows_up.h5"))
        self.assertEqual(r["attrs"]["status"], "failed")
        self.assertGreater(len(r["time"]), 0)
        # Failed runs are finished too: skipped on a re-run unless asked.
        self.assertEqual(batch.read_marker(os.path.join(d, "bad.h5"))["status"], "scene_error")

    def test_c_killed_worker(self):
        """A worker killed (SIGKILL) while it runs a variant: Dask starts the run again on a new
        worker, every result is there and equals the serial run's."""
        variants = {"long%d" % i: {"rods.cable.material.E": 1e7 * (1 + i), "duration": 40.0}
                    for i in range(4)}
        d = os.path.join(self.tmp, "killed")
        pids = self.client.run(os.getpid)
        killed = []

        def killer():
            # Kill the first worker seen running one of the long variants, half a second in.
            deadline = time.time() + 60
            while time.time() < deadline and not killed:
                busy = [w for w, keys in self.client.processing().items() if keys]
                if busy:
                    time.sleep(0.5)
                    unfinished = [v for v in variants
                                  if not os.path.exists(os.path.join(d, v + ".h5.done"))]
                    os.kill(pids[busy[0]], signal.SIGKILL)
                    killed.append(pids[busy[0]])
                    killed.append(unfinished)
                    return
                time.sleep(0.05)

        import threading

        t = threading.Thread(target=killer)
        t.start()
        rows = batch.run_batch(SCENE, variants, d, every=100, client=self.client, progress=False)
        t.join()
        self.assertEqual(len(killed), 2)
        # It was killed while runs were unfinished (one of them its own: 1 thread per worker).
        self.assertGreaterEqual(len(killed[1]), 2)
        # The nanny started a new worker process in place of the killed one.
        self.assertNotIn(killed[0], self.client.run(os.getpid).values())
        ref = os.path.join(self.tmp, "killed_ref")
        os.makedirs(ref)
        for vid, ov in variants.items():
            self.assertEqual(rows[vid]["status"], "ok", rows[vid])
            batch.run_variant(SCENE, ov, None, os.path.join(ref, vid + ".h5"), every=100)
            assert_same_file(self, os.path.join(d, vid + ".h5"), os.path.join(ref, vid + ".h5"))

    def test_d_scheduler_address(self):
        """corde_batch --scheduler runs on a cluster that is already there."""
        d = os.path.join(self.tmp, "scheduler")
        os.makedirs(d)
        sweep = os.path.join(d, "s.yaml")
        with open(sweep, "w") as f:
            f.write("scene: %s\nevery: 50\ngrid:\n  rods.cable.elements: [6, 7, 8]\n" % SCENE)
        exe = os.path.join(ROOT, "scripts", "corde_batch")
        p = subprocess.run([sys.executable, exe, sweep, "--scheduler",
                            self.cluster.scheduler_address, "--out", "r", "--no-progress"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=d)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("3 of 3 variants ok", p.stdout)
        r = batch.read_result(os.path.join(d, "r", "v0002.h5"))
        self.assertEqual(r["rods"][0]["positions"].shape, (7, 9, 3))  # 300 steps, every 50


class Sweeps(unittest.TestCase):
    def test_seeded_draws(self):
        a = batch.expand_sweep(SWEEP)
        b = batch.expand_sweep(SWEEP)
        self.assertEqual(a, b)
        more = dict(SWEEP, random=dict(SWEEP["random"], count=25))
        c = batch.expand_sweep(more)
        self.assertEqual(c[:20], a[:20])  # adding draws keeps the earlier ones
        for v in a:
            self.assertEqual(v["rods.cable.material.nu"], 0.4)
            self.assertTrue(1e6 <= v["rods.cable.material.E"] <= 1e8)
            p = v["grasps.gripper.keyframes.0.position"]
            self.assertTrue(0.45 <= p[0] <= 0.55 and 1.0 <= p[2] <= 1.1)
        self.assertEqual([v["rods.cable.elements"] for v in a], [8] * 20 + [12] * 20)

    def test_bad_sweep(self):
        with self.assertRaisesRegex(batch.SweepError, "random.keys.x: .*uniform"):
            batch.expand_sweep({"random": {"count": 2, "keys": {"x": {"gauss": [0, 1]}}}})
        with self.assertRaisesRegex(batch.SweepError, "grid.y: needs a non-empty list"):
            batch.expand_sweep({"grid": {"y": 3}})

    def test_command_line(self):
        exe = os.path.join(ROOT, "scripts", "corde_batch")
        p = subprocess.run([sys.executable, exe, "--help"], stdout=subprocess.PIPE, text=True)
        self.assertEqual(p.returncode, 0)
        self.assertIn("--scheduler", p.stdout)
        with tempfile.TemporaryDirectory() as d:
            sweep = os.path.join(d, "s.yaml")
            with open(sweep, "w") as f:
                f.write("scene: %s\nduration: 0.05\ngrid:\n  rods.cable.elements: [6, 7]\n" % SCENE)
            p = subprocess.run([sys.executable, exe, sweep, "--list"], stdout=subprocess.PIPE,
                               text=True)
            self.assertEqual(p.stdout.split("\n")[:2],
                             ["v0000 rods.cable.elements=6", "v0001 rods.cable.elements=7"])
            p = subprocess.run([sys.executable, exe, sweep, "--workers", "1", "--no-progress"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=d)
            self.assertEqual(p.returncode, 0, p.stderr)
            self.assertIn("2 of 2 variants ok", p.stdout)
            self.assertTrue(os.path.exists(os.path.join(d, "s_results", "v0001.h5")))
            with open(sweep, "a") as f:
                f.write("rate: 100\nfoo: 1\n")
            p = subprocess.run([sys.executable, exe, sweep], stderr=subprocess.PIPE, text=True)
            self.assertEqual(p.returncode, 1)
            self.assertIn("unknown key(s) foo", p.stderr)


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]] + sys.argv[1:])
