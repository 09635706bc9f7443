"""Identification of a cable's material from a recording of its motion (`corde_fit`).

A recording is 3-D points tracked along a real cable over time (CSV or rosbag, see
docs/calibration.md) and, optionally, the poses of the gripper that moved it. The fit finds the
scene keys (E, G, damping_time, drag, ...) whose simulation reproduces the tracked points best:
nonlinear least squares (scipy.optimize.least_squares) over the logarithms of the parameters,
residuals = simulated minus tracked positions at the recorded times. The Jacobian is taken by
forward finite differences; its columns are independent runs, spread over Dask workers when a
cluster is given. Confidence intervals come from J^T J and the residual variance; a parameter
whose interval is wider than a limit (or that does not change the simulation at all) is refused
as undetermined, fixed at its starting value, and the others are fitted again without it.
"""

from __future__ import annotations

import copy
import csv
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time as _time
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Sequence

import numpy as np
import yaml

# ---------------------------------------------------------------------------------------------
# Parameters
# ---------------------------------------------------------------------------------------------

# Fitted parameters by name: the scene key each one sets ({rod} is the rod's name or index,
# {obstacle} the obstacle's index) and what it is.
PARAMETERS = {
    "E": ("rods.{rod}.material.E", "Young's modulus for bending (Pa)"),
    "G": ("rods.{rod}.material.G", "shear modulus for twist (Pa)"),
    "B": ("rods.{rod}.material.B", "bending stiffness (N m^2)"),
    "C": ("rods.{rod}.material.C", "twist stiffness (N m^2)"),
    "E_s": ("rods.{rod}.material.E_s", "stretch modulus (Pa)"),
    "rho": ("rods.{rod}.material.rho", "density (kg/m^3)"),
    "damping_time": ("rods.{rod}.material.damping_time",
                     "retardation time of internal friction (s)"),
    "drag": ("rods.{rod}.drag.linear_normal", "linear normal air drag (N s/m^2)"),
    "drag_tangential": ("rods.{rod}.drag.linear_tangential",
                        "linear tangential air drag (N s/m^2)"),
    "quadratic_drag": ("rods.{rod}.drag.quadratic_normal", "quadratic normal drag (N s^2/m^3)"),
    "friction": ("obstacles.{obstacle}.friction", "Coulomb friction with the obstacle"),
}


class FitError(Exception):
    """Bad input or a failed run; the message names the file, key or parameter."""


@dataclass
class Parameter:
    name: str
    key: str  # scene key path (override syntax)
    initial: float


# ---------------------------------------------------------------------------------------------
# Recordings
# ---------------------------------------------------------------------------------------------


@dataclass
class Recording:
    """Tracked points over time, optionally their arc lengths and the gripper's poses.

    times (F,), points (F, M, 3) in m; arc_lengths (M,) in m or None (estimated by projection);
    gripper: None or (times (K,), positions (K, 3), quaternions (K, 4) as [qx, qy, qz, qw]).
    """

    times: np.ndarray
    points: np.ndarray
    arc_lengths: Optional[np.ndarray] = None
    gripper: Optional[tuple] = None

    def check(self, source: str = "recording") -> None:
        t, p = self.times, self.points
        if t.ndim != 1 or len(t) < 2:
            raise FitError(f"{source}: needs at least 2 frames, got {len(t)}")
        if p.shape != (len(t), p.shape[1], 3) or p.shape[1] < 1:
            raise FitError(f"{source}: points must be frames x points x 3, got {p.shape}")
        if not np.all(np.isfinite(t)) or not np.all(np.isfinite(p)):
            raise FitError(f"{source}: non-finite time or coordinate")
        if np.any(np.diff(t) <= 0):
            k = int(np.argmax(np.diff(t) <= 0)) + 1
            raise FitError(f"{source}: times must increase strictly (frame {k}: {t[k]} s)")
        if t[0] < 0:
            raise FitError(f"{source}: times must be >= 0 (scene time), got {t[0]}")
        if self.arc_lengths is not None:
            s = np.asarray(self.arc_lengths, float)
            if s.shape != (p.shape[1],):
                raise FitError(f"{source}: {len(s)} arc lengths for {p.shape[1]} points")
            if np.any(s < 0) or not np.all(np.isfinite(s)):
                raise FitError(f"{source}: arc lengths must be finite and >= 0")


def write_csv_recording(path: str, rec: Recording) -> None:
    """Writes the CSV format read by read_csv_recording (docs/calibration.md)."""
    m = rec.points.shape[1]
    with open(path, "w", newline="") as f:
        f.write("# corde_fit recording: time (s), then x,y,z (m) of each tracked point\n")
        if rec.arc_lengths is not None:
            f.write("# arc_length," + ",".join(repr(float(s)) for s in rec.arc_lengths) + "\n")
        w = csv.writer(f)
        w.writerow(["time"] + [f"{c}{i}" for i in range(m) for c in "xyz"])
        for t, pts in zip(rec.times, rec.points):
            w.writerow([repr(float(t))] + [repr(float(v)) for v in pts.reshape(-1)])


def read_csv_recording(path: str) -> Recording:
    """Reads a recording CSV: a header `time,x0,y0,z0,x1,...`, one row per frame; `#` lines are
    comments, except `# arc_length,s0,s1,...` which gives the points' arc lengths (m)."""
    arc = None
    rows = []
    header = None
    try:
        f = open(path, newline="")
    except OSError as e:
        raise FitError(f"{path}: {e.strerror}") from None
    with f:
        for lineno, line in enumerate(f, 1):
            line = line.strip().lstrip("\ufeff")
            if not line:
                continue
            if line.startswith("#"):
                body = line[1:].strip()
                if body.startswith("arc_length"):
                    try:
                        arc = np.array([float(v) for v in body.split(",")[1:]])
                    except ValueError:
                        raise FitError(f"{path} line {lineno}: arc_length values must be numbers")
                continue
            cells = [c.strip() for c in line.split(",")]
            if header is None:
                header = cells
                if header[0] != "time" or (len(header) - 1) % 3 != 0 or len(header) < 4:
                    raise FitError(f"{path} line {lineno}: header must be time,x0,y0,z0,... "
                                   f"(3 columns per point), got '{line}'")
                continue
            if len(cells) != len(header):
                raise FitError(f"{path} line {lineno}: {len(cells)} values, the header has "
                               f"{len(header)}")
            try:
                rows.append([float(c) for c in cells])
            except ValueError:
                raise FitError(f"{path} line {lineno}: not a number in '{line}'") from None
    if header is None:
        raise FitError(f"{path}: no header line (time,x0,y0,z0,...)")
    data = np.array(rows).reshape(len(rows), len(header))
    rec = Recording(times=data[:, 0], points=data[:, 1:].reshape(len(rows), -1, 3), arc_lengths=arc)
    rec.check(path)
    return rec


def read_bag_recording(path: str, points_topic: str = "/cable/points",
                       gripper_topic: Optional[str] = None) -> Recording:
    """Reads a rosbag: tracked points as geometry_msgs/PoseArray (positions in order along the
    cable) or sensor_msgs/PointCloud2 (fields x, y, z, in order), the gripper as
    geometry_msgs/PoseStamped. Times are the messages' header stamps minus the first points
    message's stamp (scene time 0)."""
    try:
        import rosbag  # python3-rosbag (Debian)
    except ImportError:
        raise FitError("reading a rosbag needs python3-rosbag (apt-get install python3-rosbag)")
    try:
        bag = rosbag.Bag(path)
    except Exception as e:  # rosbag raises its own types (ROSBagException, IOError)
        raise FitError(f"{path}: cannot open as a rosbag: {e}") from None
    times, frames, gt, gp, gq = [], [], [], [], []
    topics = [points_topic] + ([gripper_topic] if gripper_topic else [])
    with bag:
        info = bag.get_type_and_topic_info().topics
        for t in topics:
            if t not in info:
                raise FitError(f"{path}: no topic '{t}' (topics: {', '.join(sorted(info))})")
        for topic, msg, stamp in bag.read_messages(topics=topics):
            st = msg.header.stamp.to_sec() if msg.header.stamp.to_sec() > 0 else stamp.to_sec()
            if topic == points_topic:
                times.append(st)
                frames.append(_points_of_message(msg, path, topic))
            else:
                p, q = msg.pose.position, msg.pose.orientation
                gt.append(st)
                gp.append([p.x, p.y, p.z])
                gq.append([q.x, q.y, q.z, q.w])
    if not frames:
        raise FitError(f"{path}: no messages on '{points_topic}'")
    m = {len(f) for f in frames}
    if len(m) != 1:
        raise FitError(f"{path}: '{points_topic}': the number of tracked points changes "
                       f"({sorted(m)}); every frame must have the same points in the same order")
    t0 = times[0]
    order = np.argsort(times, kind="stable")
    rec = Recording(times=np.array(times)[order] - t0, points=np.array(frames)[order])
    if gripper_topic:
        if not gt:
            raise FitError(f"{path}: no messages on '{gripper_topic}'")
        o = np.argsort(gt, kind="stable")
        rec.gripper = (np.array(gt)[o] - t0, np.array(gp)[o], np.array(gq)[o])
    rec.check(f"{path}:{points_topic}")
    return rec


def _points_of_message(msg, path, topic):
    t = msg._type
    if t == "geometry_msgs/PoseArray":
        return [[p.position.x, p.position.y, p.position.z] for p in msg.poses]
    if t == "sensor_msgs/PointCloud2":
        from sensor_msgs import point_cloud2
        return [list(p) for p in point_cloud2.read_points(msg, field_names=("x", "y", "z"))]
    raise FitError(f"{path}: '{topic}' has {t}; tracked points must be geometry_msgs/PoseArray "
                   f"or sensor_msgs/PointCloud2")


def write_bag_recording(path: str, rec: Recording, points_topic: str = "/cable/points",
                        gripper_topic: str = "/gripper/pose", frame_id: str = "world",
                        start: float = 1.0) -> None:
    """Writes a recording as a rosbag in the format read_bag_recording reads (PoseArray points,
    PoseStamped gripper), stamped from `start` s (a bag cannot hold time 0)."""
    import rosbag
    import rospy
    from geometry_msgs.msg import Pose, PoseArray, PoseStamped

    with rosbag.Bag(path, "w") as bag:
        events = [(t, 0, i) for i, t in enumerate(rec.times)]
        if rec.gripper is not None:
            events += [(t, 1, i) for i, t in enumerate(rec.gripper[0])]
        for t, kind, i in sorted(events):
            stamp = rospy.Time.from_sec(start + t)
            if kind == 0:
                msg = PoseArray()
                msg.header.stamp, msg.header.frame_id = stamp, frame_id
                for x in rec.points[i]:
                    p = Pose()
                    p.position.x, p.position.y, p.position.z = map(float, x)
                    p.orientation.w = 1.0
                    msg.poses.append(p)
                bag.write(points_topic, msg, stamp)
            else:
                msg = PoseStamped()
                msg.header.stamp, msg.header.frame_id = stamp, frame_id
                x, q = rec.gripper[1][i], rec.gripper[2][i]
                msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = map(float, x)
                (msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z,
                 msg.pose.orientation.w) = map(float, q)
                bag.write(gripper_topic, msg, stamp)


def read_recording(path: str, points_topic: str = "/cable/points",
                   gripper_topic: Optional[str] = None) -> Recording:
    if path.endswith(".bag"):
        return read_bag_recording(path, points_topic, gripper_topic)
    if gripper_topic:
        raise FitError(f"{path}: a CSV recording has no gripper poses; the scene's grasp "
                       f"keyframes give the motion (use a rosbag for recorded poses)")
    return read_csv_recording(path)


# ---------------------------------------------------------------------------------------------
# Scenes: YAML, overrides, keys
# ---------------------------------------------------------------------------------------------


class _Loader(yaml.SafeLoader):
    """YAML as the scene reader (yaml-cpp) reads it: 1.0e7 and 3e-5 are numbers (YAML 1.1, and
    so PyYAML's safe_load, makes them strings unless the exponent has a sign)."""


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*\.[0-9_]*|\.[0-9_]+|[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)$"),
    list("-+0123456789."))


def yaml_load(text):
    return yaml.load(text, Loader=_Loader)


def load_scene_yaml(path: str) -> dict:
    try:
        with open(path) as f:
            doc = yaml_load(f)
    except OSError as e:
        raise FitError(f"{path}: {e.strerror}") from None
    except yaml.YAMLError as e:
        raise FitError(f"{path}: not YAML: {e}") from None
    if not isinstance(doc, dict) or "rods" not in doc:
        raise FitError(f"{path}: not a scene (no 'rods')")
    return doc


def _key_parts(key: str) -> List[str]:
    return [p for p in re.split(r"[.\[\]]+", key) if p != ""]


def _child(node, part: str, key: str, create: bool):
    if isinstance(node, list):
        if re.fullmatch(r"\d+", part):
            i = int(part)
            if i >= len(node):
                raise FitError(f"{key}: index {i} beyond the list of {len(node)}")
            return node, i
        for i, item in enumerate(node):
            if isinstance(item, dict) and item.get("name") == part:
                return node, i
        if part.startswith("rod") and re.fullmatch(r"rod\d+", part):
            i = int(part[3:])  # default names rod<i>
            if i < len(node):
                return node, i
        raise FitError(f"{key}: no item named '{part}'")
    if isinstance(node, dict):
        if part not in node:
            if not create:
                raise FitError(f"{key}: no key '{part}'")
            node[part] = {}
        return node, part
    raise FitError(f"{key}: '{part}' is below a value, not a map or list")


def get_key(doc: dict, key: str):
    """The value at an override key path in a scene document, or None when it is absent."""
    node = doc
    for part in _key_parts(key):
        try:
            parent, k = _child(node, part, key, create=False)
        except FitError:
            return None
        node = parent[k]
        if isinstance(node, str) and part == "material":
            node = {"preset": node}
    return node


def set_key(doc: dict, key: str, value) -> None:
    """Sets an override key path in a scene document (a material given by preset name becomes
    {preset: name}, missing maps are created), as the scene reader's overrides do."""
    parts = _key_parts(key)
    node = doc
    for j, part in enumerate(parts):
        parent, k = _child(node, part, key, create=True)
        if j == len(parts) - 1:
            parent[k] = value
            return
        if isinstance(parent[k], str) and part == "material":
            parent[k] = {"preset": parent[k]}
        if parent[k] is None:
            parent[k] = {}
        node = parent[k]


def _yaml_value(v) -> str:
    if isinstance(v, float):
        return repr(v)
    return yaml.safe_dump(v, default_flow_style=True, width=1 << 30).strip().removesuffix("...").strip()


# ---------------------------------------------------------------------------------------------
# Simulation backends: node positions of one rod at the recorded times
# ---------------------------------------------------------------------------------------------


@dataclass
class Job:
    """One simulation: the scene, its overrides (key -> value), which rod, which times."""

    scene: str
    overrides: Dict[str, object]
    rod: str
    times: np.ndarray
    backend: str = "auto"  # "api" (corde_sim module), "cli" (corde_run), "auto"
    corde_run: Optional[str] = None
    want_frames: bool = False
    statics: bool = False  # each time: the static equilibrium with the drives at that time


def find_corde_run(given: Optional[str] = None) -> str:
    cands = [given] if given else []
    cands += [os.environ.get("CORDE_RUN", "")]
    here = os.path.dirname(os.path.abspath(__file__))
    for up in ("../../build", "../../../build", "../../../../lib/corde_sim", "../../../lib/corde_sim"):
        cands.append(os.path.join(here, up, "corde_run"))
    cands.append(shutil.which("corde_run") or "")
    for c in cands:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return os.path.abspath(c)
    raise FitError("corde_run not found: build the package (make build), or give --corde-run PATH "
                   "or the environment variable CORDE_RUN")


def _api_available() -> bool:
    try:
        import corde_sim  # noqa: F401
        return hasattr(corde_sim, "load")
    except Exception:
        return False


def simulate(job: Job):
    """Runs a job; returns (node positions (F, N+1, 3) at job.times, segment quaternions
    (F, N, 4) or None). Raises FitError with the library's message when the run fails."""
    backend = job.backend
    if backend == "auto":
        backend = "api" if _api_available() else "cli"
    if job.statics:
        if backend != "api":
            raise FitError("a statics fit needs the Python module corde_sim (build it with "
                           "pybind11-dev installed)")
        return _statics_api(job)
    if backend == "api":
        return _simulate_api(job)
    return _simulate_cli(job)


def _statics_api(job: Job):
    import corde_sim

    try:
        sim = corde_sim.load(job.scene, overrides=dict(job.overrides))
    except Exception as e:
        raise FitError(f"{job.scene}: {e}") from None
    rod = int(job.rod) if str(job.rod).isdigit() else job.rod
    out, quats = [], []
    for t in job.times:
        try:
            sim.statics(time=float(t))
        except Exception as e:
            raise FitError(f"{job.scene}: statics at t = {t:g} s: {e}") from None
        out.append(np.array(sim.positions(rod)))
        if job.want_frames:
            quats.append(np.asarray(sim.frames(rod))[:, [1, 2, 3, 0]])
    return np.array(out), (np.array(quats) if job.want_frames else None)


def _interp_frames(src_t, src, times):
    """Linear interpolation in time of src (T, ...) at times (in [src_t[0], src_t[-1]])."""
    idx = np.clip(np.searchsorted(src_t, times, side="right") - 1, 0, len(src_t) - 2)
    t0, t1 = src_t[idx], src_t[idx + 1]
    w = np.where(t1 > t0, (times - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0)
    w = np.clip(w, 0.0, 1.0).reshape((-1,) + (1,) * (src.ndim - 1))
    return src[idx] * (1 - w) + src[idx + 1] * w


def _simulate_api(job: Job):
    import corde_sim

    try:
        sim = corde_sim.load(job.scene, overrides=dict(job.overrides))
    except Exception as e:
        raise FitError(f"{job.scene}: {e}") from None
    rod = int(job.rod) if str(job.rod).isdigit() else job.rod
    try:
        x = np.array(sim.positions(rod))
    except Exception as e:
        raise FitError(f"{job.scene}: rod '{job.rod}': {e}") from None
    out = np.empty((len(job.times),) + x.shape)
    quats = [] if job.want_frames else None
    prev_t, prev = sim.time, x
    for k, t in enumerate(job.times):
        cur_t, cur = sim.time, np.array(sim.positions(rod))
        while cur_t < t - 1e-12:
            prev_t, prev = cur_t, cur
            try:
                sim.step(1)
            except Exception as e:
                raise FitError(f"{job.scene}: run failed at t = {sim.time:g} s: {e}") from None
            cur_t, cur = sim.time, np.array(sim.positions(rod))
        if cur_t <= t + 1e-12 or cur_t <= prev_t:
            out[k] = cur
        else:  # between two steps: linear in time
            out[k] = prev + (t - prev_t) / (cur_t - prev_t) * (cur - prev)
        if job.want_frames:  # rows w, x, y, z -> x, y, z, w
            quats.append(np.asarray(sim.frames(rod))[:, [1, 2, 3, 0]])
    if not np.all(np.isfinite(out)):
        raise FitError(f"{job.scene}: the run produced non-finite positions")
    return out, (np.array(quats) if quats is not None else None)


def _simulate_cli(job: Job):
    exe = find_corde_run(job.corde_run)
    duration = float(job.times[-1])
    if duration <= 0:  # the start only: one step (corde_run writes the start frame first)
        step = job.overrides.get("time_step", load_scene_yaml(job.scene).get("time_step"))
        duration = float(step) if _is_number(step) else 1e-3
    with tempfile.TemporaryDirectory(prefix="corde_fit_") as tmp:
        out = os.path.join(tmp, "run.csv")
        args = [exe, job.scene, "--quiet", "--out", out, "--every", "1",
                "--duration", repr(duration)]
        for k, v in job.overrides.items():
            args += ["--set", f"{k}={v if isinstance(v, str) else _yaml_value(v)}"]
        p = subprocess.run(args, capture_output=True, text=True)
        if p.returncode != 0:
            msg = (p.stderr.strip() or p.stdout.strip()).splitlines()
            raise FitError(f"corde_run failed (status {p.returncode}): "
                           f"{msg[-1] if msg else 'no message'}")
        t, nodes, quats = _read_run_csv(out, job.rod, job.want_frames)
    pos = _interp_frames(t, nodes, np.asarray(job.times, float))
    q = None
    if job.want_frames:
        idx = np.clip(np.searchsorted(t, job.times - 1e-12), 0, len(t) - 1)
        q = quats[idx]
    return pos, q


def _is_number(v) -> bool:
    try:
        return math.isfinite(float(v)) and float(v) > 0
    except (TypeError, ValueError):
        return False


def _read_run_csv(path, rod, want_frames):
    with open(path) as f:
        next(f)
        lines = [line.split(",", 2) for line in f]
    rod_names = list(dict.fromkeys(x[1] for x in lines))
    if str(rod).isdigit() and int(rod) < len(rod_names) and str(rod) not in rod_names:
        rod = rod_names[int(rod)]
    times = [x[0] for x in lines if x[1] == rod]
    rows = [x[2] for x in lines if x[1] == rod]
    if not rows:
        raise FitError(f"no rod named '{rod}' in the run (rods: {', '.join(rod_names)})")
    data = np.loadtxt(rows, delimiter=",").reshape(len(rows), -1)
    t = np.array(times, float)
    seg = data[:, 0].astype(int)
    n = int(seg.max()) + 1
    nf = len(rows) // n
    data = data[: nf * n].reshape(nf, n, -1)
    t = t[: nf * n : n]
    nodes = np.concatenate([data[:, :, 1:4], data[:, -1:, 4:7]], axis=1)
    # a run writes its last frame twice when it ends on a frame: keep strictly increasing times
    keep = np.concatenate([[True], np.diff(t) > 0])
    return t[keep], nodes[keep], (data[keep][:, :, 7:11] if want_frames else None)


# ---------------------------------------------------------------------------------------------
# Tracked points on the simulated rod
# ---------------------------------------------------------------------------------------------


def node_arc_lengths(nodes0: np.ndarray) -> np.ndarray:
    """Arc lengths of the nodes along the rod as it starts (N+1,)."""
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(nodes0, axis=0), axis=1))])


def markers(nodes: np.ndarray, s_nodes: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Points at arc lengths s on the rods (F, N+1, 3) -> (F, M, 3): a cubic spline through the
    nodes in arc length (the rod's centreline between nodes, not its chords)."""
    from scipy.interpolate import CubicSpline

    f, n1, _ = nodes.shape
    y = np.transpose(nodes, (1, 0, 2)).reshape(n1, f * 3)
    cs = CubicSpline(s_nodes, y, axis=0, bc_type="not-a-knot" if n1 > 3 else "natural")
    return np.transpose(cs(np.clip(s, s_nodes[0], s_nodes[-1])).reshape(len(s), f, 3), (1, 0, 2))


def project_arc_lengths(points0: np.ndarray, nodes0: np.ndarray) -> np.ndarray:
    """Arc lengths of points (M, 3) projected onto the rod's centreline (N+1, 3)."""
    s_nodes = node_arc_lengths(nodes0)
    s_fine = np.linspace(0, s_nodes[-1], 40 * (len(nodes0) - 1) + 1)
    curve = markers(nodes0[None], s_nodes, s_fine)[0]
    d = np.linalg.norm(points0[:, None, :] - curve[None, :, :], axis=2)
    return s_fine[np.argmin(d, axis=1)]


def synthesize(scene: str, overrides: Dict[str, object], rod: str, times: np.ndarray,
               arc_lengths: np.ndarray, noise: float, seed: int, backend: str = "auto",
               corde_run: Optional[str] = None, gripper_segment: Optional[int] = None,
               statics: bool = False) -> Recording:
    """A synthetic recording: the scene run with the given overrides, the points at the given arc
    lengths, plus Gaussian noise of `noise` m per coordinate (seeded). With gripper_segment, the
    gripper's poses are that segment's midpoint and frame at the same times. statics: the cable
    at rest at each time (the static equilibrium with the drives and grasps then)."""
    nodes, quats = simulate(Job(scene, overrides, rod, np.asarray(times, float), backend, corde_run,
                                want_frames=gripper_segment is not None, statics=statics))
    s_nodes = node_arc_lengths(nodes[0])
    pts = markers(nodes, s_nodes, np.asarray(arc_lengths, float))
    rng = np.random.default_rng(seed)
    pts = pts + rng.normal(0.0, noise, pts.shape)
    rec = Recording(np.asarray(times, float), pts, np.asarray(arc_lengths, float))
    if gripper_segment is not None:
        g = gripper_segment
        mid = 0.5 * (nodes[:, g] + nodes[:, g + 1])
        rec.gripper = (np.asarray(times, float), mid, quats[:, g])
    return rec


# ---------------------------------------------------------------------------------------------
# Gripper poses -> grasp keyframes
# ---------------------------------------------------------------------------------------------


def grasp_segment(doc: dict, grasp: str) -> tuple:
    """(rod name or index, segment index) held by the named grasp of a scene document."""
    grasps = doc.get("grasps") or []
    for g in grasps:
        if isinstance(g, dict) and g.get("name") == grasp:
            break
    else:
        names = [g.get("name") for g in grasps if isinstance(g, dict)]
        raise FitError(f"grasps: no grasp named '{grasp}' (grasps: {', '.join(map(str, names))})")
    rods = doc["rods"]
    rod = g.get("rod", rods[0].get("name", "rod0") if len(rods) == 1 else None)
    if rod is None:
        raise FitError(f"grasps.{grasp}.rod: required with several rods")
    r = next((x for x in rods if x.get("name", None) == rod), rods[0])
    n = r.get("elements", 50)
    if not isinstance(n, int):
        raise FitError(f"rods.{rod}.elements: must be a number for a fit with recorded gripper "
                       f"poses, got {n}")
    place = g.get("place", "end")
    if place == "start":
        seg = 0
    elif place == "end":
        seg = n - 1
    elif place == "node":
        seg = min(int(g["value"]), n - 1)
    else:
        raise FitError(f"grasps.{grasp}.place: {place}: give the grasp by start, end or node "
                       f"for recorded gripper poses")
    return rod, seg


def gripper_keyframes(gripper: tuple, holder0_pos: np.ndarray, holder0_quat: np.ndarray,
                      rate: float = 50.0) -> List[dict]:
    """Keyframes (world poses) of a grasp holder rigidly attached to the recorded gripper: the
    holder keeps the pose relative to the gripper it has at the first gripper pose, H(t) =
    T(t) T(0)^-1 H(0). Poses are taken at most `rate` per second, after time 0."""
    from scipy.spatial.transform import Rotation as R

    t, p, q = gripper
    r0 = R.from_quat(q[0])
    rel_p = r0.inv().apply(holder0_pos - p[0])
    rel_r = r0.inv() * R.from_quat(holder0_quat)
    keys, last = [], 0.0
    for k in range(len(t)):
        if t[k] <= 1e-9 or (t[k] - last < (1.0 - 1e-6) / rate and k != len(t) - 1):
            continue
        rk = R.from_quat(q[k])
        pos = p[k] + rk.apply(rel_p)
        quat = (rk * rel_r).as_quat()
        keys.append({"time": float(t[k]), "position": [float(v) for v in pos],
                     "orientation": [float(v) for v in quat / np.linalg.norm(quat)]})
        last = t[k]
    return keys


def write_keyframe_csv(path: str, keys: List[dict]) -> None:
    with open(path, "w") as f:
        f.write("# grasp holder poses from the recorded gripper (corde_fit)\n")
        f.write("time,x,y,z,qx,qy,qz,qw\n")
        for k in keys:
            f.write(",".join(f"{v:.12g}" for v in [k["time"]] + k["position"] + k["orientation"])
                    + "\n")


# ---------------------------------------------------------------------------------------------
# Executors: where the runs of one Jacobian go
# ---------------------------------------------------------------------------------------------


class SerialExecutor:
    workers = 1

    def map(self, fn, items):
        return [fn(x) for x in items]

    def close(self):
        pass


class DaskExecutor:
    """Runs the simulations of one iteration on a Dask cluster: a LocalCluster of `workers`
    processes, or the scheduler at `address`."""

    def __init__(self, workers: int = 0, address: Optional[str] = None):
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise FitError("--workers/--scheduler need Dask (apt-get install python3-distributed)")
        self.cluster = None
        if address:
            self.client = Client(address)
        else:
            self.cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1,
                                        threads_per_worker=1, processes=True,
                                        dashboard_address=None)
            self.client = Client(self.cluster)
        self.workers = len(self.client.scheduler_info().get("workers", {})) or workers

    def map(self, fn, items):
        futures = self.client.map(fn, items, pure=False)
        return self.client.gather(futures)

    def close(self):
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def make_executor(workers: int = 0, scheduler: Optional[str] = None):
    if scheduler or workers > 1:
        return DaskExecutor(workers, scheduler)
    return SerialExecutor()


# ---------------------------------------------------------------------------------------------
# The fit
# ---------------------------------------------------------------------------------------------


@dataclass
class FitResult:
    names: List[str]
    keys: List[str]
    values: Dict[str, float]
    ci: Dict[str, tuple]  # name -> (low, high), the confidence interval
    undetermined: Dict[str, str]  # name -> why (the value stays at its start)
    initial: Dict[str, float]
    confidence: float
    rms: float  # m, per coordinate
    frame_rms: np.ndarray  # m, RMS distance of the tracked points per frame
    times: np.ndarray
    singular_values: np.ndarray
    correlation: np.ndarray
    runs: int
    iterations: int
    wall_time: float
    workers: int
    sigma: float  # m, the noise estimated from the residuals
    arc_lengths: np.ndarray
    message: str = ""
    overrides: Dict[str, object] = field(default_factory=dict)


def _marker_job(args):
    job, s = args
    nodes, _ = simulate(job)
    return markers(nodes, node_arc_lengths(nodes[0]), s)


class Problem:
    """The residual function of a fit: log-parameters -> (simulated - tracked) / scale."""

    def __init__(self, scene, rec: Recording, params: List[Parameter], rod: str,
                 overrides: Dict[str, object], backend="auto", corde_run=None, executor=None,
                 scale=1e-3, diff_step=1e-3, statics=False):
        self.scene, self.rec, self.params, self.rod = scene, rec, params, rod
        self.statics = statics
        self.fixed = dict(overrides)
        self.backend, self.corde_run = backend, corde_run
        self.executor = executor or SerialExecutor()
        self.scale, self.h = scale, diff_step
        self.runs = 0
        self.s = rec.arc_lengths
        self._cache = {}

    def job(self, theta) -> Job:
        ov = dict(self.fixed)
        for p, th in zip(self.params, theta):
            ov[p.key] = float(np.exp(th))
        return Job(self.scene, ov, self.rod, self.rec.times, self.backend, self.corde_run,
                   statics=self.statics)

    def _residuals_of(self, pts):
        return ((pts - self.rec.points) / self.scale).reshape(-1)

    def residuals_many(self, thetas):
        todo = [t for t in thetas if tuple(t) not in self._cache]
        if todo:
            results = self.executor.map(_marker_job, [(self.job(t), self.s) for t in todo])
            self.runs += len(todo)
            for t, pts in zip(todo, results):
                self._cache[tuple(t)] = self._residuals_of(pts)
        return [self._cache[tuple(t)] for t in thetas]

    def residuals(self, theta):
        return self.residuals_many([np.asarray(theta, float)])[0]

    def jacobian(self, theta):
        theta = np.asarray(theta, float)
        pts = [theta.copy()]
        for j in range(len(theta)):
            t = theta.copy()
            t[j] += self.h
            pts.append(t)
        r = self.residuals_many(pts)
        return np.stack([(r[j + 1] - r[0]) / self.h for j in range(len(theta))], axis=1)


def _covariance(J, r, dof):
    s2 = float(r @ r) / max(dof, 1)
    u, sv, vt = np.linalg.svd(J, full_matrices=False)
    tiny = sv <= sv[0] * 1e-12 if len(sv) and sv[0] > 0 else np.ones_like(sv, bool)
    inv = np.where(tiny, 0.0, 1.0 / np.where(tiny, 1.0, sv) ** 2)
    cov = (vt.T * inv) @ vt * s2
    for j in range(J.shape[1]):  # a direction J cannot see has an infinite variance
        if np.any(tiny & (np.abs(vt[:, j]) > 1e-6)):
            cov[j, j] = np.inf
    return cov, sv, s2


def fit(scene: str, rec: Recording, params: List[Parameter], rod: str = "0",
        overrides: Optional[Dict[str, object]] = None, backend: str = "auto",
        corde_run: Optional[str] = None, executor=None, confidence: float = 0.95,
        max_ci_factor: float = 2.0, max_iterations: int = 30, diff_step: float = 1e-3,
        log: Callable[[str], None] = lambda s: None, statics: bool = False) -> FitResult:
    """Fits params to the recording (arc lengths given, or projected onto the rod at the first
    frame with the starting parameters). statics: every frame is the cable at rest, compared
    with the static equilibrium at its time (the drives and grasps where they are then), not
    with a run. Parameters whose confidence interval spans more than a
    factor max_ci_factor either way (or that the residuals do not depend on) are refused as
    undetermined and kept at their starting value; the others are fitted again without them."""
    from scipy import optimize, stats

    t_start = _time.perf_counter()
    overrides = dict(overrides or {})
    if not params:
        raise FitError("nothing to fit: give at least one parameter")
    for p in params:
        if not (p.initial > 0 and math.isfinite(p.initial)):
            raise FitError(f"{p.name}: the starting value must be > 0 (fitted in log space), "
                           f"got {p.initial}")
    executor = executor or SerialExecutor()
    rec = copy.copy(rec)
    if rec.arc_lengths is None:
        nodes, _ = simulate(Job(scene, {**overrides, **{p.key: p.initial for p in params}}, rod,
                                np.array([rec.times[0]]), backend, corde_run, statics=statics))
        rec.arc_lengths = project_arc_lengths(rec.points[0], nodes[0])
        log("arc lengths projected onto the rod at the first frame: "
            + ", ".join(f"{s:.4f}" for s in rec.arc_lengths) + " m")
    active = list(params)
    undetermined: Dict[str, str] = {}
    runs = iterations = 0
    values = {p.name: p.initial for p in params}
    while True:
        prob = Problem(scene, rec, active, rod,
                       {**overrides, **{p.key: p.initial for p in params if p not in active}},
                       backend, corde_run, executor, diff_step=diff_step, statics=statics)
        x0 = np.log([values[p.name] for p in active])
        # parameters the recording does not depend on at all: refused before fitting
        J0 = prob.jacobian(x0)
        norms = np.linalg.norm(J0, axis=0)
        dead = [p for p, nrm in zip(active, norms) if nrm <= 1e-6 * max(norms.max(), 1e-300)]
        for p in dead:
            undetermined[p.name] = ("the recording does not depend on it (the simulated points "
                                    "do not move when it changes): nothing in the motion "
                                    "excites it")
        active = [p for p in active if p not in dead]
        if dead:
            runs += prob.runs
            if not active:
                break
            continue
        res = optimize.least_squares(prob.residuals, x0, jac=prob.jacobian, method="trf",
                                     x_scale=1.0, max_nfev=max_iterations,
                                     bounds=(x0 - math.log(1e3), x0 + math.log(1e3)),
                                     ftol=1e-8, xtol=1e-8, gtol=1e-8)
        iterations += res.nfev
        theta = res.x
        r = prob.residuals(theta)
        J = prob.jacobian(theta)
        runs += prob.runs
        dof = len(r) - len(active)
        cov, sv, s2 = _covariance(J, r, dof)
        tq = stats.t.ppf(0.5 + confidence / 2, max(dof, 1))
        half = tq * np.sqrt(np.diag(cov))
        for p, th in zip(active, theta):
            values[p.name] = float(np.exp(th))
        bad = [j for j in range(len(active)) if not (half[j] <= math.log(max_ci_factor))]
        if not bad:
            break
        # refuse the worst one, fit again without it
        j = max(bad, key=lambda k: half[k])
        p = active[j]
        sd = np.sqrt(np.diag(cov))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.outer(sd, sd)
        partner = ""
        if np.isfinite(half[j]):
            c = [(abs(corr[j, k]), active[k].name) for k in range(len(active)) if k != j]
            c = [x for x in c if np.isfinite(x[0])]
            if c and max(c)[0] > 0.9:
                partner = (f"; it trades off against {max(c)[1]} (correlation "
                           f"{max(c)[0]:.3f}): the recording sees only their combination")
        span = (f"a factor {math.exp(half[j]):.3g}" if half[j] < math.log(1e6) else
                "more than a factor 1e6")
        undetermined[p.name] = (f"its {confidence:.0%} interval would span {span} either way "
                                f"(limit {max_ci_factor:g}){partner}")
        values[p.name] = p.initial
        active = [q for q in active if q is not p]
        if not active:
            break
    names = [p.name for p in params]
    ci, frame_rms, rms, sigma, corr_full = {}, np.zeros(len(rec.times)), float("nan"), float("nan"), None
    sv_out = np.array([])
    if active:
        for k, p in enumerate(active):
            ci[p.name] = (float(np.exp(theta[k] - half[k])), float(np.exp(theta[k] + half[k])))
        d = (r * prob.scale).reshape(len(rec.times), -1, 3)
        frame_rms = np.sqrt(np.mean(np.sum(d * d, axis=2), axis=1))
        rms = float(np.sqrt(np.mean(d * d)))
        sigma = float(math.sqrt(s2) * prob.scale)
        sd = np.sqrt(np.diag(cov))
        corr_full = cov / np.outer(sd, sd)
        sv_out = sv
    final = {**overrides, **{p.key: values[p.name] for p in params}}
    return FitResult(
        names=names, keys=[p.key for p in params], values=values, ci=ci,
        undetermined=undetermined, initial={p.name: p.initial for p in params},
        confidence=confidence, rms=rms, frame_rms=frame_rms, times=rec.times,
        singular_values=sv_out, correlation=corr_full if corr_full is not None else np.zeros((0, 0)),
        runs=runs, iterations=iterations, wall_time=_time.perf_counter() - t_start,
        workers=getattr(executor, "workers", 1), sigma=sigma, arc_lengths=rec.arc_lengths,
        overrides=final)


# ---------------------------------------------------------------------------------------------
# Output
# ---------------------------------------------------------------------------------------------


def report_text(res: FitResult, params: List[Parameter]) -> str:
    lines = ["parameter         fitted        %d%% interval                 start" %
             round(100 * res.confidence)]
    for p in params:
        if p.name in res.undetermined:
            lines.append(f"{p.name:<16}  undetermined  (kept at {p.initial:.6g}): "
                         f"{res.undetermined[p.name]}")
        else:
            lo, hi = res.ci[p.name]
            lines.append(f"{p.name:<16}  {res.values[p.name]:<12.6g}  [{lo:.6g}, {hi:.6g}]"
                         f"{'':<4}{p.initial:.6g}")
    if res.ci:
        lines.append(f"residual          RMS {res.rms * 1e3:.4g} mm per coordinate (noise estimate "
                     f"{res.sigma * 1e3:.4g} mm), per frame {np.min(res.frame_rms) * 1e3:.3g} to "
                     f"{np.max(res.frame_rms) * 1e3:.3g} mm (RMS distance of the points)")
    lines.append(f"cost              {res.runs} runs, {res.iterations} evaluations, "
                 f"{res.wall_time:.2f} s wall on {res.workers} worker(s)")
    return "\n".join(lines)


def write_residuals_csv(path: str, res: FitResult) -> None:
    with open(path, "w") as f:
        f.write("time,rms_mm\n")
        for t, e in zip(res.times, res.frame_rms):
            f.write(f"{t:.9g},{e * 1e3:.6g}\n")


def write_fitted_scene(scene_path: str, out_path: str, res: FitResult,
                       extra: Optional[Dict[str, object]] = None) -> None:
    """The scene with the fitted (and fixed) keys set inline, plus `extra` keys."""
    doc = load_scene_yaml(scene_path)
    for k, v in {**res.overrides, **(extra or {})}.items():
        set_key(doc, k, v)
    head = ["# written by corde_fit from " + os.path.basename(scene_path)]
    for n in res.names:
        if n in res.undetermined:
            head.append(f"# {n}: undetermined by the recording, kept at {res.values[n]:.6g}")
        else:
            lo, hi = res.ci[n]
            head.append(f"# {n} = {res.values[n]:.6g}, {res.confidence:.0%} interval "
                        f"[{lo:.6g}, {hi:.6g}]")
    with open(out_path, "w") as f:
        f.write("\n".join(head) + "\n")
        yaml.safe_dump(doc, f, sort_keys=False, default_flow_style=None, width=100)


def material_file_data(scene_path: str, res: FitResult, rod: str, recording: str = "",
                       name: Optional[str] = None) -> dict:
    """The fitted rod's material as a material file (docs/scene_format.md, "Material files"):
    version 1, the material map's keys with the fitted values, radius, drag, the rod's contact
    friction, and under `fit` how they were found. Raises FitError for a material given by
    preset (a material file holds absolute values, not a preset's)."""
    doc = load_scene_yaml(scene_path)
    for k, v in res.overrides.items():
        set_key(doc, k, v)
    r = get_key(doc, f"rods.{rod}")
    if not isinstance(r, dict):
        raise FitError(f"rods.{rod}: no such rod")
    mat = get_key(doc, f"rods.{rod}.material")
    if not isinstance(mat, dict) or "preset" in mat or "file" in mat:
        raise FitError(f"rods.{rod}.material: a material file needs the material's values "
                       f"(not a preset or a file); give them in the scene's material map")
    name = name or os.path.splitext(os.path.basename(scene_path))[0] + "_fitted"
    out = {"version": 1, "name": name,
           "description": f"fitted by corde_fit to {os.path.basename(recording) or 'a recording'}"}
    if "radius" in r:
        out["radius"] = r["radius"]
    out.update({k: v for k, v in mat.items()})
    if isinstance(r.get("drag"), dict):
        out["drag"] = r["drag"]
    if isinstance(r.get("contact"), dict) and "friction" in r["contact"]:
        out["friction"] = r["contact"]["friction"]
    fitrec = {"recording": os.path.basename(recording), "scene": os.path.basename(scene_path),
              "confidence": res.confidence, "rms_residual_m": res.rms,
              "parameters": {}}
    for n, key in zip(res.names, res.keys):
        if n in res.undetermined:
            fitrec["parameters"][n] = {"key": key, "value": res.values[n],
                                       "undetermined": res.undetermined[n]}
        else:
            fitrec["parameters"][n] = {"key": key, "value": res.values[n],
                                       "interval": list(res.ci[n])}
    out["fit"] = fitrec
    return out


def write_material_file(path: str, data: dict) -> None:
    with open(path, "w") as f:
        f.write("# material file written by corde_fit (docs/scene_format.md, Material files)\n")
        yaml.safe_dump(data, f, sort_keys=False, default_flow_style=None, width=100)


# ---------------------------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------------------------

USAGE_EPILOG = """
examples:
  corde_fit cable.yaml recording.csv --fit E,G,damping_time,drag --out cable_fitted.yaml
  corde_fit cable.yaml run.bag --points-topic /cable/points --gripper-topic /gripper/pose \\
            --grasp gripper --fit E,damping_time --workers 2
  corde_fit record cable.yaml recording.csv --points 15 --noise 0.001 --every 0.05

parameters (--fit): %s, or NAME=key.path for any scene key
""" % ", ".join(PARAMETERS)


def _parse_kv(items, what):
    out = {}
    for it in items or []:
        if "=" not in it:
            raise FitError(f"{what} needs NAME=VALUE, got '{it}'")
        k, v = it.split("=", 1)
        out[k.strip()] = v.strip()
    return out


def _scene_rod(doc, rod):
    rods = doc["rods"]
    if rod is None:
        return rods[0].get("name", "0") if isinstance(rods[0], dict) else "0"
    return rod


def build_parameters(doc, names: Sequence[str], rod: str, obstacle: str,
                     initial: Dict[str, str]) -> List[Parameter]:
    params = []
    for spec in names:
        spec = spec.strip()
        if not spec:
            continue
        if "=" in spec:
            name, key = spec.split("=", 1)
        elif spec in PARAMETERS:
            name, key = spec, PARAMETERS[spec][0]
        else:
            raise FitError(f"--fit: unknown parameter '{spec}' (known: {', '.join(PARAMETERS)}; "
                           f"or NAME=key.path)")
        key = key.format(rod=rod, obstacle=obstacle)
        if name in initial:
            try:
                v = float(initial[name])
            except ValueError:
                raise FitError(f"--initial {name}: not a number: '{initial[name]}'") from None
        else:
            v = get_key(doc, key)
            if isinstance(v, str):
                try:
                    v = float(v)
                except ValueError:
                    v = None
            if not isinstance(v, (int, float)) or isinstance(v, bool):
                raise FitError(f"{name}: the scene has no value at {key} to start from; give "
                               f"--initial {name}=VALUE")
        params.append(Parameter(name, key, float(v)))
    return params


def _check_fixed_step(doc, overrides, scene):
    step = overrides.get("time_step", doc.get("time_step", "auto"))
    integ = overrides.get("integrator", doc.get("integrator", "split_rotation"))
    if str(step).strip() == "auto":
        raise FitError(f"{scene}: time_step: auto changes with the material (the step follows "
                       f"the stiffness), which would make the fit jump; give a number in the "
                       f"scene or --set time_step=H")
    if str(integ).strip() == "auto":
        raise FitError(f"{scene}: integrator: auto may change with the material; name the "
                       f"integrator in the scene or with --set integrator=NAME")


def _overrides_of(items):
    out = {}
    for k, v in _parse_kv(items, "--set").items():
        out[k] = v
    return out


def main_record(argv) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="corde_fit record",
                                 description="Writes a synthetic recording of a scene: tracked "
                                             "points (and the grasp's poses) with noise.")
    ap.add_argument("scene")
    ap.add_argument("out", help="recording to write (.csv or .bag)")
    ap.add_argument("--rod", default=None)
    ap.add_argument("--points", type=int, default=15, help="tracked points (evenly spaced)")
    ap.add_argument("--noise", type=float, default=1e-3, help="tracking noise (m, 1 sigma)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--every", type=float, default=0.05, help="frame interval (s)")
    ap.add_argument("--duration", type=float, default=None)
    ap.add_argument("--grasp", default=None, help="record this grasp's poses (a .bag only)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--statics", action="store_true",
                    help="each frame the static equilibrium at its time (a cable at rest)")
    ap.add_argument("--corde-run", default=None)
    a = ap.parse_args(argv)
    doc = load_scene_yaml(a.scene)
    ov = _overrides_of(a.set)
    rod = _scene_rod(doc, a.rod)
    dur = a.duration if a.duration is not None else float(ov.get("duration", doc.get("duration", 1.0)))
    times = np.arange(0.0, dur + 1e-9, a.every)
    length = _rod_length(a.scene, ov, rod, a.corde_run)
    s = np.linspace(0.0, length, a.points + 2)[1:-1] if a.points > 1 else np.array([length / 2])
    seg = grasp_segment(doc, a.grasp)[1] if a.grasp else None
    rec = synthesize(a.scene, ov, rod, times, s, a.noise, a.seed, corde_run=a.corde_run,
                     gripper_segment=seg, statics=a.statics)
    if a.out.endswith(".bag"):
        write_bag_recording(a.out, rec)
    else:
        if a.grasp:
            raise FitError("--grasp: gripper poses go into a .bag recording only")
        write_csv_recording(a.out, rec)
    print(f"corde_fit record: {len(times)} frames of {len(s)} points ({a.noise * 1e3:g} mm "
          f"noise, seed {a.seed}) -> {a.out}")
    return 0


def _rod_length(scene, ov, rod, corde_run):
    nodes, _ = simulate(Job(scene, ov, rod, np.array([0.0]), corde_run=corde_run))
    return float(node_arc_lengths(nodes[0])[-1])


def main(argv=None) -> int:
    import argparse

    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        if argv and argv[0] == "record":
            return main_record(argv[1:])
        ap = argparse.ArgumentParser(
            prog="corde_fit", formatter_class=argparse.RawDescriptionHelpFormatter,
            description="Fits a scene's material to a recording of a real cable "
                        "(docs/calibration.md).", epilog=USAGE_EPILOG)
        ap.add_argument("scene", help="scene of the recorded setup (its rod, clamps, grasp)")
        ap.add_argument("recording", help="tracked points: .csv, or .bag (rosbag)")
        ap.add_argument("--fit", default="E,G,damping_time,drag",
                        help="parameters, comma-separated (default %(default)s)")
        ap.add_argument("--initial", action="append", default=[], metavar="NAME=VALUE",
                        help="starting value (default: the scene's)")
        ap.add_argument("--rod", default=None, help="the recorded rod (default: the first)")
        ap.add_argument("--obstacle", default="0", help="obstacle of the 'friction' parameter")
        ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="scene override for every run (corde_run --set syntax)")
        ap.add_argument("--arc-lengths", default=None,
                        help="arc lengths of the points, comma-separated (m); default: the "
                             "recording's, else projected onto the rod at the first frame")
        ap.add_argument("--points-topic", default="/cable/points")
        ap.add_argument("--gripper-topic", default=None,
                        help="geometry_msgs/PoseStamped topic moving --grasp (a .bag)")
        ap.add_argument("--grasp", default=None, help="grasp moved by the recorded gripper")
        ap.add_argument("--keyframe-rate", type=float, default=50.0,
                        help="gripper poses per second turned into keyframes")
        ap.add_argument("--out", default=None,
                        help="fitted scene to write (default: SCENE_fitted.yaml beside SCENE)")
        ap.add_argument("--residuals", default=None, help="CSV of the residual per frame")
        ap.add_argument("--material-file", default=None,
                        help="also write the fitted material as a material file (e.g. "
                             "materials/my_cable.yaml beside the scene)")
        ap.add_argument("--confidence", type=float, default=0.95)
        ap.add_argument("--max-ci-factor", type=float, default=2.0,
                        help="refuse a parameter whose interval spans more than this factor")
        ap.add_argument("--max-iterations", type=int, default=30)
        ap.add_argument("--statics", action="store_true",
                        help="every frame is the cable at rest: compare with the static "
                             "equilibrium at its time instead of a run")
        ap.add_argument("--workers", type=int, default=0,
                        help="Dask local cluster of this many workers (0 or 1: serial)")
        ap.add_argument("--scheduler", default=None, help="Dask scheduler address")
        ap.add_argument("--backend", choices=["auto", "api", "cli"], default="auto")
        ap.add_argument("--corde-run", default=None)
        ap.add_argument("--quiet", action="store_true")
        a = ap.parse_args(argv)
        return _main_fit(a)
    except FitError as e:
        print(f"corde_fit: {e}", file=sys.stderr)
        return 1


def _main_fit(a) -> int:
    log = (lambda s: None) if a.quiet else (lambda s: print(s, file=sys.stderr))
    doc = load_scene_yaml(a.scene)
    ov = _overrides_of(a.set)
    _check_fixed_step(doc, ov, a.scene)
    rod = _scene_rod(doc, a.rod)
    rec = read_recording(a.recording, a.points_topic, a.gripper_topic)
    if a.arc_lengths:
        try:
            rec.arc_lengths = np.array([float(v) for v in a.arc_lengths.split(",")])
        except ValueError:
            raise FitError(f"--arc-lengths: numbers separated by commas, got '{a.arc_lengths}'")
        rec.check(a.recording)
    out = a.out or os.path.splitext(a.scene)[0] + "_fitted.yaml"
    extra = {}
    workdir = tempfile.mkdtemp(prefix="corde_fit_")
    try:
        if rec.gripper is not None:
            if not a.grasp:
                raise FitError("--gripper-topic needs --grasp NAME (the grasp the gripper moves)")
            grod, seg = grasp_segment(doc, a.grasp)
            nodes, q = simulate(Job(a.scene, ov, str(grod), np.array([0.0]), a.backend,
                                    a.corde_run, want_frames=True))
            keys = gripper_keyframes(rec.gripper, 0.5 * (nodes[0, seg] + nodes[0, seg + 1]),
                                     q[0, seg], a.keyframe_rate)
            if not keys:
                raise FitError(f"{a.recording}: no gripper pose after time 0")
            kf = os.path.join(workdir, "gripper_keyframes.csv")
            write_keyframe_csv(kf, keys)
            ov[f"grasps.{a.grasp}.keyframes"] = f"{{file: {kf}}}"
            out_kf = os.path.splitext(out)[0] + "_gripper.csv"
            write_keyframe_csv(out_kf, keys)
            extra[f"grasps.{a.grasp}.keyframes"] = {"file": os.path.relpath(
                out_kf, os.path.dirname(os.path.abspath(out)))}
            log(f"gripper: {len(keys)} keyframes from {len(rec.gripper[0])} poses -> {out_kf}")
        params = build_parameters(doc, a.fit.split(","), rod, a.obstacle, _parse_kv(a.initial,
                                                                                    "--initial"))
        executor = make_executor(a.workers, a.scheduler)
        try:
            res = fit(a.scene, rec, params, rod, ov, a.backend, a.corde_run, executor,
                      a.confidence, a.max_ci_factor, a.max_iterations, log=log,
                      statics=a.statics)
        finally:
            executor.close()
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    # the fitted scene keeps every --set override except the temporary keyframe file
    res.overrides = {k: (yaml_load(v) if isinstance(v, str) else v)
                     for k, v in res.overrides.items() if k not in extra}
    write_fitted_scene(a.scene, out, res, extra)
    print(report_text(res, params))
    for n, why in res.undetermined.items():
        print(f"corde_fit: {n}: undetermined: {why}", file=sys.stderr)
    if a.residuals:
        write_residuals_csv(a.residuals, res)
    if a.material_file:
        d = os.path.dirname(os.path.abspath(a.material_file))
        os.makedirs(d, exist_ok=True)
        name = os.path.splitext(os.path.basename(a.material_file))[0]
        write_material_file(a.material_file,
                            material_file_data(a.scene, res, rod, a.recording, name))
        print(f"material file     {a.material_file}")
    print(f"fitted scene      {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
