"""An interval on every figure: the calibration's uncertainty carried to the figures `compare` prints, to first
order, with the model's exact derivatives.

What is uncertain. Each contact's creep compliance rests on a calibration (core.basis): a library
calibration, the variant's fitted constants or its calibration factors, each with a relative standard
deviation σ (docs/materials.md). It enters the model as the scales of `drive_longitudinal_creep` and
`steering_lateral_creep` (θ = (s_D, s_S), nominal 1: under Kim's law the compliance is s·ε, under Kalker's the
calibration multiplies it by s), with covariance Σ = diag(σ_D, σ_S) R diag(σ_D, σ_S), R's correlation 1 where
both roles rest on one calibration and 0 otherwise. Effect parameters fitted to measurements add their own
σ (the variant's effect_uncertainty, as `cvtdesign diagnose` reports them), independent of the calibration.

How. Each figure is an extreme or a mean over the envelope (core.metrics.extremes): its derivative in θ is
that of the output at the point (and contact) where it is taken, dα/dθ through the model's Newton solve by the
implicit function theorem; RMS α takes every point's. To first order σ_f² = gᵀ Σ g, and the interval is
f ± Z σ_f (95 %, Z = 1.96). tests/unit/core/test_uncertainty.py checks it against sampling θ from N(1, Σ); the
docs say up to which σ the first order holds.

Contacts with the theory alone (uncalibrated) have no stated σ: their figures get no interval (their
uncertainty is the theory's gap to a measurement, 3.1–3.6× on Kim's CVT, not a statistical one).
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from cvtdesign.core import basis
from cvtdesign.core.effects import CALIBRATION
from cvtdesign.core.metrics import extremes
from cvtdesign.core import steering
from cvtdesign.core.model import CompiledModel

Z95 = 1.959963984540054
SCALES = {side: f"{effect}.scale" for side, effect in CALIBRATION.items()}
OUTPUTS = ("alpha", "alpha_steering", "alpha_drive", "omega_2", "tau_1", "tau_2", "power_loss", "utilisation",
           "p_max", "steering_torque", *steering.INPUTS)


def covariance(model: CompiledModel) -> tuple[list[int], np.ndarray] | None:
    """(indices of the model's θ entries that are uncertain, their covariance): the calibration's scales, and
    the effect parameters whose σ the variant gives (effect_uncertainty, independent of the rest); None where
    some contact's σ is unknown (uncalibrated, or not stated) or no θ entry is uncertain."""
    cal = basis.calibration(model.layout)
    if cal["uncalibrated"]:
        return None
    roles = [r for r in basis.ROLES if any(basis.role_of(x) == r for x in model.layout.rollers)]
    if any(cal["std"][r] is None for r in roles):
        return None
    roles = [r for r in roles if SCALES[r] in model.param_names]
    s = np.array([cal["std"][r] for r in roles])
    corr = np.ones((len(roles), len(roles))) if cal["same_source"] else np.eye(len(roles))
    fitted = {f"{e}.{p}": v for e, ps in model.layout.effect_uncertainty.items() for p, v in ps.items()
              if f"{e}.{p}" in model.param_names}
    idx = [model.param_names.index(SCALES[r]) for r in roles] + [model.param_names.index(k) for k in fitted]
    if not idx:
        return None
    cov = np.zeros((len(idx), len(idx)))
    cov[:len(roles), :len(roles)] = np.outer(s, s) * corr
    cov[len(roles):, len(roles):] = np.diag(np.square(list(fitted.values())))
    return idx, cov


def sensitivities(model: CompiledModel, res: dict, points: np.ndarray, theta_idx: list[int],
                  outputs=OUTPUTS, wrt: str = "theta") -> dict:
    """d(output)/dθ[theta_idx] at the given flat point indices: {output: array (points, [contacts,] k)}. With
    wrt='design', the derivatives in the model's design inputs [theta_idx] instead, at design 0 (a tolerance
    study's deviations: design.tolerance)."""
    pf = model.point_function(list(outputs))
    ins = [ca.MX.sym(n, pf.sparsity_in(i)) for i, n in enumerate(pf.name_in())]
    outs = pf.call(ins)
    th = ins[pf.name_in().index(wrt)]
    jac = ca.Function("sens", ins, [ca.jacobian(o, th)[:, theta_idx] for o in outs])
    g, t = np.ravel(res["gamma_cmd"])[points], np.ravel(res["load"])[points]
    phi0, _ = model.steering_guess(g)
    w = np.ravel(res["omega_1"])[points]
    mapped = jac.map(points.size, "thread", 2)
    got = mapped.call([g, w, t, np.zeros(points.size), phi0, model.param_values,
                       np.zeros((model.design.numel(), 1))])
    k = len(theta_idx)
    out = {}
    for n, v in zip(outputs, got):
        v = np.asarray(v).reshape(-1, points.size, k).transpose(1, 0, 2)      # (points, rows, k)
        out[n] = v[:, 0, :] if v.shape[1] == 1 else v
    return out


def figure_gradients(model: CompiledModel, res: dict, theta_idx: list[int]) -> dict:
    """{figure key: d figure/dθ (k,)} for every figure of core.metrics.extremes and RMS α."""
    ext = extremes(model, res)
    ok = np.flatnonzero(np.ravel(res["ok"]))
    at = sorted({e.point for e in ext.values() if e.point is not None})
    d = sensitivities(model, res, np.array(at, int), theta_idx)     # every output where an extreme is taken
    row = {p: i for i, p in enumerate(at)}
    val = {n: np.ravel(res[n]) if np.ndim(res[n]) == np.ndim(res["ok"]) else np.asarray(res[n]).reshape(
        np.shape(res[n])[0], -1) for n in OUTPUTS}
    deg = 180.0 / np.pi
    grads = {}
    for key, e in ext.items():
        if e.point is not None:
            grads[key] = _gradient(model, key, e, row[e.point], d, val, res) * (deg if "alpha" in key else 1.0)
    a = val["alpha"][ok]                                           # α at every ok point, for RMS α
    d_alpha = sensitivities(model, res, ok, theta_idx, ("alpha",))["alpha"]
    grads["rms_alpha_deg"] = deg * np.mean(a[:, None] * d_alpha, axis=0) / np.sqrt(np.mean(a ** 2))
    return grads


def _gradient(model: CompiledModel, key: str, e, i: int, d: dict, val: dict, res: dict) -> np.ndarray:
    """d(figure)/dθ at its extreme (row i of the sensitivities)."""
    k = e.point
    if key.startswith("max_abs_alpha"):
        name = {"max_abs_alpha_deg": "alpha", "max_abs_alpha_steering_deg": "alpha_steering",
                "max_abs_alpha_drive_deg": "alpha_drive"}[key]
        return np.sign(val[name][k]) * d[name][i]
    if key == "ratio_error_pct_at_max_load":       # |100 (ideal − ω2/ω1)/ideal|
        w1, ideal = np.ravel(res["omega_1"])[k], float(model.frame.ideal_ratio(np.ravel(res["gamma_cmd"])[k]))
        err = (ideal - val["omega_2"][k] / w1) / ideal
        return np.sign(err) * (-100.0 / ideal) * d["omega_2"][i] / w1
    if key == "min_efficiency":
        w1 = np.ravel(res["omega_1"])[k]
        p1, p2 = val["tau_1"][k] * w1, val["tau_2"][k] * val["omega_2"][k]
        dp1 = w1 * d["tau_1"][i]
        dp2 = val["tau_2"][k] * d["omega_2"][i] + val["omega_2"][k] * d["tau_2"][i]
        (p_in, dp_in), (p_out, dp_out) = ((p1, dp1), (p2, dp2)) if p1 >= p2 else ((p2, dp2), (p1, dp1))
        return -(dp_out * p_in - p_out * dp_in) / p_in ** 2
    if key == "max_loss_no_output_W":
        return d["power_loss"][i]
    if key == "max_steering_torque_Nm":
        return np.sign(val["steering_torque"][k]) * d["steering_torque"][i]
    if key == "max_standstill_steering_torque_Nm":
        return standstill_gradient(model, res, k, {q: d[q][i] for q in steering.INPUTS})
    name = "utilisation" if key == "max_traction_utilisation" else "p_max"
    return d[name][i][e.contact] / (1e6 if name == "p_max" else 1.0)


def standstill_gradient(model: CompiledModel, res: dict, k: int, d: dict) -> np.ndarray:
    """d(standstill steering torque)/dθ at flat point k from the exact derivatives of what it is made of
    (d: core.steering.INPUTS, each contacts × θ), through the quadrature by core.steering.standstill_slope
    (θ's entries are scales of order 1: a step of 1e-4)."""
    n_c = len(model.layout.rollers)
    at = {q: np.asarray(res[q], float).reshape(n_c, -1)[:, k:k + 1] for q in steering.INPUTS}
    ratios = [r.fork_ratio for r in model.layout.rollers]
    return np.array([steering.standstill_slope(at, {q: d[q][:, j:j + 1] for q in steering.INPUTS}, ratios, 1e-4)[0]
                     for j in range(next(iter(d.values())).shape[1])])


def intervals(model: CompiledModel, res: dict, row: dict) -> dict:
    """{'<figure>_interval': [lo, hi]} (95 %, first order) for every figure of `row` that has a value, or {}
    where the calibration's uncertainty is not known (module docstring)."""
    cov = covariance(model)
    if cov is None or not res["ok"].any():
        return {}
    idx, sigma = cov
    out = {}
    for key, g in figure_gradients(model, res, idx).items():
        if row.get(key) is None:
            continue
        half = Z95 * float(np.sqrt(max(g @ sigma @ g, 0.0)))
        out[f"{key}_interval"] = [row[key] - half, row[key] + half]
    return out


BAND_KEYS = ("alpha", "alpha_steering", "alpha_drive", "efficiency")


def point_bands(model: CompiledModel, res: dict) -> dict:
    """{'<quantity>_band': half-width of its 95 % interval at every point of the grid (NaN where the point is
    not ok or the uncertainty is not known)} for α, its steering and drive parts [rad] and the efficiency [-]:
    the compare figure's bands. First order, as `intervals`."""
    shape = np.shape(res["ok"])
    out = {f"{k}_band": np.full(shape, np.nan) for k in BAND_KEYS}
    cov = covariance(model)
    ok = np.flatnonzero(np.ravel(res["ok"]))
    if cov is None or ok.size == 0:
        return out
    idx, sigma = cov
    d = sensitivities(model, res, ok, idx, ("alpha", "alpha_steering", "alpha_drive", "omega_2", "tau_1", "tau_2"))
    w1, w2 = np.ravel(res["omega_1"])[ok], np.ravel(res["omega_2"])[ok]
    t1, t2 = np.ravel(res["tau_1"])[ok], np.ravel(res["tau_2"])[ok]
    p1, p2 = t1 * w1, t2 * w2
    dp1, dp2 = w1[:, None] * d["tau_1"], t2[:, None] * d["omega_2"] + w2[:, None] * d["tau_2"]
    first = (p1 >= p2)[:, None]
    p_in, p_out = np.maximum(p1, p2)[:, None], np.minimum(p1, p2)[:, None]
    dp_in, dp_out = np.where(first, dp1, dp2), np.where(first, dp2, dp1)
    with np.errstate(invalid="ignore", divide="ignore"):           # efficiency = −p_out/p_in (metrics.efficiency)
        d["efficiency"] = -(dp_out * p_in - p_out * dp_in) / p_in ** 2
    for k in BAND_KEYS:
        half = Z95 * np.sqrt(np.maximum(np.einsum("pi,ij,pj->p", d[k], sigma, d[k]), 0.0))
        band = out[f"{k}_band"].ravel()
        band[ok] = half
        out[f"{k}_band"] = band.reshape(shape)
    out["efficiency_band"][~(np.asarray(res["efficiency"]) > 0)] = np.nan     # no power in, or none out
    return out

