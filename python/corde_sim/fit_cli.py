"""The corde_fit command (docs/calibration.md): `corde_fit SCENE RECORDING` fits, `corde_fit
record SCENE OUT` writes a synthetic recording."""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
from typing import Dict, List, Sequence

import numpy as np

from .fit import (FORCE_NOISE, PARAMETERS, TORQUE_NOISE, FitError, Job, Parameter, ToolChain, fit, get_key, grasp_segment,
                  gripper_keyframes, load_scene_yaml, make_executor, material_file_data,
                  read_recording, report_text, rod_length, simulate, synthesize,
                  write_bag_recording, write_csv_recording, write_fitted_scene,
                  write_keyframe_csv, write_material_file, write_residuals_csv, yaml_load)
from .fit_wrench import synthesize_wrenches, wrench_spec

# ---------------------------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------------------------

USAGE_EPILOG = """
examples:
  corde_fit cable.yaml recording.csv --fit E,G,damping_time,drag --out cable_fitted.yaml
  corde_fit cable.yaml run.bag --points-topic /cable/points --gripper-topic /gripper/pose \\
            --grasp gripper --fit E,damping_time --workers 2
  corde_fit record cable.yaml recording.csv --points 15 --noise 0.001 --every 0.05
  corde_fit record cable.yaml rec.csv --wrench gripper --force-noise 0.003 --torque-noise 3e-4
  corde_fit cable.yaml rec.csv --grasp gripper --force-noise 0.003 --torque-noise 3e-4 \
            --fit E,G,damping_time,drag,rho

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
    ap.add_argument("--wrench", default=None, metavar="GRASP",
                    help="also record this grasp's wrench on the gripper (a force-torque sensor)")
    ap.add_argument("--force-noise", type=float, default=FORCE_NOISE,
                    help="the wrench's force noise (N, 1 sigma; default %(default)s)")
    ap.add_argument("--torque-noise", type=float, default=TORQUE_NOISE,
                    help="its torque noise (N m, 1 sigma; default %(default)s)")
    ap.add_argument("--forces-only", action="store_true", help="record no torques")
    ap.add_argument("--wrench-frame", choices=["world", "holder"], default="world",
                    help="a .bag's wrench frame: world, or the grasp's holder frame grasp/NAME")
    ap.add_argument("--corde-run", default=None)
    a = ap.parse_args(argv)
    doc = load_scene_yaml(a.scene)
    ov = _overrides_of(a.set)
    rod = _scene_rod(doc, a.rod)
    dur = a.duration
    if dur is None:
        dur = float(ov.get("duration", doc.get("duration", 1.0)))
    times = np.arange(0.0, dur + 1e-9, a.every)
    length = rod_length(a.scene, ov, rod, a.corde_run)
    s = np.linspace(0.0, length, a.points + 2)[1:-1] if a.points > 1 else np.array([length / 2])
    seg = grasp_segment(doc, a.grasp)[1] if a.grasp else None
    if a.wrench:
        if a.grasp:
            raise FitError("--wrench and --grasp: record the gripper's poses or its wrench")
        if a.wrench_frame == "holder" and not a.out.endswith(".bag"):
            raise FitError("--wrench-frame holder: a CSV holds wrenches in the world frame")
        rec = synthesize_wrenches(a.scene, ov, rod, times, s, a.noise, a.seed, a.wrench,
                                  a.force_noise, None if a.forces_only else a.torque_noise,
                                  a.wrench_frame, a.statics)
    else:
        rec = synthesize(a.scene, ov, rod, times, s, a.noise, a.seed, corde_run=a.corde_run,
                         gripper_segment=seg, statics=a.statics)
    if a.out.endswith(".bag"):
        write_bag_recording(a.out, rec, wrench_frame_id=f"grasp/{a.wrench}"
                            if a.wrench_frame == "holder" else None)
    else:
        if a.grasp:
            raise FitError("--grasp: gripper poses go into a .bag recording only")
        write_csv_recording(a.out, rec)
    print(f"corde_fit record: {len(times)} frames of {len(s)} points ({a.noise * 1e3:g} mm "
          f"noise, seed {a.seed}) -> {a.out}")
    return 0


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
                        help="geometry_msgs/PoseStamped or sensor_msgs/JointState topic moving "
                             "--grasp (a .bag)")
        ap.add_argument("--grasp", default=None, help="grasp moved by the recorded gripper")
        ap.add_argument("--urdf", default=None,
                        help="robot description, for a gripper topic of joint states")
        ap.add_argument("--tool-link", default=None,
                        help="the URDF link holding the cable (with --urdf)")
        ap.add_argument("--keyframe-rate", type=float, default=50.0,
                        help="gripper poses per second turned into keyframes")
        ap.add_argument("--wrench-topic", default=None,
                        help="geometry_msgs/WrenchStamped topic: the wrench the cable exerts on "
                             "the gripper of --grasp (a .bag; a CSV has columns fx,fy,fz,...)")
        ap.add_argument("--world-frame", default="world",
                        help="the frame_id of wrenches in the world frame (default %(default)s)")
        ap.add_argument("--tracking-noise", type=float, default=1e-3,
                        help="the tracked points' noise (m, 1 sigma; default %(default)s): "
                             "their residuals' unit")
        ap.add_argument("--force-noise", type=float, default=FORCE_NOISE,
                        help="the measured forces' noise (N, 1 sigma; default %(default)s)")
        ap.add_argument("--torque-noise", type=float, default=TORQUE_NOISE,
                        help="the measured torques' noise (N m, 1 sigma; default %(default)s)")
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
        ap.add_argument("--jacobian", choices=["auto", "fd"], default="auto",
                        help="statics fits: material keys' columns from the equilibrium's "
                             "Hessian (auto) or all by finite differences (fd)")
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
    tool = None
    if a.urdf or a.tool_link:
        if not (a.urdf and a.tool_link):
            raise FitError("--urdf and --tool-link go together (the robot and the link that "
                           "holds the cable)")
        tool = ToolChain(a.urdf, a.tool_link)
    rec = read_recording(a.recording, a.points_topic, a.gripper_topic, tool, a.wrench_topic,
                         a.grasp, a.world_frame)
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
        wspec = None
        if rec.wrenches is not None:
            grasp = a.grasp
            if not grasp:
                names = [g.get("name") for g in (doc.get("grasps") or []) if isinstance(g, dict)]
                if len(names) != 1:
                    raise FitError(f"{a.recording}: the recording has wrenches: name the grasp "
                                   f"holding the sensor with --grasp NAME (grasps: "
                                   f"{', '.join(map(str, names)) or 'none'})")
                grasp = names[0]
            wspec = wrench_spec(rec, grasp, grasp_segment(doc, grasp)[1], a.force_noise,
                                a.torque_noise)
            kinds = "force and torque" if wspec.columns == 6 else "force"
            log(f"wrenches: {len(wspec.times)} frames of {kinds} ({wspec.frame} frame) at grasp "
                f"'{grasp}', noise {a.force_noise:g} N"
                + (f", {a.torque_noise:g} N m" if wspec.columns == 6 else ""))
        executor = make_executor(a.workers, a.scheduler)
        try:
            res = fit(a.scene, rec, params, rod, ov, a.backend, a.corde_run, executor,
                      a.confidence, a.max_ci_factor, a.max_iterations, log=log,
                      statics=a.statics, wrench=wspec, tracking_noise=a.tracking_noise,
                      jacobian=a.jacobian)
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
