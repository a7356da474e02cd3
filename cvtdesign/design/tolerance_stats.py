"""The statistics of a tolerance study: each of compare's figures over the samples, its first-order prediction
from the model's exact derivatives (the linearised envelope), the check of one against the other, and each
toleranced dimension's effect. The method is in design.tolerance's docstring and docs/tolerances.md.
"""
from __future__ import annotations

from statistics import NormalDist

import numpy as np
import pandas as pd

from cvtdesign.core import steering
from cvtdesign.core.metrics import batch_figures, efficiency
from cvtdesign.core.model import CompiledModel
from cvtdesign.core.tolerances import KINDS
from cvtdesign.core.uncertainty import OUTPUTS, sensitivities
from cvtdesign.design.tolerance import FIGURES, LINEAR_DRAWS, LINEAR_STREAM, stream_draws
from cvtdesign.design.tolerance_inputs import columns

EFFECT_NODES = 33       # equal-probability points of a dimension's distribution for its effect
STANDSTILL_STEP = 1e-3  # × σ: the step of the standstill torque's central differences along each slope
BATCH = 250             # linearised envelopes taken at once (each output: contacts × BATCH × points values)


def first_order(model: CompiledModel, nominal: dict, content, xs: np.ndarray) -> dict:
    """The linearised envelope and its figures: {"draws": LINEAR_DRAWS deviations of its own (draws,
    dimensions + inputs), "values": its figures at them (draws, FIGURES), "at_samples": its figures at the
    deviations `xs`, "ok": the points it is taken over (flat indices), "slopes": every output's derivatives
    there, in each dimension and each physical input}."""
    ok = np.flatnonzero(np.ravel(nominal["ok"]))
    slopes = derivatives(model, nominal, ok, content)
    slopes["steering_torque_standstill"] = standstill_slopes(model, nominal, ok, slopes, content.sources)
    for name in steering.INPUTS[1:]:
        del slopes[name]
    draws = stream_draws(content, LINEAR_STREAM, LINEAR_DRAWS)
    return {"draws": draws, "values": linearised_figures(model, nominal, ok, slopes, draws),
            "at_samples": linearised_figures(model, nominal, ok, slopes, xs), "ok": ok, "slopes": slopes}


def derivatives(model: CompiledModel, nominal: dict, ok: np.ndarray, content) -> dict:
    """Every output's exact derivatives at the ok points `ok` in each dimension, then each physical input
    (design.tolerance_inputs.columns: a θ input through its θ entries, a design one through its column):
    {output: (points, [contacts,] dimensions + inputs)}. OUTPUTS include core.steering.INPUTS, what the
    standstill torque is made of."""
    if not content.inputs:
        return sensitivities(model, nominal, ok, list(range(len(content.dims))), OUTPUTS, wrt="design")
    theta_idx, E = columns(model, len(content.dims), content.inputs)
    d = sensitivities(model, nominal, ok, list(range(model.design.numel())), OUTPUTS, wrt="design")
    if theta_idx:
        t = sensitivities(model, nominal, ok, theta_idx, OUTPUTS, wrt="theta")
        d = {k: np.concatenate([t[k], v], axis=-1) for k, v in d.items()}
    return {k: v @ E for k, v in d.items()}


def linearised_figures(model: CompiledModel, nominal: dict, ok: np.ndarray, slopes: dict, xs: np.ndarray) -> np.ndarray:
    """FIGURES of the envelope with every output at the ok points `ok` (flat indices) moved to first order,
    nominal + slopes·x, for each row x of `xs`: (len(xs), FIGURES), NaN where a figure has no point. BATCH
    rows at once (core.metrics.batch_figures)."""
    out = np.full((len(xs), len(FIGURES)), np.nan)
    fixed = {k: np.ravel(nominal[k]) for k in ("gamma_cmd", "load", "omega_1", "ok")}
    for start in range(0, len(xs), BATCH):
        x = xs[start:start + BATCH]
        res = dict(fixed)
        for name, d in slopes.items():
            v = np.asarray(nominal[name], float)
            if d.ndim == 3:                                   # a contact's output: d (points, contacts, inputs)
                moved = np.repeat(v.reshape(v.shape[0], 1, -1), len(x), axis=1)             # (contacts, rows, points)
                moved[:, :, ok] += np.einsum("pci,ri->crp", d, x)
            else:
                moved = np.repeat(v.reshape(1, -1), len(x), axis=0)                          # (rows, points)
                moved[:, ok] += x @ d.T
            res[name] = moved
        res["efficiency"] = efficiency(res["tau_1"] * res["omega_1"], res["tau_2"] * res["omega_2"])
        got = batch_figures(model, res)
        out[start:start + len(x)] = np.column_stack([got[k] for k in FIGURES])
    return out


def standstill_slopes(model: CompiledModel, nominal: dict, ok: np.ndarray, slopes: dict, dims) -> np.ndarray:
    """d(steering motor's torque at standstill)/dx at the ok points (points, dimensions) [N·m per SI unit]:
    the exact derivatives of what it is made of (core.steering.INPUTS) carried through its quadrature by
    central differences along them (core.steering.standstill_slope, step STANDSTILL_STEP·σ_j). The quadrature is
    numpy's, so it costs 2 of its evaluations a dimension rather than one a linearised envelope."""
    at = {k: np.asarray(nominal[k], float).reshape(len(model.roller_names), -1)[:, ok] for k in steering.INPUTS}
    ratios = [r.fork_ratio for r in model.layout.rollers]
    out = np.zeros((ok.size, len(dims)))
    for j, d in enumerate(dims):
        along = {k: slopes[k][:, :, j].T for k in steering.INPUTS}
        out[:, j] = steering.standstill_slope(at, along, ratios, STANDSTILL_STEP * (d.std or 1.0))   # σ 0: any step
    return out


def effects(model: CompiledModel, nominal: dict, fo: dict, dims) -> np.ndarray:
    """Each dimension's effect on each figure [figure unit], (FIGURES, dimensions): the figure's spread on
    the linearised envelope when that dimension alone deviates, taken over EFFECT_NODES equal-probability
    points of its distribution (scaled to its σ exactly). With the extreme at one point it is |∂f/∂x_j| σ_j;
    where several points come close it is what x_j alone does to their largest."""
    out = np.full((len(FIGURES), len(dims)), np.nan)
    for j, d in enumerate(dims):
        p = (np.arange(EFFECT_NODES) + 0.5) / EFFECT_NODES
        z = np.array([NormalDist().inv_cdf(q) for q in p]) if d.distribution == "normal" else 2 * p - 1
        xs = np.zeros((EFFECT_NODES, len(dims)))
        xs[:, j] = z / np.std(z) * d.std
        values = linearised_figures(model, nominal, fo["ok"], fo["slopes"], xs)
        out[:, j] = np.std(values, axis=0)
    return out


def slopes(table: pd.DataFrame, fo: dict, dims) -> np.ndarray:
    """The check of the sensitivities against the sampling: each figure's least-squares slope on each
    deviation over the samples that held, times the deviation's σ [figure unit], (2, FIGURES, dimensions):
    [0] of the sampled figures, [1] of the first-order values at the same deviations (`fo`'s at_samples, so
    the draws' noise is the same in both). NaN where a figure has no more values than dimensions + 1."""
    held = (table["status"] == "ok").to_numpy()
    xs = table[[f"x.{d.label}" for d in dims]].to_numpy(float)[held]
    basis = np.column_stack([np.ones(len(xs)), xs])
    std = np.array([d.std for d in dims])
    out = np.full((2, len(FIGURES), len(dims)), np.nan)
    for k, values in enumerate((table[list(FIGURES)].to_numpy(float)[held], fo["at_samples"][held])):
        for f in range(len(FIGURES)):
            y = values[:, f]
            m = np.isfinite(y)
            if m.sum() > len(dims) + 1:
                out[k, f] = np.linalg.lstsq(basis[m], y[m], rcond=None)[0][1:] * std
    return out


def summary(table: pd.DataFrame, nominal: dict, fo: dict, eff: np.ndarray, slope: np.ndarray, content) -> dict:
    """The study's JSON body: `samples` and `figures` (each: nominal, mean, std, p05, p95 over the samples
    that held; first_order_mean, first_order_std of the linearised envelope), `first_order_at_samples`
    (mean, std and RMS difference from the samples of the first-order values at the samples' own
    deviations), `effects` (per figure, the dimensions and physical inputs ranked by their first-order effect
    `eff`, from `effects`, each with its `slopes` check: slope_sampled, slope_first_order), the samples left
    out by status, the dimensions, and the physical inputs sampled (`inputs`) and not (`inputs_left_out`)."""
    dims = content.dims
    held = (table["status"] == "ok").to_numpy()
    sampled = table[list(FIGURES)].to_numpy(float)
    out = {"samples": int(len(table)), "samples_held": int(held.sum()),
           "samples_left_out": {str(k): int(v) for k, v in table.loc[~held, "status"].value_counts().items()},
           "figures": {}, "first_order_at_samples": {}, "effects": {}}
    for f, key in enumerate(FIGURES):
        v, lin, at = sampled[held, f], fo["values"][:, f], fo["at_samples"][held, f]
        out["figures"][key] = {"nominal": _value(nominal[key]), **_spread(v), "first_order_mean": _mean(lin),
                               "first_order_std": _std(lin)}
        both = np.isfinite(v) & np.isfinite(at)
        out["first_order_at_samples"][key] = {"mean": _mean(at[both]), "std": _std(at[both]), "rms_difference":
                                              _value(np.sqrt(np.mean((at[both] - v[both]) ** 2)) if both.any() else None)}
        rank = np.argsort(-np.nan_to_num(np.abs(eff[f]), nan=-1.0))
        out["effects"][key] = [_source(content, j) | {"effect": _value(eff[f, j]), "slope_sampled": _value(
            slope[0, f, j]), "slope_first_order": _value(slope[1, f, j])} for j in rank]
    out["dimensions"] = [{"label": d.label, "dimension": d.kind, "rollers": list(d.rollers), "distribution": d.distribution,
                          "size": d.size, "std": d.std, "unit": {"angle": "rad", "length": "m"}.get(KINDS[d.kind], "")}
                         for d in dims]
    out["inputs"] = [{"label": s.label, "key": s.key, "kind": s.kind, "distribution": s.distribution, "size": s.size,
                      "std": s.std, "assumed": s.assumed, "unit": "relative"} for s in content.inputs]
    out["inputs_left_out"] = dict(content.left_out)
    return out


def _source(content, j: int) -> dict:
    """How an effect names the j-th thing sampled: {"dimension": label}, or {"input": label, "kind": kind}."""
    if j < len(content.dims):
        return {"dimension": content.dims[j].label}
    s = content.inputs[j - len(content.dims)]
    return {"input": s.label, "kind": s.kind}


def _value(v):
    return None if v is None or not np.isfinite(v) else float(v)


def _mean(v):
    v = v[np.isfinite(v)]
    return _value(np.mean(v)) if v.size else None


def _std(v):
    v = v[np.isfinite(v)]
    return _value(np.std(v, ddof=1)) if v.size > 1 else None


def _spread(v) -> dict:
    """mean, std, p05 and p95 of the finite values (None where there are none; std needs two)."""
    v = v[np.isfinite(v)]
    if not v.size:
        return dict.fromkeys(("mean", "std", "p05", "p95"))
    return {"mean": _mean(v), "std": _std(v), "p05": _value(np.percentile(v, 5)), "p95": _value(np.percentile(v, 95))}
