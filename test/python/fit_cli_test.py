#!/usr/bin/env python3
"""The corde_fit command: a rosbag recording (tracked points as PoseArray, the gripper as
PoseStamped) fitted end to end, the gripper's poses becoming the grasp's keyframes; the fitted
scene runs in corde_run; bad input is refused with messages naming the file, key or parameter."""

import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
try:
    from corde_sim import fit as F
except ImportError:  # the source tree's package (corde_run as the simulator)
    sys.path.insert(0, os.path.join(ROOT, "python"))
    from corde_sim import fit as F

SCENE = os.path.join(ROOT, "config", "scenes", "calibration_cable.yaml")
CORDE_FIT = [sys.executable, os.path.join(ROOT, "scripts", "corde_fit")]


def corde_fit(*args):
    return subprocess.run(CORDE_FIT + list(args), capture_output=True, text=True)


class Bag(unittest.TestCase):
    def test_bag_with_gripper_poses(self):
        from scipy.spatial.transform import Rotation as R

        times = np.arange(0.0, 1.6 + 1e-9, 0.02)
        length = F.rod_length(SCENE, {}, "cable", None)
        s = np.linspace(0.0, length, 14)[1:-1]
        rec = F.synthesize(SCENE, {}, "cable", times, s, 1e-3, 5, gripper_segment=11)
        # the robot reports its tool frame: 4 cm off the grasped segment, turned by 90 degrees
        off_p, off_r = np.array([0.0, 0.04, 0.01]), R.from_euler("x", 90, degrees=True)
        gt, gp, gq = rec.gripper
        hr = R.from_quat(gq)
        rec.gripper = (gt, gp + hr.apply(off_p), (hr * off_r).as_quat())
        rec.arc_lengths = None  # estimated by projection at the first frame
        with tempfile.TemporaryDirectory() as tmp:
            bag = os.path.join(tmp, "cable.bag")
            F.write_bag_recording(bag, rec, "/cable/points", "/gripper/pose")
            doc = F.load_scene_yaml(SCENE)
            del doc["grasps"][0]["keyframes"]  # the motion comes from the bag
            scene = os.path.join(tmp, "setup.yaml")
            with open(scene, "w") as f:
                yaml.safe_dump(doc, f)
            out = os.path.join(tmp, "fitted.yaml")
            p = corde_fit(scene, bag, "--gripper-topic", "/gripper/pose", "--grasp", "gripper",
                          "--fit", "E,damping_time", "--initial", "E=4e7", "--initial",
                          "damping_time=0.07", "--out", out, "--residuals",
                          os.path.join(tmp, "res.csv"), "--material-file",
                          os.path.join(tmp, "materials", "my_cable.yaml"))
            print(p.stdout, p.stderr, file=sys.stderr)
            self.assertEqual(p.returncode, 0, p.stderr)
            fitted = F.load_scene_yaml(out)
            e = fitted["rods"][0]["material"]["E"]
            tau = fitted["rods"][0]["material"]["damping_time"]
            self.assertLess(abs(e / 3e7 - 1), 0.02)
            self.assertLess(abs(tau / 0.05 - 1), 0.10)
            kf = fitted["grasps"][0]["keyframes"]
            self.assertEqual(kf, {"file": "fitted_gripper.csv"})
            self.assertTrue(os.path.isfile(os.path.join(tmp, "fitted_gripper.csv")))
            rms = float(p.stdout.split("RMS ")[1].split(" mm")[0])
            self.assertLess(rms, 1.05)
            res = np.loadtxt(os.path.join(tmp, "res.csv"), delimiter=",", skiprows=1)
            self.assertEqual(res.shape, (len(times), 2))
            # the material file (docs/scene_format.md, "Material files"): absolute values
            with open(os.path.join(tmp, "materials", "my_cable.yaml")) as f:
                m = yaml.safe_load(f)
            self.assertEqual((m["version"], m["name"]), (1, "my_cable"))
            self.assertEqual((m["E"], m["damping_time"]), (e, tau))
            self.assertEqual((m["G"], m["rho"], m["radius"]), (1e7, 2000, 0.003))
            self.assertEqual(m["drag"], {"linear_normal": 0.02})
            self.assertEqual(m["fit"]["parameters"]["E"]["value"], e)
            self.assertLess(m["fit"]["parameters"]["E"]["interval"][0], e)
            # the fitted cable runs
            run = subprocess.run([F.find_corde_run(), out, "--quiet"], capture_output=True,
                                 text=True)
            self.assertEqual(run.returncode, 0, run.stderr)
            # and a scene naming the material file (as the node loads it) runs the same cable
            by_name = dict(fitted)
            by_name["rods"] = [dict(fitted["rods"][0], material="my_cable")]
            by_name["rods"][0].pop("drag", None)  # the file carries the drag
            named = os.path.join(tmp, "by_name.yaml")
            with open(named, "w") as f:
                yaml.safe_dump(by_name, f)
            runs = []
            for scene_file in (out, named):
                csv = scene_file + ".csv"
                r = subprocess.run([F.find_corde_run(), scene_file, "--quiet", "--duration",
                                    "0.5", "--out", csv], capture_output=True, text=True)
                self.assertEqual(r.returncode, 0, r.stderr)
                with open(csv) as f:
                    runs.append(f.read())
            self.assertGreater(len(runs[0].splitlines()), 10)
            self.assertEqual(runs[1], runs[0])



class Wrenches(unittest.TestCase):
    def test_bag_with_wrench_stamped_in_the_holder_frame(self):
        # The gripper's sensor as the node's grasps/<name>/reaction topic publishes it:
        # geometry_msgs/WrenchStamped in the holder frame grasp/gripper.
        with tempfile.TemporaryDirectory() as tmp:
            bag = os.path.join(tmp, "rec.bag")
            p = corde_fit("record", SCENE, bag, "--points", "12", "--every", "0.05", "--seed",
                          "4", "--wrench", "gripper", "--force-noise", "0.003",
                          "--torque-noise", "1.5e-4", "--wrench-frame", "holder")
            self.assertEqual(p.returncode, 0, p.stderr)
            import rosbag

            with rosbag.Bag(bag) as b:
                msgs = [m for _, m, _ in b.read_messages(topics=["/gripper/wrench"])]
            self.assertEqual(msgs[0]._type, "geometry_msgs/WrenchStamped")
            self.assertEqual(msgs[0].header.frame_id, "grasp/gripper")
            res = os.path.join(tmp, "res.csv")
            p = corde_fit(SCENE, bag, "--wrench-topic", "/gripper/wrench", "--grasp", "gripper",
                          "--force-noise", "0.003", "--torque-noise", "1.5e-4", "--fit",
                          "E,rho", "--initial", "E=4e7", "--initial", "rho=2500",
                          "--arc-lengths", ",".join(repr(x) for x in np.linspace(
                              0, F.rod_length(SCENE, {}, "cable", None), 14)[1:-1]),
                          "--out", os.path.join(tmp, "fitted.yaml"), "--residuals", res)
            print(p.stdout, p.stderr, file=sys.stderr)
            self.assertEqual(p.returncode, 0, p.stderr)
            self.assertRegex(p.stdout, r"force residual\s+RMS")
            self.assertRegex(p.stdout, r"torque residual\s+RMS")
            m = F.load_scene_yaml(os.path.join(tmp, "fitted.yaml"))["rods"][0]["material"]
            self.assertLess(abs(m["rho"] / 2000 - 1), 0.02)
            self.assertLess(abs(m["E"] / 3e7 - 1), 0.02)
            with open(res) as f:
                self.assertEqual(f.readline().strip(), "time,rms_mm,force_n,torque_nm")
            r = np.loadtxt(res, delimiter=",", skiprows=1)
            self.assertEqual(r.shape, (33, 4))
            self.assertLess(np.sqrt(np.mean(r[:, 2] ** 2)), 2 * 0.003)

    def test_csv_wrench_columns_and_messages(self):
        with tempfile.TemporaryDirectory() as tmp:
            csv = os.path.join(tmp, "rec.csv")
            p = corde_fit("record", SCENE, csv, "--points", "8", "--every", "0.1", "--wrench",
                          "gripper", "--forces-only", "--force-noise", "0.003")
            self.assertEqual(p.returncode, 0, p.stderr)
            rec = F.read_recording(csv)
            self.assertEqual(rec.wrenches[1].shape, (17, 3))
            with open(csv) as f:
                header = [x for x in f if not x.startswith("#")][0].strip().split(",")
            self.assertEqual(header[-3:], ["fx", "fy", "fz"])
            p = corde_fit(SCENE, csv, "--fit", "rho", "--force-noise", "0", "--out",
                          os.path.join(tmp, "f.yaml"))
            self.assertEqual(p.returncode, 1)
            self.assertIn("--force-noise: must be a number > 0, got 0", p.stderr)
            with open(os.path.join(tmp, "bad.csv"), "w") as f:
                f.write("time,x0,y0,z0,fx,fy\n0,0,0,1,0,0\n")
            p = corde_fit(SCENE, os.path.join(tmp, "bad.csv"), "--fit", "rho")
            self.assertEqual(p.returncode, 1)
            self.assertIn("the wrench columns must close the header", p.stderr)

class JointStates(unittest.TestCase):
    URDF = os.path.join(ROOT, "urdf", "cell_example.urdf")

    def test_forward_kinematics_of_the_cell_arm(self):
        # urdf/cell_example.urdf: at zero joints the tool is at (0.20, 0, 0.85), z pointing down;
        # shoulder and elbow turn about z on a column at (-0.35, 0), links 0.30 and 0.25 m.
        from scipy.spatial.transform import Rotation as R

        tool = F.ToolChain(self.URDF, "tool")
        self.assertEqual(tool.moving, ["shoulder", "elbow"])
        p, q = tool.pose({"shoulder": 0.0, "elbow": 0.0})
        np.testing.assert_allclose(p, [0.20, 0.0, 0.85], atol=1e-12)
        np.testing.assert_allclose(R.from_quat(q).apply([0, 0, 1]), [0, 0, -1], atol=1e-12)
        p, _ = tool.pose({"shoulder": np.pi / 2, "elbow": -np.pi / 2})
        np.testing.assert_allclose(p, [-0.35 + 0.25, 0.30, 0.85], atol=1e-12)
        with self.assertRaisesRegex(F.FitError, "no link 'tcp'"):
            F.ToolChain(self.URDF, "tcp")

    def test_bag_with_joint_states(self):
        # The arm turns its shoulder and elbow; the cable's end is held in the gripper as the
        # grasp holder is at the start. The bag has the tracked points and the joint states.
        tool = F.ToolChain(self.URDF, "tool")
        jt = np.arange(0.0, 1.6 + 1e-9, 0.02)
        u = np.clip(jt / 1.1, 0.0, 1.0)
        ramp = 0.5 - 0.5 * np.cos(np.pi * u)
        q = np.stack([0.25 * ramp, -0.4 * np.sin(np.pi * u) ** 2], axis=1)
        poses = [tool.pose({"shoulder": a, "elbow": b}) for a, b in q]
        gripper = (jt, np.array([p for p, _ in poses]), np.array([r for _, r in poses]))
        with tempfile.TemporaryDirectory() as tmp:
            doc = F.load_scene_yaml(SCENE)
            del doc["grasps"][0]["keyframes"]
            scene = os.path.join(tmp, "setup.yaml")
            with open(scene, "w") as f:
                yaml.safe_dump(doc, f)
            nodes, quats = F.simulate(F.Job(scene, {}, "cable", np.array([0.0]),
                                            want_frames=True))
            keys = F.gripper_keyframes(gripper, 0.5 * (nodes[0, 11] + nodes[0, 12]),
                                       quats[0, 11])
            kf = os.path.join(tmp, "truth.csv")
            F.write_keyframe_csv(kf, keys)
            times = np.arange(0.0, 1.6 + 1e-9, 0.05)
            s = np.linspace(0.0, F.rod_length(scene, {}, "cable"), 14)[1:-1]
            rec = F.synthesize(scene, {"grasps.gripper.keyframes": "{file: %s}" % kf}, "cable",
                               times, s, 1e-3, 8)
            bag = os.path.join(tmp, "arm.bag")
            F.write_bag_recording(bag, rec, joints=(jt, ["shoulder", "elbow"], q))
            out = os.path.join(tmp, "fitted.yaml")
            p = corde_fit(scene, bag, "--gripper-topic", "/joint_states", "--urdf", self.URDF,
                          "--tool-link", "tool", "--grasp", "gripper", "--fit", "E",
                          "--initial", "E=4e7", "--out", out)
            print(p.stdout, p.stderr, file=sys.stderr)
            self.assertEqual(p.returncode, 0, p.stderr)
            e = F.load_scene_yaml(out)["rods"][0]["material"]["E"]
            self.assertLess(abs(e / 3e7 - 1), 0.02)
            rms = float(p.stdout.split("RMS ")[1].split(" mm")[0])
            self.assertLess(rms, 1.05)
            p = corde_fit(scene, bag, "--gripper-topic", "/joint_states", "--grasp", "gripper")
            self.assertIn("has joint states: give the robot's URDF and its tool link", p.stderr)


class Backends(unittest.TestCase):
    def test_corde_run_gives_the_api_fit(self):
        # Without the extension the runs go through corde_run (its CSV has 9 digits): the same
        # fit to 1e-4.
        with tempfile.TemporaryDirectory() as tmp:
            rec = os.path.join(tmp, "rec.csv")
            p = corde_fit("record", SCENE, rec, "--points", "10", "--every", "0.1", "--seed", "3")
            self.assertEqual(p.returncode, 0, p.stderr)
            fitted = {}
            for backend in ("api", "cli"):
                out = os.path.join(tmp, backend + ".yaml")
                p = corde_fit(SCENE, rec, "--fit", "E", "--initial", "E=4e7", "--backend", backend,
                              "--out", out)
                self.assertEqual(p.returncode, 0, p.stderr)
                fitted[backend] = F.load_scene_yaml(out)["rods"][0]["material"]["E"]
            print(fitted, file=sys.stderr)
            self.assertLess(abs(fitted["cli"] / fitted["api"] - 1), 1e-4)
            self.assertLess(abs(fitted["api"] / 3e7 - 1), 0.02)


class BadInput(unittest.TestCase):
    def test_messages(self):
        with tempfile.TemporaryDirectory() as tmp:
            csv = os.path.join(tmp, "r.csv")
            with open(csv, "w") as f:
                f.write("time,x0,y0\n0,1,2\n")
            p = corde_fit(SCENE, csv)
            self.assertEqual(p.returncode, 1)
            self.assertIn("r.csv line 1: header must be time,x0,y0,z0", p.stderr)
            with open(csv, "w") as f:
                f.write("# arc_length,0.1,0.2\ntime,x0,y0,z0\n0,1,2,3\n0.1,1,2,3\n")
            p = corde_fit(SCENE, csv)
            self.assertIn("2 arc lengths for 1 points", p.stderr)
            with open(csv, "w") as f:
                f.write("time,x0,y0,z0\n0.1,1,2,3\n0.1,1,2,3\n")
            p = corde_fit(SCENE, csv)
            self.assertIn("times must increase strictly (frame 1: 0.1 s)", p.stderr)
            with open(csv, "w") as f:
                f.write("time,x0,y0,z0\n0,0.1,0,1\n0.1,0.1,0,1\n")
            p = corde_fit(SCENE, csv, "--set", "time_step=auto")
            self.assertEqual(p.returncode, 1)
            self.assertIn("time_step: auto changes with the material", p.stderr)
            p = corde_fit(SCENE, csv, "--fit", "E,stiffness")
            self.assertIn("unknown parameter 'stiffness'", p.stderr)
            p = corde_fit(SCENE, csv, "--fit", "friction")
            self.assertIn("friction: the scene has no value at obstacles.0.friction", p.stderr)
            p = corde_fit(SCENE, csv, "--fit", "E", "--initial", "E=-3")
            self.assertIn("E: the starting value must be > 0", p.stderr)
            p = corde_fit(SCENE, csv, "--fit", "E", "--set", "rods.cable.material.G=-5")
            self.assertEqual(p.returncode, 1)
            self.assertIn("calibration_cable.yaml: rods[0].material.G: must be > 0, got -5",
                          p.stderr)  # the library's message, once
            self.assertEqual(p.stderr.count("calibration_cable.yaml"), 1)
            p = corde_fit(SCENE, os.path.join(tmp, "missing.csv"))
            self.assertIn("missing.csv: No such file or directory", p.stderr)

    def test_csv_round_trip(self):
        rec = F.Recording(np.array([0.0, 0.05]), np.arange(12.0).reshape(2, 2, 3) * 1e-3,
                          np.array([0.1, 0.2]))
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "r.csv")
            F.write_csv_recording(path, rec)
            back = F.read_csv_recording(path)
        np.testing.assert_array_equal(back.times, rec.times)
        np.testing.assert_array_equal(back.points, rec.points)
        np.testing.assert_array_equal(back.arc_lengths, rec.arc_lengths)


if __name__ == "__main__":
    unittest.main(verbosity=2)
