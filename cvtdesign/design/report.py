"""The report of a solve: the binding constraints, and the optimised design as a variant file.

`constraint_report` gives, per constraint family, the most binding row (value, bound, slack, multiplier,
active), in the row's report units (normal force in newtons). `variant_text` / `write_variant` make the
base variant with the optimised design a variant file `compare` reads, with a provenance header; they
refuse a solution that did not succeed, the envelope check included (no variant file for a design outside
the model's physics).
"""
from __future__ import annotations

import datetime
from pathlib import Path

import numpy as np
import yaml

from cvtdesign.design.problem import Problem
from cvtdesign.design.solution import Solution
from cvtdesign.io.output import make_folder, write_file
from cvtdesign.io.units import registry

ACTIVE_TOL = 1e-7   # a constraint within this (relative) slack of its bound counts as active


# the unit of each constraint family's value, bound and slack in the report (ROW_UNITS; '' dimensionless:
# hertz_pressure is p_max/p_allow, traction (|F| − (1 − m)μN)/(μP), reach_gamma the linkage misfit)
ROW_UNITS = {"worst_alpha": "deg", "epsilon": "deg", "normal_force": "N", "clearance": "m", "envelope_radius": "m"}


def constraint_report(problem: Problem, sol: Solution) -> list[dict]:
    """Per constraint family, the most binding row: value, bound, slack, multiplier and whether active.
    Values, bounds and slacks are in the row's `unit` (ROW_UNITS: normal_force in newtons, worst_alpha in
    degrees, lengths in metres; a design variable's bound in SI), the multiplier per that unit."""
    rows = []
    scale = np.ones(problem.g_lb.size) if problem.g_report is None else problem.g_report
    for fam in dict.fromkeys(problem.g_family):
        idx = [i for i, f in enumerate(problem.g_family) if f == fam]
        slack = np.minimum(sol.g[idx] - problem.g_lb[idx], problem.g_ub[idx] - sol.g[idx])
        j = idx[int(np.argmin(slack))]
        bound = problem.g_ub[j] if np.isfinite(problem.g_ub[j]) and problem.g_ub[j] - sol.g[j] <= sol.g[j] - problem.g_lb[j] \
            else problem.g_lb[j]
        s = float(np.min(slack))
        active = bool(s <= ACTIVE_TOL * max(1.0, abs(bound)))
        lam = float(np.max(np.abs(sol.lam_g[idx]) / scale[idx]))
        rows.append({"name": fam, "where": problem.g_labels[j], "value": float(sol.g[j] * scale[j]),
                     "bound": float(bound * scale[j]), "slack": s * float(scale[j]), "multiplier": lam,
                     "active": active, "unit": ROW_UNITS.get(fam, "")})
    for i, n in enumerate(problem.names):
        at_lo, at_hi = sol.z[i] < 1e-6, sol.z[i] > 1 - 1e-6
        if at_lo or at_hi:
            rows.append({"name": f"bound {n}", "where": "lower" if at_lo else "upper",
                         "value": sol.design[n], "bound": float(problem.lower[i] if at_lo else problem.upper[i]),
                         "slack": 0.0, "multiplier": float(abs(sol.lam_x[i]) / (problem.upper[i] - problem.lower[i])),
                         "active": True, "unit": "SI"})
    return rows


def _unit_of(raw) -> str | None:
    if isinstance(raw, str) and not raw.strip().startswith("="):
        return str(registry().Quantity(raw.strip()).units)
    return None


def variant_text(problem: Problem, sol: Solution, out_dir: Path, name: str | None = None,
                 study: bool = False) -> tuple[Path, str]:
    """(path, text) of the optimised design as a variant file `compare` reads, with a provenance header
    (name: default '<base variant>_<study>'): the base variant with the optimised design variables, the
    case's sweep parameters, the study's effects and envelope (when it sets them); `study`: written by
    `cvtdesign study` (named in the header), else by `optimise`. Refuses a solution that did not
    succeed, the envelope check included (no variant file for a design outside the model's physics)."""
    if not sol.success:
        raise ValueError(f"not writing a variant for a failed solve (status {sol.status})")

    data = yaml.safe_load(problem.base_file.read_text())
    # the design variables, the case's sweep parameters, and the envelope the design was optimised over
    # (a study's narrower envelope is what the clearance and reach constraints held for)
    if problem.spec.envelope is not None:
        data["envelope"] = problem.spec.envelope.model_dump(exclude_unset=True)
    if problem.spec.effects is not None:  # the model the design was optimised with (rolling resistance, ...)
        data["effects"] = list(problem.spec.effects)
    if problem.spec.calibration:          # the fitted effect parameters the design was optimised with
        data["effect_parameters"] = problem.vspec.effect_parameters
    for n, v in (problem.fixed | sol.design).items():
        unit = _unit_of(data["parameters"][n])
        if unit:
            q = registry().Quantity(v, registry().Quantity(1, unit).to_base_units().units).to(unit)
            data["parameters"][n] = f"{q.magnitude:.6g} {unit}"
        else:
            data["parameters"][n] = float(f"{v:.6g}")
    name = name or f"{data['name']}_{problem.spec.name}"
    data["description"] = f"{problem.spec.name} optimum of {data['name']}. " + problem.spec.description
    data["name"] = name
    header = (f"# Optimised by `cvtdesign {'study' if study else 'optimise'} {problem.study_file}`\n"
              f"# study: {problem.spec.name}; objective: {problem.spec.objective.kind} = {sol.objective:.6g}\n"
              f"# date: {datetime.datetime.now().isoformat(timespec='seconds')}; solver: IPOPT, status "
              f"{sol.status}, {sol.iterations} iterations, start {sol.start}\n"
              f"# base variant: {problem.base_file}\n"
              + (f"# calibration: {problem.spec.calibration} (fitted effect parameters)\n" if problem.spec.calibration else ""))
    return Path(out_dir) / f"{name}.yaml", header + yaml.safe_dump(data, sort_keys=False, allow_unicode=True)


def write_variant(problem: Problem, sol: Solution, out_dir: Path, name: str | None = None) -> Path:
    """Write `variant_text` into `out_dir` (an output folder: created if missing); returns the path."""
    path, text = variant_text(problem, sol, out_dir, name)
    make_folder(out_dir, kind="variant folder")
    return write_file(path, text, kind="variant file")


