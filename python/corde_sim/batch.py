"""corde_sim.batch: many runs of one scene with different scene keys, on Dask (docs/python.md).

    corde_batch sweep.yaml                       # local cluster of this machine's cores
    corde_batch sweep.yaml --scheduler tcp://host:8786 --out /shared/results

A sweep (a YAML file, docs/python.md "Sweep files") names a scene and the overrides of each
variant: a grid over keys, seeded random draws, or both. Each variant is one run_variant() call:
one HDF5 file with the frames at the chosen rate, the supports' reactions, the energies and the
guard's events, the overrides as attributes; then a done marker. The summary table (summary.csv)
has one row per variant. A run that fails is a row with its message; re-running the same command
skips the variants whose marker matches (same scene text, overrides and output settings); a
worker lost mid-run has its runs started again by Dask.
"""

import argparse
import csv
import functools
import hashlib
import itertools
import json
import math
import os
import sys
import time
import uuid

import numpy as np

FORMAT_VERSION = 1
SUMMARY_NAME = "summary.csv"


# --- one run ------------------------------------------------------------------------------------
def _atomic_write_text(path, text):
    tmp = "%s.tmp-%d" % (path, os.getpid())
    with open(tmp, "w") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def variant_key(scene, overrides, out_rate=None, every=None, duration=None, guard=True):
    """What makes a variant's result: the scene file's text, the override strings and the output
    settings (sha256, hex). A done marker counts only with the same key."""
    import corde_sim

    h = hashlib.sha256()
    if isinstance(scene, dict):
        h.update(json.dumps(scene, sort_keys=True).encode())
    else:
        h.update(_file_digest(os.path.abspath(scene), os.path.getmtime(scene)))
    for s in corde_sim.override_strings(overrides):
        h.update(b"\0" + s.encode())
    guard = sorted(guard.items()) if isinstance(guard, dict) else bool(guard)
    h.update(repr((FORMAT_VERSION, out_rate, every, duration, guard)).encode())
    return h.hexdigest()


@functools.lru_cache(maxsize=16)
def _file_digest(path, mtime):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).digest()


def marker_path(out_path):
    return out_path + ".done"


def read_marker(out_path):
    """The done marker's row (a dict) of a finished run, or None."""
    try:
        with open(marker_path(out_path)) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


class _Recorder:
    """Frames of one run, kept in memory until the file is written."""

    def __init__(self, sim, keep_velocities):
        self.sim = sim
        self.keep_velocities = keep_velocities
        self.times = []
        self.rods = [{"positions": [], "frames": [], "velocities": [], "energies": []}
                     for _ in range(sim.num_rods)]
        self.supports = None
        self.reactions = {"force": [], "moment": [], "point": []}

    ENERGY_COLUMNS = ("kinetic_translation", "kinetic_rotation", "stretch", "bend_twist",
                      "coupling", "gravity", "total")

    def frame(self):
        sim = self.sim
        self.times.append(sim.time)
        for i, r in enumerate(self.rods):
            r["positions"].append(sim.positions(i))
            r["frames"].append(sim.frames(i))
            if self.keep_velocities:
                r["velocities"].append(sim.velocities(i))
            e = sim.energies(i)
            r["energies"].append([e[c] for c in self.ENERGY_COLUMNS])
        reactions = sim.reactions()
        if self.supports is None:
            self.supports = [(r["support"], r["rod"]) for r in reactions]
        for k in ("force", "moment", "point"):
            self.reactions[k].append(np.array([r[k] for r in reactions]).reshape(-1, 3))

    def arrays(self):
        """The frames as read_result() returns them (without attrs)."""
        n = len(self.times)
        rods = []
        for i, r in enumerate(self.rods):
            nodes = len(self.sim.positions(i))
            d = {"name": self.sim.rod_names[i],
                 "positions": np.array(r["positions"], dtype=float).reshape(n, nodes, 3),
                 "frames": np.array(r["frames"], dtype=float).reshape(n, nodes - 1, 4),
                 "energies": np.array(r["energies"], dtype=float).reshape(
                     n, len(self.ENERGY_COLUMNS))}
            if self.keep_velocities:
                d["velocities"] = np.array(r["velocities"], dtype=float).reshape(n, nodes, 3)
            rods.append(d)
        supports = self.supports or []
        reactions = {k: np.array(v, dtype=float).reshape(n, len(supports), 3)
                     for k, v in self.reactions.items()}
        reactions["support"] = [s for s, _ in supports]
        reactions["rod"] = [r for _, r in supports]
        return {"time": np.array(self.times, dtype=float), "rods": rods, "reactions": reactions,
                "guard_events": self.sim.guard_events()}

    def write(self, path, attrs):
        import h5py

        a = self.arrays()
        tmp = "%s.tmp-%d" % (path, os.getpid())
        str_dt = h5py.string_dtype()
        with h5py.File(tmp, "w") as f:
            for k, v in attrs.items():
                f.attrs[k] = v
            f.create_dataset("time", data=a["time"])
            rods = f.create_group("rods")
            for i, r in enumerate(a["rods"]):
                g = rods.create_group(str(i))
                g.attrs["name"] = r["name"]
                for k in ("positions", "frames", "velocities", "energies"):
                    if k in r:
                        g.create_dataset(k, data=r[k])
                g["energies"].attrs["columns"] = ",".join(self.ENERGY_COLUMNS)
            g = f.create_group("reactions")
            for k in ("support", "rod"):
                g.create_dataset(k, data=a["reactions"][k], dtype=str_dt)
            for k in ("force", "moment", "point"):
                g.create_dataset(k, data=a["reactions"][k])
            g = f.create_group("events")
            g.create_dataset("guard", data=[json.dumps(e) for e in a["guard_events"]],
                             dtype=str_dt)
            g.create_dataset("all", data=[json.dumps(e) for e in self.sim.events()],
                             dtype=str_dt)
        os.replace(tmp, path)


def run_variant(scene, overrides=None, out_rate=None, out_path=None, duration=None, every=None,
                guard=True, keep_velocities=False, key=None, collect=False):
    """Run one variant of a scene; a pure function of its arguments (Dask may run it twice).

    scene: scene file path (or dict); overrides: {"key.path": value} as for corde_sim.load.
    Frames (positions, frames, energies, reactions) at t = 0, then every `every` steps (default:
    round(1 / (out_rate * time_step)) steps, or every 10 ms of simulated time as corde_run) and
    at the end: exactly the states corde_run --every K writes. duration: simulated time (default:
    the scene's). A scene with mode: statics is solved instead (one frame, at the equilibrium).

    out_path: the HDF5 file to write (atomically), with the overrides as attributes, the status
    and message; then its done marker (out_path + ".done", JSON with the returned row). None:
    nothing written. Returns the summary row: status (ok, failed: the run stopped with the
    library's message, scene_error: the scene or an override is invalid, error: anything
    else), message, wall_time (s), sim_time, steps, frames, guard_events; with collect=True
    also "data": the frames as read_result() gives them (for callers that want no files).
    """
    import corde_sim

    start = time.perf_counter()
    strings = corde_sim.override_strings(overrides)
    row = {"status": "ok", "message": "", "wall_time": 0.0, "sim_time": 0.0, "steps": 0,
           "frames": 0, "guard_events": 0}
    sim = None
    rec = None
    try:
        sim = corde_sim.load(scene, strings, guard=guard)
        rec = _Recorder(sim, keep_velocities)
        if sim.statics_mode:
            sim.statics()
            rec.frame()
        else:
            h = sim.time_step
            total = sim.duration if duration is None else float(duration)
            steps = max(0, math.ceil(total / h - 1e-9))
            if every is None:
                every = (max(1, round(1.0 / (out_rate * h))) if out_rate
                         else int(min(max(round(0.01 / h), 1), 1e9)))
            every = int(every)
            problem = sim.check()  # corde_run checks the scene's own start
            if problem:
                raise corde_sim.RunawayError(
                    "the run blew up at step 0 (t = %.6g s): %s" % (sim.time, problem))
            rec.frame()
            done = 0
            while done < steps:
                n = min(every, steps - done)
                sim.step(n)
                done += n
                rec.frame()
    except corde_sim.SceneError as e:
        row["status"], row["message"] = "scene_error", str(e)
    except corde_sim.Error as e:
        row["status"], row["message"] = "failed", str(e)
    except Exception as e:  # noqa: BLE001 - reported in the row, the other runs go on
        row["status"] = "error"
        row["message"] = "%s: %s" % (type(e).__name__, e)
    if sim is not None:
        row["sim_time"] = sim.time
        row["steps"] = sim.steps
        row["guard_events"] = len(sim.guard_events())
    row["frames"] = len(rec.times) if rec else 0
    row["wall_time"] = time.perf_counter() - start
    if collect:
        row["data"] = rec.arrays() if rec else None
    if out_path:
        attrs = {
            "format_version": FORMAT_VERSION,
            "scene": scene if isinstance(scene, str) else json.dumps(scene),
            "overrides": json.dumps(strings),
            "status": row["status"],
            "message": row["message"],
            "wall_time": row["wall_time"],
            "every": -1 if every is None else int(every),
        }
        for s in strings:
            k, v = s.split("=", 1)
            attrs["set:" + k] = v
        if rec is None:  # the scene did not load: a file with the attributes only
            import h5py

            tmp = "%s.tmp-%d" % (out_path, os.getpid())
            with h5py.File(tmp, "w") as f:
                for k, v in attrs.items():
                    f.attrs[k] = v
            os.replace(tmp, out_path)
        else:
            rec.write(out_path, attrs)
        marker = {k: v for k, v in row.items() if k != "data"}
        marker["key"] = key
        _atomic_write_text(marker_path(out_path), json.dumps(marker))
    return row


def read_result(path):
    """An HDF5 file of run_variant as a dict of numpy arrays: time, rods (list of dicts with
    name, positions, frames, energies, maybe velocities), reactions (support, rod, force,
    moment, point), guard_events (list of dicts), attrs."""
    import h5py

    with h5py.File(path, "r") as f:
        out = {"attrs": {k: (v.decode() if isinstance(v, bytes) else v)
                         for k, v in f.attrs.items()}}
        if "time" not in f:
            return out
        out["time"] = f["time"][()]
        out["rods"] = []
        for i in range(len(f["rods"])):
            g = f["rods"][str(i)]
            r = {"name": g.attrs["name"]}
            for k in g:
                r[k] = g[k][()]
            out["rods"].append(r)
        g = f["reactions"]
        out["reactions"] = {k: g[k][()] for k in ("force", "moment", "point")}
        for k in ("support", "rod"):
            out["reactions"][k] = [s.decode() if isinstance(s, bytes) else s for s in g[k][()]]
        out["guard_events"] = [json.loads(s) for s in f["events"]["guard"][()]]
    return out


# --- sweeps -------------------------------------------------------------------------------------
class SweepError(ValueError):
    pass


def _draw(rng, key, spec):
    if not isinstance(spec, dict) or len(set(spec) - {"clip"}) != 1:
        raise SweepError("random.keys.%s: needs one of uniform: [low, high], log_uniform: "
                         "[low, high], normal: [mean, std], choice: [values...] (and clip: "
                         "[low, high]), got %r" % (key, spec))
    kind = next(k for k in spec if k != "clip")
    args = spec[kind]
    if kind == "choice":
        if not isinstance(args, list) or not args:
            raise SweepError("random.keys.%s.choice: needs a non-empty list" % key)
        return args[int(rng.integers(len(args)))]
    if not isinstance(args, list) or len(args) != 2:
        raise SweepError("random.keys.%s.%s: needs a list of two (numbers or equal-length "
                         "lists), got %r" % (key, kind, args))
    try:
        a = np.asarray(args[0], dtype=float)
        b = np.asarray(args[1], dtype=float)
        a, b = np.broadcast_arrays(a, b)
    except (TypeError, ValueError):
        raise SweepError("random.keys.%s.%s: %r are not numbers or lists of equal length" %
                         (key, kind, args))
    if kind == "uniform":
        if np.any(b < a):
            raise SweepError("random.keys.%s.uniform: high < low" % key)
        x = a + (b - a) * rng.random(a.shape)
    elif kind == "log_uniform":
        if np.any(a <= 0) or np.any(b < a):
            raise SweepError("random.keys.%s.log_uniform: needs 0 < low <= high" % key)
        x = np.exp(np.log(a) + (np.log(b) - np.log(a)) * rng.random(a.shape))
    elif kind == "normal":
        if np.any(b < 0):
            raise SweepError("random.keys.%s.normal: std < 0" % key)
        x = a + b * rng.standard_normal(a.shape)
    else:
        raise SweepError("random.keys.%s: unknown distribution '%s' (uniform, log_uniform, "
                         "normal, choice)" % (key, kind))
    if "clip" in spec:
        lo, hi = spec["clip"]
        x = np.clip(x, lo, hi)
    return x.tolist() if x.ndim else float(x)


def expand_sweep(sweep):
    """The variants of a sweep (dict of the sweep file): a list of override dicts, in order.

    fixed: {key: value} for every variant; grid: {key: [values]} (every combination, keys in the
    file's order, the last varying fastest); random: {count, seed, keys: {key: distribution}}
    (draw i uses a generator seeded with [seed, i], so adding draws keeps the earlier ones). With
    grid and random, every grid point is combined with every draw."""
    fixed = sweep.get("fixed") or {}
    grid = sweep.get("grid") or {}
    random = sweep.get("random")
    if not isinstance(fixed, dict) or not isinstance(grid, dict):
        raise SweepError("fixed and grid must be maps of scene keys")
    for k, v in grid.items():
        if not isinstance(v, list) or not v:
            raise SweepError("grid.%s: needs a non-empty list of values, got %r" % (k, v))
    points = [dict(zip(grid, combo)) for combo in itertools.product(*grid.values())]
    draws = [{}]
    if random:
        if not isinstance(random, dict) or "count" not in random or "keys" not in random:
            raise SweepError("random: needs count, keys (and seed)")
        count = int(random["count"])
        seed = int(random.get("seed", 0))
        keys = random["keys"] or {}
        if count < 1 or not isinstance(keys, dict):
            raise SweepError("random: count >= 1 and keys as a map of scene keys")
        draws = []
        for i in range(count):
            rng = np.random.default_rng([seed, i])
            draws.append({k: _draw(rng, k, spec) for k, spec in keys.items()})
    return [dict(fixed, **p, **d) for p in points for d in draws]


def load_sweep(path):
    """The sweep file as a dict, scene path resolved against the file's folder."""
    import yaml

    with open(path) as f:
        sweep = yaml.safe_load(f)
    if not isinstance(sweep, dict) or "scene" not in sweep:
        raise SweepError("%s: a sweep file is a map with at least `scene:`" % path)
    known = {"scene", "fixed", "grid", "random", "out", "rate", "every", "duration", "guard",
             "velocities"}
    unknown = set(sweep) - known
    if unknown:
        raise SweepError("%s: unknown key(s) %s (known: %s)" % (
            path, ", ".join(sorted(unknown)), ", ".join(sorted(known))))
    base = os.path.dirname(os.path.abspath(path))
    sweep["scene"] = os.path.join(base, sweep["scene"])
    if sweep.get("out"):
        sweep["out"] = os.path.join(base, sweep["out"])
    return sweep


# --- the batch ----------------------------------------------------------------------------------
def _value_text(v):
    import corde_sim

    return corde_sim.yaml_value(v)


def write_summary(path, variants, rows):
    """summary.csv: one row per variant: id, one column per swept key (the YAML value text),
    status, message, wall_time, sim_time, steps, frames, guard_events, file."""
    keys = []
    for v in variants.values():
        for k in v:
            if k not in keys:
                keys.append(k)
    cols = ["id"] + keys + ["status", "message", "wall_time", "sim_time", "steps", "frames",
                            "guard_events", "file"]
    tmp = "%s.tmp-%d" % (path, os.getpid())
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for (vid, v), row in zip(variants.items(), rows):
            row = row or {"status": "not_run"}
            w.writerow([vid] + [_value_text(v[k]) if k in v else "" for k in keys] +
                       [row.get(c, "") for c in cols[len(keys) + 1:]])
    os.replace(tmp, path)


class _Progress:
    def __init__(self, total, stream=sys.stderr, enabled=True):
        self.total, self.done, self.failed = total, 0, 0
        self.stream, self.enabled = stream, enabled
        self.start = time.perf_counter()

    def update(self, failed=False, n=1):
        self.done += n
        self.failed += failed
        if not self.enabled:
            return
        frac = self.done / self.total if self.total else 1.0
        bar = "#" * int(30 * frac) + "-" * (30 - int(30 * frac))
        el = time.perf_counter() - self.start
        self.stream.write("\r[%s] %d/%d runs, %d failed, %.0f s" % (
            bar, self.done, self.total, self.failed, el))
        if self.done >= self.total:
            self.stream.write("\n")
        self.stream.flush()


def run_batch(scene, variants, out_dir, out_rate=None, every=None, duration=None, guard=True,
              keep_velocities=False, client=None, workers=None, retries=3, progress=True,
              rerun_failed=False):
    """Run the variants ({id: overrides} or a list of override dicts) on Dask and write
    out_dir/<id>.h5 per variant and out_dir/summary.csv. Variants whose done marker matches are
    skipped (failed ones too, unless rerun_failed). client: a distributed.Client (default: a
    LocalCluster of `workers` processes, one thread each, default os.cpu_count()). Returns the
    summary rows {id: row}."""
    if not isinstance(variants, dict):
        variants = {"v%04d" % i: v for i, v in enumerate(variants)}
    os.makedirs(out_dir, exist_ok=True)
    if isinstance(scene, str):
        scene = os.path.abspath(scene)
    rows = {}
    todo = []
    for vid, ov in variants.items():
        path = os.path.join(os.path.abspath(out_dir), vid + ".h5")
        key = variant_key(scene, ov, out_rate, every, duration, guard)
        marker = read_marker(path)
        if (marker and marker.get("key") == key and os.path.exists(path) and
                (marker["status"] == "ok" or not rerun_failed)):
            row = dict(marker)
            row.pop("key", None)
            row["file"] = vid + ".h5"
            rows[vid] = row
        else:
            todo.append((vid, ov, path, key))
    # Temporary files left by runs killed while writing (they run again).
    again = {vid for vid, _, _, _ in todo}
    for name in os.listdir(out_dir):
        if ".tmp-" in name and name.split(".h5", 1)[0] in again:
            os.unlink(os.path.join(out_dir, name))
    bar = _Progress(len(variants), enabled=progress)
    bar.update(n=len(rows), failed=sum(r["status"] != "ok" for r in rows.values()))
    summary = os.path.join(out_dir, SUMMARY_NAME)
    own_cluster = None
    if todo:
        from distributed import Client, LocalCluster, as_completed

        if client is None:
            own_cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1,
                                       threads_per_worker=1, processes=True,
                                       dashboard_address=None)
            client = Client(own_cluster)
        try:
            futures = {}
            batch_id = uuid.uuid4().hex[:8]  # a task key of an earlier batch is never reused
            for vid, ov, path, key in todo:
                fut = client.submit(run_variant, scene, ov, out_rate, path, duration, every,
                                    guard, keep_velocities, key,
                                    key="corde-%s-%s" % (vid, batch_id), pure=False,
                                    retries=retries)
                futures[fut] = vid
            last_write = time.perf_counter()
            for fut in as_completed(list(futures)):
                vid = futures[fut]
                try:
                    row = fut.result()
                except Exception as e:  # noqa: BLE001 - the worker died every time, or similar
                    row = {"status": "lost", "message": "%s: %s" % (type(e).__name__, e)}
                row["file"] = vid + ".h5"
                rows[vid] = row
                bar.update(failed=row["status"] != "ok")
                if time.perf_counter() - last_write > 5.0:
                    write_summary(summary, variants, [rows.get(v) for v in variants])
                    last_write = time.perf_counter()
        finally:
            if own_cluster is not None:
                client.close()
                own_cluster.close()
    write_summary(summary, variants, [rows.get(v) for v in variants])
    return {v: rows.get(v) for v in variants}


def main(argv=None):
    p = argparse.ArgumentParser(
        prog="corde_batch",
        description="Run the variants of a sweep (docs/python.md) on Dask: one HDF5 file per "
                    "variant and summary.csv in the output folder. Re-running skips finished "
                    "variants.")
    p.add_argument("sweep", help="sweep file (YAML): scene, fixed, grid, random, rate, ...")
    p.add_argument("--out", help="output folder (default: the sweep's `out`, else "
                                 "<sweep file name>_results in the working folder)")
    p.add_argument("--scheduler", help="address of a Dask scheduler (tcp://host:8786); default: "
                                       "a local cluster")
    p.add_argument("--workers", type=int, default=None,
                   help="local cluster: worker processes (default: this machine's cores, %d)" %
                        (os.cpu_count() or 1))
    p.add_argument("--rate", type=float, help="frames per simulated second (default: the "
                                               "sweep's, else 100)")
    p.add_argument("--every", type=int, help="a frame every K steps (instead of --rate)")
    p.add_argument("--duration", type=float, help="simulated time per run (default: the "
                                                  "sweep's, else the scene's)")
    p.add_argument("--retries", type=int, default=3,
                   help="times Dask starts a run again when its worker dies (default 3)")
    p.add_argument("--rerun-failed", action="store_true",
                   help="run the variants again that finished with a failure")
    p.add_argument("--list", action="store_true", help="print the variants and exit")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    a = p.parse_args(argv)
    try:
        sweep = load_sweep(a.sweep)
        variants = expand_sweep(sweep)
    except (OSError, SweepError, ValueError) as e:
        print("corde_batch: %s" % e, file=sys.stderr)
        return 1
    ids = {"v%04d" % i: v for i, v in enumerate(variants)}
    if a.list:
        import corde_sim

        for vid, v in ids.items():
            print(vid, " ".join(corde_sim.override_strings(v)))
        return 0
    out = (a.out or sweep.get("out") or
           os.path.splitext(os.path.basename(a.sweep))[0] + "_results")
    every = a.every if a.every is not None else sweep.get("every")
    rate = a.rate if a.rate is not None else sweep.get("rate")
    if every is None and rate is None:
        rate = 100.0
    duration = a.duration if a.duration is not None else sweep.get("duration")
    client = None
    if a.scheduler:
        from distributed import Client

        client = Client(a.scheduler)
    try:
        rows = run_batch(sweep["scene"], ids, out, out_rate=None if every else rate,
                         every=every, duration=duration, guard=sweep.get("guard", True),
                         keep_velocities=bool(sweep.get("velocities", False)), client=client,
                         workers=a.workers, retries=a.retries, progress=not a.no_progress,
                         rerun_failed=a.rerun_failed)
    except KeyboardInterrupt:
        print("corde_batch: interrupted; finished runs are kept, run again to go on",
              file=sys.stderr)
        return 130
    finally:
        if client is not None:
            client.close()
    failed = {v: r for v, r in rows.items() if r is None or r["status"] != "ok"}
    for v, r in failed.items():
        print("corde_batch: %s failed (%s): %s [%s]" % (
            v, (r or {}).get("status", "not_run"), (r or {}).get("message", ""),
            " ".join("%s=%s" % (k, _value_text(x)) for k, x in ids[v].items())), file=sys.stderr)
    print("corde_batch: %d of %d variants ok; summary: %s" % (
        len(rows) - len(failed), len(rows), os.path.join(out, SUMMARY_NAME)))
    return 0 if not failed else 3


if __name__ == "__main__":
    sys.exit(main())
