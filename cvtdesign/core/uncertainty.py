"""An interval on every figure: every uncertain input we know of (core.inputs: the calibration, the preload,
each material's modulus, each pair's friction, the law's own error, fitted effect parameters) carried to the
figures `compare` prints, to first order, with the model's exact derivatives; and each figure's budget, which
input contributes how much.

How. Each figure is an extreme or a mean over the envelope (core.metrics.extremes): its derivative in each
input is that of the output at the point (and contact) where it is taken, through the model's Newton solve by
the implicit function theorem (calibration and effect inputs are θ entries of the model; the physical ones its
design vector, core.inputs.uncertain_model); RMS α takes every point's. Inputs of one key are one quantity
(their derivatives add); different keys are independent. So σ_f² = Σ_key (g_key σ_key)², the interval is
f ± Z σ_f (95 %, Z = 1.96), and the budget gives each input its share (g_key σ_key)²/σ_f², summing to 1. The
difference of two variants' figures has its own σ over the union of their keys, shared keys cancelling
(`difference`). tests/unit/core/test_uncertainty.py checks the intervals against sampling the same inputs.

Contacts with the theory alone (uncalibrated) have no stated σ for their creep: their figures carry the other
inputs' spread and say that the theory's own gap (3.1–3.6× on Kim's CVT) is not in it.
"""
from __future__ import annotations

import math
import zlib
from dataclasses import dataclass

import numpy as np

from cvtdesign.core import steering
from cvtdesign.core.inputs import Input, model_inputs
from cvtdesign.core.metrics import envelopes, extremes, metrics
from cvtdesign.core.model import CompiledModel
from cvtdesign.core.sensitivity import derivatives
from cvtdesign.core import basis

Z95 = 1.959963984540054
OUTPUTS = ("alpha", "alpha_steering", "alpha_drive", "omega_2", "tau_1", "tau_2", "power_loss", "utilisation",
           "p_max", "steering_torque", *steering.INPUTS)


def covariance(model: CompiledModel) -> tuple[list[int], np.ndarray] | None:
    """(indices of the model's θ entries that are uncertain, their covariance): the calibration's scales (fully
    correlated where both roles rest on one calibration) and the fitted effect parameters with a stated σ; None
    where some contact's σ is unknown or no θ entry is uncertain. The θ part of the inputs, for a study that is
    robust to the calibration (design.robust)."""
    cal = basis.calibration(model.layout)
    if cal["uncalibrated"]:
        return None
    inputs = [i for i in model_inputs(model) if i.in_theta]
    if not inputs:
        return None
    idx, s = [], []
    for i in inputs:
        idx.append(model.param_names.index(i.target))
        s.append(i.std)
    keys = [i.key for i in inputs]
    corr = np.array([[1.0 if a == b else 0.0 for b in keys] for a in keys])
    return idx, np.outer(s, s) * corr


def sensitivities(model: CompiledModel, res: dict, points: np.ndarray, theta_idx: list[int],
                  outputs=OUTPUTS, wrt: str = "theta") -> dict:
    """d(output)/dθ[theta_idx] at the given flat point indices: {output: array (points, [contacts,] k)}. With
    wrt='design', the derivatives in the model's design inputs [theta_idx] instead, at design 0 (a tolerance
    study's deviations: design.tolerance)."""
    columns = {"theta": theta_idx if wrt == "theta" else [], "design": theta_idx if wrt == "design" else []}
    return _jacobian(model, res, points, columns, outputs)


def _jacobian(model: CompiledModel, res: dict, points: np.ndarray, columns: dict, outputs) -> dict:
    """d(output)/d(θ[columns['theta']], design[columns['design']]) at the given flat point indices, in that
    column order, then d(output)/d(load) where columns['load'] (a capacity's interval: core.capacity_interval);
    by the implicit function theorem at each point's solution (core.sensitivity)."""
    g, t = np.ravel(res["gamma_cmd"])[points], np.ravel(res["load"])[points]
    phi0, _ = model.steering_guess(g)
    w = np.ravel(res["omega_1"])[points]
    got = derivatives(model, g, w, t, phi0, list(outputs), columns["theta"], columns["design"],
                      bool(columns.get("load")))
    out = {}
    for n, v in zip(outputs, got):
        v = v.transpose(1, 0, 2)                                              # (points, rows, k)
        out[n] = v[:, 0, :] if v.shape[1] == 1 else v
    return out


def jacobians(model: CompiledModel, res: dict, points: np.ndarray, inputs: list[Input], outputs=OUTPUTS,
              load: bool = False) -> dict:
    """d(output)/d(input) at the given flat point indices for every input of `inputs` (core.inputs, θ ones
    first), then, with `load`, d(output)/d(load) [per N m]: {output: array (points, [contacts,] k)}."""
    columns = {"theta": [model.param_names.index(i.target) for i in inputs if i.in_theta],
               "design": list(range(model.design.numel())) if any(not i.in_theta for i in inputs) else [],
               "load": load}
    return _jacobian(model, res, points, columns, outputs)


def figure_gradients(model: CompiledModel, res: dict, inputs: list[Input]) -> dict:
    """{figure key: d figure/d input (k,)} for every figure of core.metrics.extremes and RMS α."""
    ext = extremes(model, res)
    ok = np.flatnonzero(np.ravel(res["ok"]))
    at = sorted({e.point for e in ext.values() if e.point is not None})
    d = jacobians(model, res, np.array(at, int), inputs)            # every output where an extreme is taken
    row = {p: i for i, p in enumerate(at)}
    val = {n: np.ravel(res[n]) if np.ndim(res[n]) == np.ndim(res["ok"]) else np.asarray(res[n]).reshape(
        np.shape(res[n])[0], -1) for n in OUTPUTS}
    deg = 180.0 / np.pi
    grads = {}
    for key, e in ext.items():
        if e.point is not None:
            grads[key] = _gradient(model, key, e, row[e.point], d, val, res) * (deg if "alpha" in key else 1.0)
    a = val["alpha"][ok]                                           # α at every ok point, for RMS α
    d_alpha = jacobians(model, res, ok, inputs, ("alpha",))["alpha"]
    grads["rms_alpha_deg"] = deg * np.mean(a[:, None] * d_alpha, axis=0) / np.sqrt(np.mean(a ** 2))
    return grads


@dataclass
class Spread:
    """A layout's figures' first-order spread: {figure: {input key: d figure / d input}}, each key's relative
    σ and its label (in a budget) and whether its σ was assumed."""
    gradients: dict
    std: dict
    labels: dict
    assumed: dict

    def sigma(self, figure: str) -> float:
        g = self.gradients[figure]
        return math.sqrt(sum((g[k] * self.std[k]) ** 2 for k in g))

    def budget(self, figure: str) -> dict:
        """{input label: share of the figure's variance}, largest first; the shares sum to 1."""
        g = self.gradients[figure]
        var = {self.labels[k]: (g[k] * self.std[k]) ** 2 for k in g}
        total = sum(var.values())
        if total <= 0:
            return {}
        return dict(sorted(((k, v / total) for k, v in var.items()), key=lambda kv: -kv[1]))


def spread(model: CompiledModel, res: dict) -> Spread | None:
    """The first-order spread of every figure of the model (an uncertain_model's, or a plain one's θ inputs
    alone), or None where no point is ok."""
    inputs = model_inputs(model)
    if not inputs or not res["ok"].any():
        return None
    return keyed_spread(inputs, figure_gradients(model, res, inputs))


def keyed_spread(inputs: list[Input], grads: dict) -> Spread:
    """The Spread of {figure: d figure/d input (k,)}, the derivatives of inputs of one key (one quantity) added."""
    by_key = {}
    for figure, g in grads.items():
        by_key[figure] = {}
        for inp, v in zip(inputs, g):
            by_key[figure][inp.key] = by_key[figure].get(inp.key, 0.0) + float(v)
    return Spread(by_key, {i.key: i.std for i in inputs}, {i.key: i.label for i in inputs},
                  {i.key: i.assumed for i in inputs})


def difference(a: Spread, b: Spread, figure: str) -> float:
    """σ of (figure of a − figure of b) over the union of their inputs, shared keys moving together."""
    ga, gb = a.gradients[figure], b.gradients[figure]
    std = a.std | b.std
    return math.sqrt(sum(((ga.get(k, 0.0) - gb.get(k, 0.0)) * std[k]) ** 2 for k in set(ga) | set(gb)))


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


def intervals(spread_: Spread | None, row: dict) -> dict:
    """{'<figure>_interval': [lo, hi], '<figure>_budget': {input: share}} (95 %, first order) for every figure
    of `row` that has a value, or {} where there is no spread (module docstring)."""
    if spread_ is None:
        return {}
    out = {}
    for key in spread_.gradients:
        if row.get(key) is None:
            continue
        half = Z95 * spread_.sigma(key)
        out[f"{key}_interval"] = [row[key] - half, row[key] + half]
        out[f"{key}_budget"] = spread_.budget(key)
    return out


BAND_KEYS = ("alpha", "alpha_steering", "alpha_drive", "efficiency")


def point_bands(model: CompiledModel, res: dict) -> dict:
    """{'<quantity>_band': half-width of its 95 % interval at every point of the grid (NaN where the point is
    not ok or the uncertainty is not known)} for α, its steering and drive parts [rad] and the efficiency [-]:
    the compare figure's bands. First order, as `intervals`."""
    shape = np.shape(res["ok"])
    out = {f"{k}_band": np.full(shape, np.nan) for k in BAND_KEYS}
    inputs = model_inputs(model)
    ok = np.flatnonzero(np.ravel(res["ok"]))
    if not inputs or ok.size == 0:
        return out
    s, keys = np.array([i.std for i in inputs]), [i.key for i in inputs]
    sigma = np.outer(s, s) * np.array([[a == b for b in keys] for a in keys], float)   # one key: one quantity
    d = jacobians(model, res, ok, inputs, ("alpha", "alpha_steering", "alpha_drive", "omega_2", "tau_1", "tau_2"))
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



BETTER = {"max_abs_alpha_deg": -1, "rms_alpha_deg": -1, "ratio_error_pct_at_max_load": -1, "min_efficiency": 1,
          "max_loss_no_output_W": -1}     # the figures an ordering is stated for, and which way is better


def orderings(rows: list[dict], spreads: list[Spread | None], samples: list[list[dict]] | None = None) -> list[dict]:
    """For every pair of variants (rows with a Spread) and each figure of BETTER: which is better, whether the
    difference is resolved, P(better is better) and the input that contributes most to the difference's
    variance (what would settle it). With each variant's `samples` (sampled_figures, paired through their
    shared inputs) P is the share of paired samples in which the better stays better, and the difference is
    resolved where that share is at least 97.5 %; without, to first order: P = Φ(|Δ|/σ_Δ), σ_Δ over both
    variants' inputs with shared inputs cancelling, resolved where |Δ| > 1.96 σ_Δ."""
    out = []
    by_name = dict(zip([r["name"] for r in rows], samples)) if samples else {}
    have = [(r, s) for r, s in zip(rows, spreads) if s is not None]
    for i, (ra, sa) in enumerate(have):
        for rb, sb in have[i + 1:]:
            for fig, sign in BETTER.items():
                if ra.get(fig) is None or rb.get(fig) is None or fig not in sa.gradients or fig not in sb.gradients:
                    continue
                delta = ra[fig] - rb[fig]
                sigma = difference(sa, sb, fig)
                a_better = sign * delta > 0
                better, worse = (ra, rb) if a_better else (rb, ra)
                p = 0.5 * (1 + math.erf(abs(delta) / (sigma * math.sqrt(2)))) if sigma > 0 else 1.0
                resolved = abs(delta) > Z95 * sigma
                if by_name.get(ra["name"]) and by_name.get(rb["name"]):
                    p = _paired_share(by_name[better["name"]], by_name[worse["name"]], fig, sign)
                    if p < 0.5:                          # the samples favour the other one
                        better, worse, p = worse, better, 1.0 - p
                    resolved = p >= 0.975
                out.append({"figure": fig, "better": better["name"], "worse": worse["name"],
                            "resolved": bool(resolved), "p_better": p, "method": "sampled" if by_name else "first order",
                            "difference": abs(delta), "difference_sigma": sigma,
                            "settle": _largest_share(sa, sb, fig)})
    return out


def _paired_share(better: list[dict], worse: list[dict], figure: str, sign: int) -> float:
    """The share of paired samples in which `better`'s figure is better than `worse`'s (a sample where either
    has no value counts against)."""
    wins = [b.get(figure) is not None and w.get(figure) is not None and sign * (b[figure] - w[figure]) > 0
            for b, w in zip(better, worse)]
    return float(np.mean(wins))


def _largest_share(a: Spread, b: Spread, figure: str) -> str | None:
    """The label of the input that contributes most to the variance of a's figure minus b's."""
    ga, gb, std = a.gradients[figure], b.gradients[figure], a.std | b.std
    var = {k: ((ga.get(k, 0.0) - gb.get(k, 0.0)) * std[k]) ** 2 for k in set(ga) | set(gb)}
    if not var or max(var.values()) <= 0:
        return None
    k = max(var, key=var.get)
    return (a.labels | b.labels)[k]


SAMPLE_TOLERANCE = 0.10   # a linear interval whose ends miss the sampled ones by more than this share of its
                          # width is replaced by the sampled one (the linearisation no longer holds there);
                          # below the 15 % an interval must hold to, by about the samples' own noise on an end


CHUNK_POINTS = 50_000    # operating points evaluated in one call when sampling (memory: about 100 kB a point)


def draw(inputs: list[Input], n: int, seed: int = 0) -> np.ndarray:
    """n samples of the inputs' deviations, (n, len(inputs)): normal for calibrations, effects, preloads and
    moduli, uniform (±σ√3) for friction and the law's error. Each key's draws come from a generator seeded by
    the key itself, so inputs of one key get one draw, in this layout and in any other that shares it (two
    variants' samples are then paired, as the quantity they share is one)."""
    by_key = {}
    for i in inputs:
        if i.key not in by_key:
            rng = np.random.default_rng([seed, zlib.crc32(i.key.encode())])
            uniform = i.kind in ("friction", "spin")
            by_key[i.key] = (rng.uniform(-1, 1, n) * i.std * math.sqrt(3)) if uniform else rng.normal(0, i.std, n)
    return np.column_stack([by_key[i.key] for i in inputs]) if inputs else np.zeros((n, 0))


def sample_arguments(model: CompiledModel, inputs: list[Input], x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The model's θ and design vector for each row of draws x (samples × inputs, `draw`): (θ rows, design
    rows), the θ inputs added to the model's own θ."""
    theta = np.tile(np.asarray(model.param_values, float), (len(x), 1))
    for j, i in enumerate(inputs):
        if i.in_theta:
            theta[:, model.param_names.index(i.target)] += x[:, j]
    return theta, x[:, [j for j, i in enumerate(inputs) if not i.in_theta]]


def sampled_figures(model: CompiledModel, n: int, seed: int = 0) -> list[dict]:
    """The figures (core.metrics.metrics) of n samples of every uncertain input of an uncertain_model."""
    inputs = model_inputs(model)
    theta, design = sample_arguments(model, inputs, draw(inputs, n, seed))
    chunk = max(1, CHUNK_POINTS // model.layout.gamma_grid.size // model.layout.load_grid.size)
    return [metrics(model, r) for k in range(0, n, chunk) for r in envelopes(model, design[k:k + chunk], theta[k:k + chunk])]


def checked_by_sampling(row: dict, samples: list[dict]) -> dict:
    """The row's intervals checked against the samples' 2.5–97.5 % range: where an end misses
    by more than SAMPLE_TOLERANCE of the linear interval's width, the sampled range replaces it, with
    `<figure>_interval_method` 'sampled'; elsewhere 'first order, checked'; where over a tenth of the samples
    have no value (the figure left the physics there), no interval is given and the method says so."""
    out = {}
    for key in [k.removesuffix("_interval") for k in row if k.endswith("_interval")]:
        values = np.array([s[key] for s in samples if s.get(key) is not None], float)
        lo, hi = row[f"{key}_interval"]
        if values.size < 0.9 * len(samples):
            out[f"{key}_interval"] = None
            out[f"{key}_interval_method"] = f"left the physics in {len(samples) - values.size} of {len(samples)} samples"
            continue
        s_lo, s_hi = np.percentile(values, [2.5, 97.5])
        if max(abs(s_lo - lo), abs(s_hi - hi)) > SAMPLE_TOLERANCE * (hi - lo):
            out[f"{key}_interval"] = [float(min(s_lo, row[key])), float(max(s_hi, row[key]))]
            out[f"{key}_interval_method"] = f"sampled ({len(samples)})"
        else:
            out[f"{key}_interval_method"] = f"first order, checked by {len(samples)} samples"
    return out
