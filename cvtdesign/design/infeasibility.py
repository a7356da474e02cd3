"""Why a study found no feasible design: the constraint families that cannot be met, with the part and the margin.

When no start reaches a feasible point, each constraint row is evaluated at a set of designs spread over the
bounds: the base design and every corner of the design box (up to 2^MAX_CORNER_VARIABLES corners; beyond that
the study's starts). A row violated at every one of them is reported per
family, the row that misses most at its best design first: its part and envelope point (the row's label), its
value there and the bound. For the rows that depend on the design alone (clearance, envelope radius) the
closest any design within the bounds comes is then found exactly (IPOPT over the box, from the best of those
designs), so "for every design within the bounds" is said only when that closest design still violates the
row; for a row that depends on the operating points, the message says at which designs it was evaluated.
"""
from __future__ import annotations

import itertools

import casadi as ca
import numpy as np

from cvtdesign.design.problem import Problem
from cvtdesign.design.report import ROW_UNITS

MAX_CORNER_VARIABLES = 4
SKIP = ("worst_alpha", "epsilon")       # the epigraph rows: met by any large enough t
DESIGN_ONLY = ("clearance", "envelope_radius")   # rows of the design alone: pushed to the bounds' best
SHOW = {"m": (1e3, "mm"), "N": (1.0, "N"), "deg": (1.0, "°"), "": (1.0, "")}


def candidate_designs(problem: Problem, starts: np.ndarray) -> np.ndarray:
    """Normalised designs (rows) spread over the bounds: the base design, then the corners or the study's
    `starts` (design.solve.starts)."""
    n = len(problem.names)
    z_base = np.clip((problem.base_values - problem.lower) / (problem.upper - problem.lower), 0, 1)
    if n <= MAX_CORNER_VARIABLES:
        spread = np.array(list(itertools.product((0.0, 1.0), repeat=n)), float)
    else:
        spread = starts
    return np.unique(np.vstack([z_base[None, :], spread]), axis=0)


def _violations(problem: Problem, g: np.ndarray) -> np.ndarray:
    """How far each row misses its bounds, in report units (0 where met, beyond IPOPT's 1e-8 relaxation)."""
    scale = np.ones(g.size) if problem.g_report is None else problem.g_report
    miss = np.maximum(problem.g_lb - g, g - problem.g_ub)
    return np.where(miss > 1e-8 * np.maximum(1.0, np.abs(np.where(miss == problem.g_lb - g, problem.g_lb, problem.g_ub))),
                    miss * scale, 0.0)


def unmet_constraints(problem: Problem, starts: np.ndarray) -> list[dict]:
    """Per constraint family that no candidate design meets: {family, where, value, bound, unit, every_design,
    text}, the family whose row misses most first (module docstring). Computed once per problem."""
    if "unmet_constraints" not in problem.solvers:
        problem.solvers["unmet_constraints"] = _unmet(problem, starts)
    return problem.solvers["unmet_constraints"]


def _unmet(problem: Problem, starts: np.ndarray) -> list[dict]:
    zs = candidate_designs(problem, starts)
    G = []
    for z in zs:
        t = [float(problem.start_t(z))] if problem.epigraph else []
        G.append(problem.rows_and_points(np.concatenate([z, t]))[0])
    G = np.array(G)
    V = np.array([_violations(problem, g) for g in G])
    fam = np.array(problem.g_family)
    out = []
    for family in dict.fromkeys(problem.g_family):
        if family in SKIP:
            continue
        idx = np.flatnonzero(fam == family)
        least = V[:, idx].min(axis=0)                    # each row's smallest miss over the candidates
        if not np.any(least > 0):
            continue
        j = idx[int(np.argmax(least))]
        c = int(np.argmin(V[:, j]))
        row = _unmet_row(problem, j, zs[c], G[c, j], family)
        others = [problem.g_labels[i] for i in idx[least > 0] if i != j]
        if others and family in DESIGN_ONLY:
            row["text"] += f" (also {', '.join(others[:3])}{', …' if len(others) > 3 else ''})"
        elif others:
            row["text"] += f" (and {len(others)} more rows of {family})"
        out.append(row)
    return sorted(out, key=lambda r: -r["miss"]) or _conflict(problem, V, fam, len(zs))


def _conflict(problem: Problem, V: np.ndarray, fam: np.ndarray, n: int) -> list[dict]:
    """Where no one family rules out every design: the families the evaluated designs miss, each with how many
    of them miss it (a conflict between families: e.g. capacity wants larger rollers than the envelope
    radius allows). [] when some design evaluated meets every row (IPOPT's failure is then its own)."""
    missed = {f: int(np.sum(np.any(V[:, fam == f] > 0, axis=1))) for f in dict.fromkeys(problem.g_family)
              if f not in SKIP}
    missed = {f: k for f, k in sorted(missed.items(), key=lambda x: -x[1]) if k}
    if not missed or not np.all(np.any(V[:, np.isin(fam, list(missed))] > 0, axis=1)):
        return []
    spread = "every corner of the bounds" if len(problem.names) <= MAX_CORNER_VARIABLES else "the study's starts"
    parts = ", ".join(f"{f} ({k} of {n})" for f, k in missed.items())
    return [{"family": " and ".join(missed), "where": "", "value": None, "bound": None, "unit": "",
             "every_design": False, "miss": 0.0,
             "text": f"no one constraint rules out every design, but each design evaluated (the base design and "
                     f"{spread}) misses one of: {parts}: they conflict"}]


def _unmet_row(problem: Problem, j: int, z: np.ndarray, g: float, family: str) -> dict:
    """The report of row j, violated at every candidate (the closest: z, where it is g)."""
    upper = g > problem.g_ub[j]
    bound = problem.g_ub[j] if upper else problem.g_lb[j]
    design_row = family in DESIGN_ONLY
    if design_row:
        g = _closest(problem, j, z, upper)
    scale = 1.0 if problem.g_report is None else float(problem.g_report[j])
    factor, unit = SHOW[ROW_UNITS.get(family, "")]
    value, limit = g * scale * factor, bound * scale * factor
    every = design_row and (g > bound if upper else g < bound)
    verb = "reaches" if upper else "only reaches"
    rel = ">" if upper else "<"
    spread = "every corner of the bounds" if len(problem.names) <= MAX_CORNER_VARIABLES else "the study's starts"
    where = "for every design within the bounds" if every else f"at the base design and at {spread}"
    text = f"{family}: {problem.g_labels[j]} {verb} {value:.4g} {unit} {rel} {limit:.4g} {unit} {where}".replace("  ", " ")
    return {"family": family, "where": problem.g_labels[j], "value": value, "bound": limit, "unit": unit,
            "every_design": bool(every), "miss": abs(value - limit), "text": text}


def _closest(problem: Problem, j: int, z0: np.ndarray, upper: bool) -> float:
    """The design row j's least (upper bound) or largest (lower bound) value over the design box [IPOPT]."""
    pt = problem.parts
    n = len(problem.names)
    z = ca.MX.sym("z", n)
    x = ca.vertcat(z, ca.MX.zeros(pt.x.shape[0] - n))
    row = ca.substitute([pt.g_design], [pt.x], [x])[0][int(np.flatnonzero(pt.design_index == j)[0])]
    solver = ca.nlpsol("closest", "ipopt", {"x": z, "f": row if upper else -row},
                       {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"})
    sol = solver(x0=z0, lbx=0.0, ubx=1.0)
    return float(ca.Function("row", [z], [row])(sol["x"]))
