"""Measured gripper wrenches in corde_fit (docs/calibration.md, "Forces"): the simulated grasp
reaction at the recorded times, compared with what the gripper's force-torque sensor read.

Tracked points alone see only ratios of the forces to the mass (stiffness, drag and density scale
together); a measured force fixes the scale, so density becomes identifiable. The residuals of
the two kinds are divided by their noise (positions by the tracking noise in m, forces by
`force_noise` in N, torques by `torque_noise` in N m) and enter one least squares.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .fit_recording import FitError, Recording
from .fit_sim import Job, _interp_frames

# Defaults of --force-noise and --torque-noise: a wrist force-torque sensor's noise, 1 sigma.
FORCE_NOISE = 0.05  # N
TORQUE_NOISE = 0.0025  # N m


@dataclass
class WrenchSpec:
    """Which grasp the sensor is in, how its readings are expressed, and their noise."""

    grasp: str
    segment: int  # the grasped segment (its frame is the holder's for a rigid grasp)
    frame: str  # "world" or "holder"
    times: np.ndarray  # (W,)
    values: np.ndarray  # (W, 3) or (W, 6): on the gripper by the cable
    force_noise: float = FORCE_NOISE
    torque_noise: float = TORQUE_NOISE

    @property
    def columns(self) -> int:
        return self.values.shape[1]

    def scale(self) -> np.ndarray:
        return np.array([self.force_noise] * 3 + [self.torque_noise] * 3)[: self.columns]


def wrench_spec(rec: Recording, grasp: str, segment: int, force_noise: float,
                torque_noise: float) -> Optional[WrenchSpec]:
    """The recording's wrenches as a WrenchSpec (None without wrenches); checks the noises."""
    if rec.wrenches is None:
        return None
    for name, v in (("--force-noise", force_noise), ("--torque-noise", torque_noise)):
        if not (np.isfinite(v) and v > 0):
            raise FitError(f"{name}: must be a number > 0, got {v:g}")
    return WrenchSpec(grasp, segment, rec.wrench_frame, np.asarray(rec.wrenches[0], float),
                      np.asarray(rec.wrenches[1], float), force_noise, torque_noise)


def _grasp_wrench(sim, grasp: str):
    """The grasp's wrench on the gripper by the cable over the last step (world frame, torque
    about the grasped segment's midpoint): minus the library's reaction on the rod."""
    for r in sim.reactions():
        if r["support"] == grasp:
            return -np.concatenate([np.asarray(r["force"]), np.asarray(r["moment"])])
    raise FitError(f"grasps: no grasp '{grasp}' among the scene's supports")


def _to_holder(w, quat_wxyz):
    from scipy.spatial.transform import Rotation as R

    rot = R.from_quat(np.asarray(quat_wxyz)[[1, 2, 3, 0]])
    return np.concatenate([rot.inv().apply(w[:3]), rot.inv().apply(w[3:])])


def simulate_with_wrench(job: Job, spec: WrenchSpec):
    """Runs a job through the Python API (dynamics, or statics with job.statics) and returns
    (node positions (F, N+1, 3) at job.times, the grasp's wrench (W, columns) at spec.times).
    Between steps both are linear in time; a step's reaction (over the step) stands at its end,
    the first step's also at the start."""
    import corde_sim

    if job.backend == "cli":
        raise FitError("a fit with measured wrenches needs the Python module corde_sim (the "
                       "corde_run backend gives no reactions at the recorded times)")
    try:
        sim = corde_sim.load(job.scene, overrides=dict(job.overrides))
    except Exception as e:
        raise FitError(str(e)) from None
    rod = int(job.rod) if str(job.rod).isdigit() else job.rod

    def state():
        w = _grasp_wrench(sim, spec.grasp)
        if spec.frame == "holder":
            w = _to_holder(w, np.asarray(sim.frames(rod))[spec.segment])
        return np.array(sim.positions(rod)), w

    if job.statics:
        times = np.union1d(job.times, spec.times)
        xs, ws = [], []
        for t in times:
            try:
                sim.statics(time=float(t))
            except Exception as e:
                raise FitError(f"{job.scene}: statics at t = {t:g} s: {e}") from None
            x, w = state()
            xs.append(x)
            ws.append(w)
        nodes = np.array(xs)[np.searchsorted(times, job.times)]
        wr = np.array(ws)[np.searchsorted(times, spec.times)]
        return nodes, wr[:, : spec.columns]
    end = max(float(job.times[-1]), float(spec.times[-1]))
    ts, xs, ws = [sim.time], [np.array(sim.positions(rod))], [None]
    while ts[-1] < end - 1e-12:
        try:
            sim.step(1)
        except Exception as e:
            raise FitError(f"{job.scene}: run failed at t = {sim.time:g} s: {e}") from None
        x, w = state()
        ts.append(sim.time)
        xs.append(x)
        ws.append(w)
    if len(ts) == 1:  # nothing to step: one step for the reaction
        sim.step(1)
        ws[0] = state()[1]
    ws[0] = ws[1] if len(ws) > 1 else ws[0]
    ts, xs, ws = np.array(ts), np.array(xs), np.array(ws)
    nodes = _interp_frames(ts, xs, np.asarray(job.times, float)) if len(ts) > 1 else xs[[0] * len(
        job.times)]
    wr = _interp_frames(ts, ws, spec.times) if len(ts) > 1 else ws[[0] * len(spec.times)]
    if not (np.all(np.isfinite(nodes)) and np.all(np.isfinite(wr))):
        raise FitError(f"{job.scene}: the run produced non-finite positions or reactions")
    return nodes, wr[:, : spec.columns]


def frame_errors(spec: WrenchSpec, simulated: np.ndarray):
    """Per wrench frame the RMS force error (N, over x, y, z) and torque error (N m; None
    without torques)."""
    d = simulated - spec.values
    f = np.sqrt(np.mean(d[:, :3] ** 2, axis=1))
    t = np.sqrt(np.mean(d[:, 3:] ** 2, axis=1)) if spec.columns == 6 else None
    return f, t


def add_noise(values: np.ndarray, force_noise: float, torque_noise: float,
              rng: np.random.Generator) -> np.ndarray:
    scale = np.array([force_noise] * 3 + [torque_noise] * 3)[: values.shape[1]]
    return values + rng.normal(0.0, 1.0, values.shape) * scale


def synthesize_wrenches(scene: str, overrides: dict, rod: str, times: np.ndarray,
                        arc_lengths: np.ndarray, noise: float, seed: int, grasp: str,
                        force_noise: float, torque_noise: Optional[float] = None,
                        frame: str = "world", statics: bool = False,
                        backend: str = "auto") -> Recording:
    """A synthetic recording with the gripper's wrench: the points as fit_sim.synthesize makes
    them (Gaussian noise of `noise` m) and the grasp's wrench at the same times with Gaussian
    noise of force_noise N (and torque_noise N m; None: forces only), seeded."""
    from .fit_recording import grasp_segment
    from .fit_sim import load_scene_yaml, markers, node_arc_lengths

    times = np.asarray(times, float)
    seg = grasp_segment(load_scene_yaml(scene), grasp)[1]
    cols = 3 if torque_noise is None else 6
    spec = WrenchSpec(grasp, seg, frame, times, np.zeros((len(times), cols)))
    nodes, w = simulate_with_wrench(Job(scene, dict(overrides), rod, times, backend,
                                        statics=statics), spec)
    rng = np.random.default_rng(seed)
    s = np.asarray(arc_lengths, float)
    pts = markers(nodes, node_arc_lengths(nodes[0]), s)
    pts = pts + rng.normal(0.0, noise, pts.shape)
    w = add_noise(w, force_noise, torque_noise or 0.0, rng)
    rec = Recording(times, pts, s, wrenches=(times.copy(), w), wrench_frame=frame)
    rec.check("synthetic recording")
    return rec
