"""Runs for corde_fit: scene files and override keys, the simulation of one rod at the recorded
times (through the Python API or corde_run), and the tracked points on the simulated rod."""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from typing import Dict, List, Optional

import numpy as np
import yaml

from .fit_recording import FitError, Recording


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
    text = yaml.safe_dump(v, default_flow_style=True, width=1 << 30).strip()
    return text.removesuffix("...").strip()


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
    for up in ("../../build", "../../../build", "../../../../lib/corde_sim",
               "../../../lib/corde_sim"):
        cands.append(os.path.join(here, up, "corde_run"))
    cands.append(shutil.which("corde_run") or "")
    for c in cands:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return os.path.abspath(c)
    raise FitError("corde_run not found: build the package (make build), or give --corde-run PATH "
                   "or the environment variable CORDE_RUN")


def _api_available() -> bool:
    """Whether the extension corde_sim._core is built (the package imports without it)."""
    try:
        from corde_sim import _core  # noqa: F401
        return True
    except ImportError:
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


def statics_at_times(job: Job, then=None):
    """Loads job's scene and solves its statics at each of job.times, yielding (sim, rod, what
    then(sim, rod) returned after the solve); errors become FitError naming the scene and time."""
    import corde_sim

    try:
        sim = corde_sim.load(job.scene, overrides=dict(job.overrides))
    except Exception as e:
        raise FitError(str(e)) from None  # the message names the file
    rod = int(job.rod) if str(job.rod).isdigit() else job.rod
    for t in job.times:
        try:
            sim.statics(time=float(t))
            got = then(sim, rod) if then else None
        except Exception as e:
            raise FitError(f"{job.scene}: statics at t = {t:g} s: {e}") from None
        yield sim, rod, got


def _statics_api(job: Job):
    out, quats = [], []
    for sim, rod, _ in statics_at_times(job):
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
        raise FitError(str(e)) from None  # the message names the file
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


def refine_arc_lengths(points: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Arc lengths (M,) of tracked points (F, M, 3) that fit the simulated rod (F, N+1, 3) best
    over every frame: per point, the least sum of squared distances over a grid of 20 samples per
    segment, refined by a parabola through the best sample and its neighbours."""
    s_nodes = node_arc_lengths(nodes[0])
    grid = np.linspace(0.0, s_nodes[-1], 20 * (nodes.shape[1] - 1) + 1)
    curve = markers(nodes, s_nodes, grid)  # (F, G, 3)
    out = np.empty(points.shape[1])
    for i in range(points.shape[1]):
        cost = np.sum((curve - points[:, i:i + 1, :]) ** 2, axis=(0, 2))
        k = int(np.argmin(cost))
        s = grid[k]
        if 0 < k < len(grid) - 1:
            c0, c1, c2 = cost[k - 1], cost[k], cost[k + 1]
            den = c0 - 2 * c1 + c2
            if den > 0:
                s += 0.5 * (c0 - c2) / den * (grid[1] - grid[0])
        out[i] = s
    return out


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


def rod_length(scene: str, overrides: Dict[str, object], rod: str,
               corde_run: Optional[str] = None) -> float:
    """The rod's length as it starts (the sum of its segments at t = 0)."""
    nodes, _ = simulate(Job(scene, overrides, rod, np.array([0.0]), corde_run=corde_run))
    return float(node_arc_lengths(nodes[0])[-1])
