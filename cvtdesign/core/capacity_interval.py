"""The 95 % interval of every load capacity and its budget: every uncertain input of core.inputs (the
calibration, the preloads, each material's modulus, each pair's friction, the law's own error) carried to the
capacity that core.capacity finds at each γ and sign.

First order, by the implicit function theorem. Where the search ends on a smooth limit, the capacity τc is the
load at which the limiting measure h(τ, x) reaches its bound: the limiting contact's utilisation |F|/(μN)
(gross_slip), its normal force N (lost_contact), its Hertz peak pressure (pressure; the allowable pressure is a
property of the material, not uncertain here) or the slip angle α (usable_ratio). Holding h at its bound,

    dτc/dx = −(∂h/∂x) / (∂h/∂τ),

both derivatives exact, from the model's Jacobian through its Newton solve (core.uncertainty.jacobians). Inputs
of one key are one quantity; the interval is τc ± Z σ and the budget each key's share of σ², as compare's
(core.uncertainty.Spread).

A runaway ends where the model has no steady state left, with the apparent axis γ + α at the pole of the speed
ratio (core.capacity). There dα/dτ stays finite (the box at γ 80°: 0.0557 rad per N·m at the last load that
held, the same at 0.9 of it): the apparent axis reaches the pole at a finite rate, and the model stops within
a few hundredths of a degree before it (α 9.978° of the 10° that would put the axis at 90°). So the runaway's
measure is α as well, held at its value at the capacity: −(∂α/∂x)/(∂α/∂τ) is the derivative of the load at
which the axis reaches the pole. Where exactly before the pole the solver stops depends on its numerics, not on
the inputs: the stop's own derivative in the preload differs by 5 % (2.61 against 2.49 N·m per unit of
relative preload), well inside the sampled check's tolerance.

`with_intervals(..., samples=n)` repeats the whole search for n draws of every input (one vectorised search) and
replaces a first-order interval by the sampled range where its ends miss by more than
core.uncertainty.SAMPLE_TOLERANCE of its width, as compare does (tests/unit/core/test_capacity_interval.py:
the first order against central differences of the search and against 200 samples, a runaway included).
"""
from __future__ import annotations

import numpy as np

from cvtdesign.core.capacity import LIMITS, capacity
from cvtdesign.core.inputs import Input, model_inputs
from cvtdesign.core.model import CompiledModel
from cvtdesign.core.uncertainty import (Spread, checked_by_sampling, draw, intervals, jacobians, keyed_spread,
                                        sample_arguments)

MEASURE = {"gross_slip": "utilisation", "lost_contact": "N", "pressure": "p_max", "usable_ratio": "alpha",
           "runaway": "alpha"}
SIDES = ("max", "min")


def figure(side: str) -> str:
    """The JSON name of a capacity figure (its interval and budget are `<figure>_interval`, `<figure>_budget`)."""
    return f"tau_perp_{side}_Nm"


def capacity_spreads(model: CompiledModel, cap: dict) -> list[Spread | None]:
    """Per γ of a core.capacity result: the first-order Spread of its capacities ('tau_perp_max_Nm',
    'tau_perp_min_Nm') where the search ended on a smooth limit under load (module docstring), None where
    neither side did or the model has no uncertain input."""
    inputs = model_inputs(model)
    n = len(cap["gamma"])
    grads = [dict() for _ in range(n)]
    if inputs:
        for side in SIDES:
            for i, g in _first_order(model, cap, side, inputs).items():
                grads[i][figure(side)] = g
    return [keyed_spread(inputs, g) if g else None for g in grads]


def _first_order(model: CompiledModel, cap: dict, side: str, inputs: list[Input]) -> dict:
    """{γ index: dτc/d(input) (k,)} for the capacities of one side that end on a smooth limit."""
    tau, limit, contact = cap[f"tau_perp_{side}"], cap[f"limit_{side}"], cap[f"contact_{side}"]
    rows = [i for i in range(len(tau)) if limit[i] in MEASURE and np.isfinite(tau[i]) and tau[i] != 0]
    out = {}
    for name in {MEASURE[limit[i]] for i in rows}:
        mine = [i for i in rows if MEASURE[limit[i]] == name]
        res = model.evaluate(cap["gamma"][mine], tau[mine])
        d = jacobians(model, res, np.arange(len(mine)), inputs, (name,), load=True)[name]
        for j, i in enumerate(mine):
            row = d[j] if d.ndim == 2 else d[j, contact[i]]      # the limiting contact's measure
            if row[-1] != 0 and np.all(np.isfinite(row)):
                out[i] = -row[:-1] / row[-1]
    return out


def with_intervals(model: CompiledModel, cap: dict, rows: list[dict], samples: int = 0, seed: int = 0) -> list[dict]:
    """The capacity JSON rows (uses.load_capacity.variant_record's) with '<figure>_interval', '<figure>_budget' and
    '<figure>_interval_method' for each side: first order, and, with `samples` > 0, each interval checked
    against that many draws (module docstring)."""
    spreads = capacity_spreads(model, cap)
    out = [r | intervals(s, r) for r, s in zip(rows, spreads)]
    for r in out:
        for side in SIDES:
            if f"{figure(side)}_interval" in r:
                r[f"{figure(side)}_interval_method"] = "first order"
    if samples > 0 and model_inputs(model):
        for i, values in enumerate(_sampled(model, cap, samples, seed)):
            linear = [s for s in SIDES if out[i].get(f"{figure(s)}_interval_method") == "first order"]
            row = {k: out[i][k] for s in linear for k in (figure(s), f"{figure(s)}_interval")}
            out[i] |= checked_by_sampling(row, [{figure(s): _value(values[s][k]) for s in linear}
                                                for k in range(samples)])
    return out


def _value(v: float) -> float | None:
    return None if np.isnan(v) else float(v)


def _sampled(model: CompiledModel, cap: dict, n: int, seed: int) -> list[dict]:
    """The capacities at every γ of `cap` for n draws of every input, searched together: per γ {side: (n,)
    capacities, NaN where the search ended on no limit of the CVT}."""
    inputs = model_inputs(model)
    theta, design = sample_arguments(model, inputs, draw(inputs, n, seed))
    m = len(cap["gamma"])
    got = capacity(model, np.tile(cap["gamma"], n), cap["bound"], cap["safety"],
                   None if np.isnan(cap["max_slip"]) else cap["max_slip"],
                   design=np.repeat(design, m, axis=0), theta=np.repeat(theta, m, axis=0))
    values = [{} for _ in range(m)]
    for side in SIDES:
        tau = np.asarray(got[f"tau_perp_{side}"], float).reshape(n, m)
        known = np.isin(np.asarray(got[f"limit_{side}"]).reshape(n, m), LIMITS)
        for j in range(m):
            values[j][side] = np.where(known[:, j], tau[:, j], np.nan)
    return values
