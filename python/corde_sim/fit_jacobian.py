"""Analytic Jacobian columns for a statics fit (corde_fit --statics).

At a static equilibrium the library gives how the nodes move with a material key
(Simulation.statics_sensitivity: dx/dp = -H^-1 dg/dp through the equilibrium's Hessian), in the
same solve that gives the residual. The fit's residual is r = (markers(nodes) - points) / scale
over the log-parameters theta = log p, so its column for p is

    dr/dtheta = p * (dmarkers/dnodes . dnodes/dp) / scale,

dmarkers/dnodes the directional derivative of the marker map (a cubic spline through the nodes
in the arc length of the first frame's nodes): linear in the nodes for fixed knots, and the knots'
own dependence taken by a central difference of that map (cheap, no simulation). Columns of
parameters the library cannot differentiate (damping, drag, friction, keys of other rods) stay
finite differences (fit.Problem.jacobian)."""

from __future__ import annotations

import re
from typing import Dict, List, Optional, Sequence

import numpy as np

from .fit_recording import FitError
from .fit_sim import Job, markers, node_arc_lengths, statics_at_times

# Material keys whose statics sensitivity the library computes (scene_statics.h).
ANALYTIC_KEYS = ("E", "G", "E_s", "B", "C", "K_s", "kappa", "rho")


def analytic_key(key: str, rod: str) -> Optional[str]:
    """The library's parameter name for a fitted scene key, or None: rods.<rod>.material.<K>
    (also rods[<rod>]) with K in ANALYTIC_KEYS and <rod> the fitted rod."""
    m = re.fullmatch(r"rods(?:\.|\[)([^.\[\]]+)\]?\.material\.([A-Za-z_]+)", key)
    if not m or m.group(2) not in ANALYTIC_KEYS:
        return None
    return m.group(2) if m.group(1) == str(rod) else None


def _spline_derivative(nodes: np.ndarray, dnodes: np.ndarray, s: np.ndarray) -> np.ndarray:
    """d markers(nodes + e dnodes, arc lengths of their first frame) / de at e = 0: (F, M, 3).
    Central difference of the marker map, exact for its linear part (the spline's values) and
    second order in the knots (the first frame's chord lengths)."""
    size = max(np.abs(dnodes).max(), 1e-300)
    extent = max(np.ptp(nodes[0], axis=0).max(), 1e-3)
    e = 1e-6 * extent / size
    plus, minus = nodes + e * dnodes, nodes - e * dnodes
    mp = markers(plus, node_arc_lengths(plus[0]), s)
    mm = markers(minus, node_arc_lengths(minus[0]), s)
    return (mp - mm) / (2.0 * e)


def statics_with_sensitivity(job: Job, names: Sequence[str]):
    """The statics job's nodes (F, N+1, 3) at job.times and their derivatives by each library
    parameter in `names` (P, F, N+1, 3), from one solve per time."""
    out, dout = [], []
    for sim, rod, d in statics_at_times(
            job, lambda sim, rod: sim.statics_sensitivity(list(names), rod=rod)):
        out.append(np.array(sim.positions(rod)))
        dout.append([np.asarray(d[n]) for n in names])
    nodes = np.array(out)
    return nodes, np.transpose(np.array(dout), (1, 0, 2, 3))


def marker_job_with_sensitivity(args):
    """For an executor: (job, arc lengths, [(library name, value)]) -> (markers (F, M, 3),
    d markers / d log p for each parameter (P, F, M, 3))."""
    job, s, params = args
    names = [n for n, _ in params]
    nodes, dnodes = statics_with_sensitivity(job, names)
    pts = markers(nodes, node_arc_lengths(nodes[0]), s)
    dpts = np.array([value * _spline_derivative(nodes, dn, s)
                     for (_, value), dn in zip(params, dnodes)])
    return pts, dpts


def analytic_columns(params, rod: str, statics: bool, mode: str) -> Dict[int, str]:
    """Column index -> library parameter name of the fitted parameters whose Jacobian column
    comes from the library's sensitivity: in a statics fit with mode 'auto'; none with 'fd'."""
    if mode not in ("auto", "fd"):
        raise FitError(f"jacobian: 'auto' or 'fd', got '{mode}'")
    if not statics or mode == "fd":
        return {}
    out = {}
    for j, p in enumerate(params):
        name = analytic_key(p.key, rod)
        if name is not None:
            out[j] = name
    return out


def parameter_values(theta, columns: Dict[int, str]) -> List[tuple]:
    return [(columns[j], float(np.exp(theta[j]))) for j in sorted(columns)]
