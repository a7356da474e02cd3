"""`cvtdesign optimise --report`: the optimum as a review reads it. It opens with a summary in plain words
(the optimum against the base design, then how sure it is), then the figures (the optimum beside the base
design, how the solve converged, the room each constraint family leaves), then the printed tables, and it
ends with a glossary of every figure, column and constraint family."""
from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np

from cvtdesign.design.objectives import objective
from cvtdesign.io.plots import beside_figure, convergence_figure, slack_figure
from cvtdesign.io.report import Glossary, Heading, Summary, png_figure
from cvtdesign.io.units import degrees, engineering
from cvtdesign.io.variant import load_variant

FIGURES = [
    ("Figure 1", "the base design (left column) and the optimum (right column) in the three orthogonal views (a row "
                 "each, the same view of both side by side), on one "
                 "scale, at commanded γ = 45°: each roller labelled with its role and its shaft or fork"),
    ("Figure 2", "how the solve converged: left, the best start's IPOPT iterations, its objective and its primal "
                 "infeasibility (how far the constraints are from holding; log scale), each working-set round "
                 "shaded in turn (a round adds the envelope rows the previous one violated, so the objective may "
                 "rise between rounds); right, every start's optimum, the best marked"),
    ("Figure 3", "each constraint family's most binding row: its slack as a share of its bound, in percent "
                 "(0: active, the optimum sits on it), with the slack in its unit"),
]
COLUMNS = [
    ("variable, optimum, base, lower, upper", "a design variable of the study, its value at the optimum and in the "
                                              "base variant, and the bounds the study allows"),
    ("constraint", "a constraint family (below); the table shows its most binding row"),
    ("where", "that row: the roller and the operating point (γ, τ⊥) or the pair of rollers it concerns"),
    ("value, bound", "the row's value at the optimum and the bound it must keep, in the row's unit"),
    ("slack", "how far the value is from the bound (0: active)"),
    ("multiplier", "how much the objective would improve per unit the bound were loosened (the Lagrange "
                   "multiplier), e.g. °/mm"),
    ("active", "yes when the optimum sits on the bound: it holds the optimum back"),
]
FAMILIES = [
    ("worst_alpha", "the epigraph rows ±α ≤ t at every envelope point: t is the worst |α| the objective minimises"),
    ("epsilon", "of a Pareto point: worst |α| ≤ ε"),
    ("hertz_pressure", "the Hertz peak pressure over the material's allowable pressure, ≤ 1 at every contact and point"),
    ("traction", "(|F| − (1 − margin)μN)/(μP) ≤ 0: every contact keeps the study's traction margin"),
    ("steering_torque", "the steering motor's torque while rolling and at standstill over the study's "
                        "max_steering_torque (1: at the limit)"),
    ("normal_force", "every contact's normal force N at least the study's minimum (5 % of the preload unless set), in N"),
    ("clearance", "the gap between every two rollers at least the study's clearance, in mm"),
    ("envelope_radius", "every roller within the study's envelope radius from the sphere's centre, in mm"),
    ("reach_gamma", "the steering linkage reaches every commanded γ of the envelope (its misfit ≤ 1e-6)"),
    ("bound <variable>", "a design variable at its lower or upper bound"),
]


def _changes(res: dict, kinds: dict) -> str:
    """'d = 31.94 mm (base 60 mm), r_steer = 20 mm (base 38 mm)'."""
    return ", ".join(f"{n} = {engineering(v, kinds[n][0])} (base {engineering(res['base_design'][n], kinds[n][0])})"
                     for n, v in res["design"].items())


def summary(res: dict, kinds: dict, objective: str) -> Summary:
    """The optimum against the base design in plain words, then how sure it is: how many starts found it,
    IPOPT's status, the whole-envelope check, the constraints it sits on. objective: 'worst |α| = 3.779°'."""
    if not res["success"]:
        return Summary(f"No optimum: no start of study {res['study']} solved and passed the whole-envelope check "
                       f"({res['status']}); no variant file was written.", "See the notes below for the best failure.")
    answer = f"The optimum of study {res['study']}: {objective}"
    base, best = res.get("base_envelope_check") or {}, res["envelope_check"]
    b, o = base.get("max_abs_alpha_deg"), best["max_abs_alpha_deg"]
    if b is not None and o is not None and math.isfinite(b) and math.isfinite(o) and b > 0:
        answer += f"; over the whole envelope its worst |α| is {degrees(o)} against {degrees(b)} for the base design"
        answer += f" ({100 * (b - o) / b:.1f} % less)" if o <= b else f" ({100 * (o - b) / b:.1f} % more)"
    answer += f". It has {_changes(res, kinds)}."
    found = res["optima"][0]["found"] if res["optima"] else 0
    active = [c for c in res["active_constraints"] if c != "worst_alpha"]    # the objective's own epigraph rows
    binds = (f"It sits on {', '.join(active)}: loosening those would improve it further, at the rates the "
             "constraints table gives (multiplier)." if active else "No constraint binds: an interior optimum.")
    sure = (f"How sure: {found} of {res['starts']} starts reached it ({len(res['optima'])} distinct optima in all); "
            f"IPOPT: {res['status']}; checked on the whole envelope by the model: {best['points']} operating points, "
            f"{best['points'] - best['failed']} inside the physics. {binds}")
    return Summary(answer, sure)


def slack_rows(res: dict, table) -> list[tuple[str, str, float, bool]]:
    """(family, the slack as the constraints table writes it (`table`: cli.optimise.constraint_table) and
    as a share of the bound (of the value where the bound is 0), that share [%], active) per constraint
    family, from its most binding row."""
    out = []
    for r, cells in zip(res["constraints"], table.rows):
        of, scale = ("bound", abs(r["bound"])) if r["bound"] else ("value", abs(r["value"]))
        share = 100.0 * max(r["slack"], 0.0) / scale if scale else 0.0
        text = f"{cells[4]} ({share:.0f} % of the {of})" if share >= 10 else f"{cells[4]} ({share:.2g} % of the {of})"
        if r["name"] == "worst_alpha":
            text = "the objective's own rows (α ≤ t): always on them"
        out.append((r["name"], text, share, bool(r["active"]) and r["name"] != "worst_alpha"))
    return out


def figures(res: dict, kinds: dict, constraints) -> list:
    """The report's figures (written to a temporary folder, embedded, removed)."""
    label = objective(res["objective_kind"]).axis
    with tempfile.TemporaryDirectory() as tmp:
        paths = [Path(tmp) / f"{n}.png" for n in ("beside", "convergence", "slack")]
        base = load_variant(res["base_variant"])
        optimum = load_variant(res["base_variant"], dict(res["design"]))
        beside_figure([("base design", base), (f"optimum: {_changes(res, kinds)}", optimum)], np.radians(45.0), paths[0])
        convergence_figure(res["history"], res["start_objectives"], label, paths[1])
        slack_figure(slack_rows(res, constraints), paths[2])
        captions = ["Figure 1. The optimum beside the base design.", "Figure 2. How the solve converged.",
                    "Figure 3. The room each constraint family leaves at the optimum."]
        return [png_figure(p, c) for p, c in zip(paths, captions)]


def report_blocks(res: dict, blocks: list, kinds: dict, objective: str, constraints) -> list:
    """The report: summary, figures (when there is an optimum), the printed blocks, glossary. objective: the
    optimum's objective as printed; constraints: the printed constraints table (None without an optimum)."""
    shown = [Heading("Figures"), *figures(res, kinds, constraints)] if res["success"] else []
    return [summary(res, kinds, objective), *shown, Heading("Tables"), *blocks, Glossary(FIGURES + COLUMNS + FAMILIES)]
