"""Identification of a cable's material from a recording of its motion (`corde_fit`).

A recording is 3-D points tracked along a real cable over time (CSV or rosbag, see
docs/calibration.md) and, optionally, the poses of the gripper that moved it. The fit finds the
scene keys (E, G, damping_time, drag, ...) whose simulation reproduces the tracked points best:
nonlinear least squares (scipy.optimize.least_squares) over the logarithms of the parameters,
residuals = simulated minus tracked positions at the recorded times. The Jacobian is taken by
forward finite differences; its columns are independent runs, spread over Dask workers when a
cluster is given. In a statics fit the columns of material keys the library differentiates (E, G,
rho, ...) come from the equilibrium's Hessian instead, in the same solve as the residual
(fit_jacobian). Confidence intervals come from J^T J and the residual variance; a parameter
whose interval is wider than a limit (or that does not change the simulation at all) is refused
as undetermined, fixed at its starting value, and the others are fitted again without it.
"""


from __future__ import annotations

import copy
import math
import os
import time as _time
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional

import numpy as np
import yaml

from .fit_recording import (FitError, Recording, ToolChain, grasp_segment,  # noqa: F401
                            gripper_keyframes,
                            read_bag_recording, read_csv_recording, read_recording,
                            write_bag_recording, write_csv_recording, write_keyframe_csv)
from .fit_wrench import (FORCE_NOISE, TORQUE_NOISE, WrenchSpec, frame_errors,  # noqa: F401
                         simulate_with_wrench, synthesize_wrenches, wrench_spec)
from .fit_jacobian import analytic_columns, marker_job_with_sensitivity, parameter_values
from .fit_sim import (Job, find_corde_run, get_key, load_scene_yaml, markers,  # noqa: F401
                      node_arc_lengths, project_arc_lengths, refine_arc_lengths, rod_length,
                      set_key, simulate,
                      synthesize, yaml_load)

# The identification's interface; recordings and runs come from fit_recording and fit_sim.
__all__ = [
    "PARAMETERS", "Parameter", "FitError", "FitResult", "Recording", "ToolChain", "Job", "fit",
    "simulate",
    "synthesize", "markers", "node_arc_lengths", "project_arc_lengths", "rod_length",
    "read_recording", "read_csv_recording", "write_csv_recording", "read_bag_recording",
    "write_bag_recording", "gripper_keyframes", "grasp_segment", "write_keyframe_csv",
    "load_scene_yaml", "yaml_load", "get_key", "set_key", "find_corde_run", "SerialExecutor",
    "DaskExecutor", "make_executor", "report_text", "write_residuals_csv", "write_fitted_scene",
    "material_file_data", "write_material_file", "WrenchSpec", "wrench_spec",
    "synthesize_wrenches", "simulate_with_wrench", "FORCE_NOISE", "TORQUE_NOISE",
]

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


@dataclass
class Parameter:
    name: str
    key: str  # scene key path (override syntax)
    initial: float


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
    # With measured wrenches (fit_wrench): their times, the RMS force (N) and torque (N m, or
    # None) error per wrench frame, and the RMS force error per component over all frames.
    wrench_times: Optional[np.ndarray] = None
    frame_force: Optional[np.ndarray] = None
    frame_torque: Optional[np.ndarray] = None
    force_rms: float = float("nan")
    torque_rms: float = float("nan")
    tracking_noise: float = 1e-3
    force_noise: float = float("nan")
    torque_noise: float = float("nan")


def _marker_job(args):
    job, s = args
    nodes, _ = simulate(job)
    return markers(nodes, node_arc_lengths(nodes[0]), s)


def _marker_wrench_job(args):
    job, s, spec = args
    nodes, w = simulate_with_wrench(job, spec)
    return markers(nodes, node_arc_lengths(nodes[0]), s), w


class Problem:
    """The residual function of a fit: log-parameters -> (simulated - tracked) / scale."""

    def __init__(self, scene, rec: Recording, params: List[Parameter], rod: str,
                 overrides: Dict[str, object], backend="auto", corde_run=None, executor=None,
                 scale=1e-3, diff_step=1e-3, statics=False, wrench: WrenchSpec = None,
                 jacobian="auto"):
        self.scene, self.rec, self.params, self.rod = scene, rec, params, rod
        self.statics = statics
        self.fixed = dict(overrides)
        self.backend, self.corde_run = backend, corde_run
        self.executor = executor or SerialExecutor()
        self.scale, self.h = scale, diff_step
        self.wrench = wrench  # measured wrenches: residuals / their noise after the points'
        self.runs = 0
        self.s = rec.arc_lengths
        self._cache = {}
        # columns from the library's statics sensitivity (fit_jacobian), and their cache
        # (positions only: with measured wrenches every column is a finite difference)
        self.columns = analytic_columns(params, rod, statics, jacobian if wrench is None else "fd")
        self._dcache = {}

    def job(self, theta) -> Job:
        ov = dict(self.fixed)
        for p, th in zip(self.params, theta):
            ov[p.key] = float(np.exp(th))
        return Job(self.scene, ov, self.rod, self.rec.times, self.backend, self.corde_run,
                   statics=self.statics)

    def _residuals_of(self, pts):
        if self.wrench is not None:
            pts, w = pts
            return np.concatenate([((pts - self.rec.points) / self.scale).reshape(-1),
                                   ((w - self.wrench.values) / self.wrench.scale()).reshape(-1)])
        return ((pts - self.rec.points) / self.scale).reshape(-1)

    def residuals_many(self, thetas):
        todo = [t for t in thetas if tuple(t) not in self._cache]
        if todo and self.columns:
            results = self.executor.map(
                marker_job_with_sensitivity,
                [(self.job(t), self.s, parameter_values(t, self.columns)) for t in todo])
            self.runs += len(todo)
            for t, (pts, dpts) in zip(todo, results):
                self._cache[tuple(t)] = self._residuals_of(pts)
                self._dcache[tuple(t)] = dpts.reshape(len(dpts), -1) / self.scale
        elif todo:
            if self.wrench is not None:
                results = self.executor.map(_marker_wrench_job,
                                            [(self.job(t), self.s, self.wrench) for t in todo])
            else:
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
        fd = [j for j in range(len(theta)) if j not in self.columns]
        for j in fd:
            t = theta.copy()
            t[j] += self.h
            pts.append(t)
        r = self.residuals_many(pts)
        J = np.empty((len(r[0]), len(theta)))
        for k, j in enumerate(fd):
            J[:, j] = (r[k + 1] - r[0]) / self.h
        for k, j in enumerate(sorted(self.columns)):
            J[:, j] = self._dcache[tuple(theta)][k]
        return J


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
        log: Callable[[str], None] = lambda s: None, statics: bool = False,
        wrench: Optional[WrenchSpec] = None, tracking_noise: float = 1e-3,
        jacobian: str = "auto") -> FitResult:
    """Fits params to the recording (arc lengths given, or projected onto the rod at the first
    frame with the starting parameters). statics: every frame is the cable at rest, compared
    with the static equilibrium at its time (the drives and grasps where they are then), not
    with a run; there, jacobian='auto' takes the columns of the material keys the library
    differentiates from the equilibrium's Hessian ('fd': finite differences for all; always
    with wrench, whose reactions have no analytic derivative yet). wrench: the gripper's
    measured wrenches (fit_wrench.wrench_spec), compared with the simulated grasp reaction,
    each residual divided by its noise (the points' by tracking_noise, m). Parameters whose
    confidence interval spans more than a
    factor max_ci_factor either way (or that the residuals do not depend on) are refused as
    undetermined and kept at their starting value; the others are fitted again without them."""
    from scipy import optimize, stats

    t_start = _time.perf_counter()
    overrides = dict(overrides or {})
    if not params:
        raise FitError("nothing to fit: give at least one parameter")
    if not (tracking_noise > 0 and math.isfinite(tracking_noise)):
        raise FitError(f"--tracking-noise: must be a number > 0, got {tracking_noise}")
    for p in params:
        if not (p.initial > 0 and math.isfinite(p.initial)):
            raise FitError(f"{p.name}: the starting value must be > 0 (fitted in log space), "
                           f"got {p.initial}")
    executor = executor or SerialExecutor()
    rec = copy.copy(rec)
    projected = rec.arc_lengths is None
    if projected:
        nodes, _ = simulate(Job(scene, {**overrides, **{p.key: p.initial for p in params}}, rod,
                                np.array([rec.times[0]]), backend, corde_run, statics=statics))
        rec.arc_lengths = project_arc_lengths(rec.points[0], nodes[0])
        log("arc lengths projected onto the rod at the first frame: "
            + ", ".join(f"{s:.4f}" for s in rec.arc_lengths) + " m")
    active = list(params)
    undetermined: Dict[str, str] = {}
    runs = iterations = 0
    values = {p.name: p.initial for p in params}
    for rnd in range(2 if projected else 1):
        while True:
            prob = Problem(scene, rec, active, rod,
                           {**overrides, **{p.key: p.initial for p in params if p not in active}},
                           backend, corde_run, executor, scale=tracking_noise,
                           diff_step=diff_step, statics=statics, wrench=wrench,
                           jacobian=jacobian)
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
                    if wrench is None and "rho" in (p.name, max(c)[1]):
                        partner += (" (positions alone see forces only relative to the mass: "
                                    "record the gripper's force to determine the density)")
            span = (f"a factor {math.exp(half[j]):.3g}" if half[j] < math.log(1e6) else
                    "more than a factor 1e6")
            undetermined[p.name] = (f"its {confidence:.0%} interval would span {span} either way "
                                    f"(limit {max_ci_factor:g}){partner}")
            values[p.name] = p.initial
            active = [q for q in active if q is not p]
            if not active:
                break
        if rnd == 0 and projected and active:
            # The projection at the first frame carries that frame's noise; the points' arc
            # lengths fitted to every frame of the fitted cable (a cheap 1-D search each), then
            # the parameters fitted again from where they are.
            nodes, _ = simulate(Job(scene, {**overrides, **{p.key: values[p.name] for p in params}},
                                    rod, rec.times, backend, corde_run, statics=statics))
            runs += 1
            rec.arc_lengths = refine_arc_lengths(rec.points, nodes)
            log("arc lengths fitted to every frame: "
                + ", ".join(f"{s:.4f}" for s in rec.arc_lengths) + " m")
    names = [p.name for p in params]
    ci, frame_rms, corr_full = {}, np.zeros(len(rec.times)), None
    rms = sigma = force_rms = torque_rms = float("nan")
    frame_force = frame_torque = None
    sv_out = np.array([])
    if active:
        for k, p in enumerate(active):
            ci[p.name] = (float(np.exp(theta[k] - half[k])), float(np.exp(theta[k] + half[k])))
        npos = rec.points.size
        d = (r[:npos] * prob.scale).reshape(len(rec.times), -1, 3)
        frame_rms = np.sqrt(np.mean(np.sum(d * d, axis=2), axis=1))
        rms = float(np.sqrt(np.mean(d * d)))
        sigma = float(math.sqrt(s2) * prob.scale)
        if wrench is not None:
            sim_w = r[npos:].reshape(wrench.values.shape) * wrench.scale() + wrench.values
            frame_force, frame_torque = frame_errors(wrench, sim_w)
            dw = sim_w - wrench.values
            force_rms = float(np.sqrt(np.mean(dw[:, :3] ** 2)))
            torque_rms = float(np.sqrt(np.mean(dw[:, 3:] ** 2))) if wrench.columns == 6 else \
                float("nan")
        sd = np.sqrt(np.diag(cov))
        corr_full = cov / np.outer(sd, sd)
        sv_out = sv
    final = {**overrides, **{p.key: values[p.name] for p in params}}
    return FitResult(
        names=names, keys=[p.key for p in params], values=values, ci=ci,
        undetermined=undetermined, initial={p.name: p.initial for p in params},
        confidence=confidence, rms=rms, frame_rms=frame_rms, times=rec.times,
        singular_values=sv_out,
        correlation=corr_full if corr_full is not None else np.zeros((0, 0)),
        runs=runs, iterations=iterations, wall_time=_time.perf_counter() - t_start,
        workers=getattr(executor, "workers", 1), sigma=sigma, arc_lengths=rec.arc_lengths,
        overrides=final, wrench_times=None if wrench is None else wrench.times,
        frame_force=frame_force, frame_torque=frame_torque, force_rms=force_rms,
        torque_rms=torque_rms, tracking_noise=tracking_noise,
        force_noise=float("nan") if wrench is None else wrench.force_noise,
        torque_noise=float("nan") if wrench is None else wrench.torque_noise)


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
    if res.ci and res.frame_force is not None:
        lines.append(f"force residual    RMS {res.force_rms:.4g} N per component (noise given "
                     f"{res.force_noise:.4g} N), per frame {np.min(res.frame_force):.3g} to "
                     f"{np.max(res.frame_force):.3g} N")
        if res.frame_torque is not None:
            lines.append(f"torque residual   RMS {res.torque_rms:.4g} N m per component (noise "
                         f"given {res.torque_noise:.4g} N m), per frame "
                         f"{np.min(res.frame_torque):.3g} to {np.max(res.frame_torque):.3g} N m")
    lines.append(f"cost              {res.runs} runs, {res.iterations} evaluations, "
                 f"{res.wall_time:.2f} s wall on {res.workers} worker(s)")
    return "\n".join(lines)


def write_residuals_csv(path: str, res: FitResult) -> None:
    """`time,rms_mm` per frame of the points; with wrenches also `force_n` (and `torque_nm`) per
    wrench frame, rows merged by time (a cell is empty where that kind has no frame)."""
    if res.frame_force is None:
        with open(path, "w") as f:
            f.write("time,rms_mm\n")
            for t, e in zip(res.times, res.frame_rms):
                f.write(f"{t:.9g},{e * 1e3:.6g}\n")
        return
    rows: Dict[float, list] = {}
    for t, e in zip(res.times, res.frame_rms):
        rows.setdefault(float(t), ["", "", ""])[0] = f"{e * 1e3:.6g}"
    for k, t in enumerate(res.wrench_times):
        row = rows.setdefault(float(t), ["", "", ""])
        row[1] = f"{res.frame_force[k]:.6g}"
        if res.frame_torque is not None:
            row[2] = f"{res.frame_torque[k]:.6g}"
    torque = res.frame_torque is not None
    with open(path, "w") as f:
        f.write("time,rms_mm,force_n" + (",torque_nm" if torque else "") + "\n")
        for t in sorted(rows):
            f.write(f"{t:.9g}," + ",".join(rows[t][:3 if torque else 2]) + "\n")


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
