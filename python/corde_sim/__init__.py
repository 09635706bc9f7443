"""corde_sim: Cosserat rod (CoRdE) cable simulation from Python (docs/python.md).

    import corde_sim
    sim = corde_sim.load("config/scenes/default.yaml", {"rods.cable.elements": 60})
    sim.run(0.5)
    x = sim.positions("cable")          # (N+1, 3) node positions, m

A Simulation steps a scene exactly as corde_run does (the same driver, stability guard and checks),
so a Python run gives corde_run's numbers. Errors raise corde_sim.Error subclasses carrying the
library's messages: SceneError (also a ValueError) for a bad scene or override, GuardError when
the stability guard cannot recover, RunawayError when a state fails the runaway checks,
StaticsError when statics finds no equilibrium. Batch runs on Dask: corde_sim.batch.
"""

import json as _json
import math as _math
import os as _os
import pkgutil as _pkgutil

# The package spans folders: python/corde_sim (this file) and, in a catkin devel space, the one
# holding _core and the generated messages. catkin's relay there joins them; a process that
# finds this folder first (a Dask worker started with the parent's sys.path) joins them here.
__path__ = _pkgutil.extend_path(__path__, __name__)

try:
    from ._core import Error, GuardError, RunawayError, SceneError, StaticsError  # noqa: F401
    from ._core import _Simulation
except ImportError as _e:  # the messages (corde_sim.msg) must import without the extension
    _core_missing = _e

    class Error(RuntimeError):
        pass

    class SceneError(Error, ValueError):
        pass

    class GuardError(Error):
        pass

    class RunawayError(Error):
        pass

    class StaticsError(Error):
        pass

    class _Simulation:
        @staticmethod
        def _missing(*args, **kwargs):
            raise ImportError("corde_sim's extension _core is not available (%s): build it "
                              "(cmake/CordePython.cmake, needs pybind11-dev) and put it on "
                              "PYTHONPATH (docs/python.md)" % _core_missing)

        load = parse = _missing

__all__ = [
    "Error",
    "GuardError",
    "RunawayError",
    "SceneError",
    "StaticsError",
    "Simulation",
    "load",
    "parse",
    "override_strings",
    "yaml_value",
]


def yaml_value(value):
    """The YAML text of an override value, as corde_run's --set key=VALUE takes it.

    Strings pass unchanged (so "[0, 0, -1]" works as on the command line); numbers keep every
    digit (repr: the value read back is the same double); lists, tuples, numpy arrays and dicts
    become YAML flow collections."""
    if isinstance(value, str):
        return value
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        value = value.tolist()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if _math.isnan(value):
            return ".nan"
        if _math.isinf(value):
            return ".inf" if value > 0 else "-.inf"
        return repr(value)
    if value is None:
        return "null"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(yaml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(
            "%s: %s" % (_json.dumps(str(k)), yaml_value(v)) for k, v in value.items()) + "}"
    raise TypeError("override value %r: not a number, string, list or dict" % (value,))


def override_strings(overrides):
    """corde_run's --set strings ("key.path=value") from a dict {"key.path": value} or a list of
    such strings (or of (key, value) pairs)."""
    if overrides is None:
        return []
    if isinstance(overrides, dict):
        items = overrides.items()
    else:
        items = []
        for o in overrides:
            if isinstance(o, str):
                if "=" not in o:
                    raise ValueError("override %r: needs key.path=value" % o)
                items.append(tuple(o.split("=", 1)))
            else:
                items.append(tuple(o))
    out = []
    for key, value in items:
        if not isinstance(key, str) or not key:
            raise ValueError("override key %r: needs a key path such as rods.0.elements" % (key,))
        out.append(key + "=" + yaml_value(value))
    return out


def _guard_args(guard):
    """(enabled, settings) from guard=True/False or a dict of the guard's settings."""
    if isinstance(guard, dict):
        settings = dict(guard)
        return bool(settings.pop("enabled", True)), settings
    return bool(guard), {}


def _rod_arg(rod):
    if isinstance(rod, str):
        return rod
    return int(rod)


class Simulation:
    """A scene being simulated: its rods, supports and grasps, and the driver that steps it.

    Make one with load() or parse(). Rods are named by index (0 is the first rod of the scene,
    negative counts from the end) or by name. Arrays are copies (changing them changes nothing).
    Stepping releases the GIL; one Simulation must not be used from two threads at once.
    """

    def __init__(self, core):
        self._core = core

    # --- stepping -------------------------------------------------------------------------
    def step(self, n=1):
        """Advance n steps of time_step, then check the state as corde_run does before it writes
        a frame (the stability guard's check, then the runaway checks). Raises GuardError when
        the guard could not recover (the state stays at its last good one, the time there) and
        RunawayError when a state fails the runaway checks (guard off)."""
        self._core.step(int(n))
        return self

    def run(self, duration=None):
        """Advance ceil(duration / time_step) steps in one go (the scene's duration when None),
        then check as step() does: corde_run's run of the same duration without output files."""
        self._core.run(-1.0 if duration is None else float(duration))
        return self

    def statics(self, time=None, check=True):
        """Solve the static equilibrium of every rod (corde_run --statics) with the drives and
        grasps at `time` (default: the scene's statics_time). The rods are left at it, at rest, the
        clock at `time`, and each support's reaction is the static one. Returns a dict: ok,
        problem, time, wall_seconds, summary (corde_run's report), rods (per rod: converged,
        residual, relative_residual, iterations, load_steps, attempts, energy, negative_modes,
        zero_modes, sag, ...). Raises SceneError when statics cannot handle the scene, and with
        check=True StaticsError when it does not converge (the rods at the last iterate)."""
        t = self._core.statics_time if time is None else float(time)
        return self._core.statics(t, bool(check))

    def statics_sensitivity(self, params=("E", "G", "rho"), rod=0, rotations=False):
        """How the equilibrium of the last statics() moves with material keys: a dict parameter
        -> (N+1, 3) array of d(node position)/dp (m per unit of p: per Pa for E and G, per kg/m^3
        for rho), from the equilibrium's Hessian (dx/dp = -H^-1 dg/dp, docs/python.md), not by
        re-solving. Parameters: the material keys E, G, E_s, B, C, K_s, kappa, rho (or density);
        each moves the section constants the scene derived from it (E: bending, and stretch
        unless E_s or K_s is given; G: twist and a default kappa; rho: the cable's own weight,
        not its point masses). rotations=True also returns a dict of (N, 3) body rotations per
        unit of p (dq/dp = q (x) (0, w)/2). Raises StaticsError when no equilibrium was solved
        (or the state changed since), SceneError for an unknown parameter or one the rod's
        material does not derive anything from."""
        if isinstance(params, str):
            params = [params]
        pos, rot = self._core.statics_sensitivity(_rod_arg(rod), [str(p) for p in params])
        return (pos, rot) if rotations else pos

    def check(self):
        """"" when the state passes the runaway checks, else the problem (corde_run checks the
        scene's start so)."""
        return self._core.problem()

    # --- state ----------------------------------------------------------------------------
    @property
    def time(self):
        """The world's time (s)."""
        return self._core.time

    @property
    def time_step(self):
        """The scene's time step (s; the guard may run smaller substeps while it recovers)."""
        return self._core.time_step

    @property
    def steps(self):
        """Steps taken since load."""
        return self._core.steps

    @property
    def duration(self):
        """The scene's duration (s)."""
        return self._core.duration

    @property
    def num_rods(self):
        return len(self._core.rod_names)

    @property
    def rod_names(self):
        return list(self._core.rod_names)

    @property
    def name(self):
        return self._core.name

    @property
    def integrator(self):
        return self._core.integrator

    @property
    def gravity(self):
        return self._core.gravity

    @property
    def warnings(self):
        """Problems the scene reader found that do not stop a run."""
        return list(self._core.warnings)

    @property
    def notes(self):
        """The reader's automatic choices (elements/time_step/integrator: auto) and why."""
        return list(self._core.notes)

    @property
    def settled(self):
        """Rods started from their equilibrium (initial_state: equilibrium), one line each."""
        return list(self._core.settled)

    @property
    def statics_mode(self):
        """Whether the scene says mode: statics (corde_run would solve it, not run it)."""
        return self._core.statics_mode

    def positions(self, rod=0):
        """Node positions, an (N+1, 3) float64 array (m, world frame)."""
        return self._core.positions(_rod_arg(rod))

    def velocities(self, rod=0):
        """Node velocities, (N+1, 3) (m/s)."""
        return self._core.velocities(_rod_arg(rod))

    def frames(self, rod=0):
        """Segment orientations, (N, 4) unit quaternions as rows w, x, y, z (Eigen's Quaterniond,
        active rotation from the segment's material frame to the world: its columns d1, d2, d3 =
        the tangent; corde_run's --out CSV writes them as qx, qy, qz, qw)."""
        return self._core.frames(_rod_arg(rod))

    def angular_velocities(self, rod=0):
        """Segment angular velocities, (N, 3), in each segment's material (body) frame (rad/s)."""
        return self._core.angular_velocities(_rod_arg(rod))

    def rest_lengths(self, rod=0):
        """Segment rest lengths, (N,) (m)."""
        return self._core.rest_lengths(_rod_arg(rod))

    def energies(self, rod=0):
        """The rod's energies (J), as corde_run --energies: kinetic_translation,
        kinetic_rotation, stretch, bend_twist, coupling, gravity (zero at the world origin),
        total (their sum)."""
        return self._core.energies(_rod_arg(rod))

    def reactions(self):
        """Per support (each clamp, driven or constrained item and grasp of the scene, in
        corde_run --reactions' order) a dict: support, rod, force and moment (N, N m, world
        frame, exerted by the support on the rod over the last step; the moment about point)."""
        return self._core.reactions()

    def guard_events(self):
        """The stability guard's events since load (the last 10000), oldest first: dicts with
        time, kind, action, rollback_to, rod, item, detail, time_step, integrator and message
        (the line corde_run prints)."""
        return self._core.guard_events()

    def events(self):
        """Every driver event since load (the last 10000: guard, took_hold, let_go, cannot_hold,
        script_ended, stalled): dicts with time, kind, grasp, text."""
        return self._core.events()

    def __repr__(self):
        return "<corde_sim.Simulation %r t=%.6g s, %d rod(s)>" % (self.name, self.time,
                                                                   self.num_rods)


def load(scene, overrides=None, guard=True):
    """Load a scene and return a Simulation at its start.

    scene: a scene file path (docs/scene_format.md), or a dict with the scene's keys (a scene
    built in code: {"rods": [{"name": "cable", "elements": 40, "material": {...}, ...}], ...}).
    overrides: {"key.path": value} (or "key.path=value" strings): corde_run's --set, applied to
    the YAML before it is checked, e.g. {"rods.cable.material.E": 2e7, "integrator": "bdf2",
    "grasps.gripper.keyframes.1.position": [0.5, 0, 1]}.
    guard: False runs without the stability guard (corde_run --no-guard); a dict sets its
    settings (docs/stability_guard.md): check_every (steps between checks, 64), max_halvings (3),
    allow_implicit (True), energy_tolerance (0.1), energy_floor (1e-3), relax_after (0.5 s).
    Raises SceneError with corde_run's message ("file: key.path: what is wrong").
    """
    strings = override_strings(overrides)
    if isinstance(scene, dict):
        return parse(scene, overrides=overrides, guard=guard)
    path = _os.fspath(scene)
    return Simulation(_Simulation.load(path, strings, *_guard_args(guard)))


def parse(text, overrides=None, source="<string>", guard=True):
    """load() from YAML text (or a dict of the scene's keys); `source` names it in messages.
    File references in the scene (URDFs, keyframe CSVs) are relative to the working folder."""
    if isinstance(text, dict):
        # JSON is YAML and keeps every float digit; numpy arrays as lists.
        text = _json.dumps(text, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))
        if source == "<string>":
            source = "<dict>"
    return Simulation(_Simulation.parse(str(text), override_strings(overrides), source,
                                        *_guard_args(guard)))
