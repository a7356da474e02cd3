"""The sim-to-real gap: where it lies, which unmodelled effect causes it, how far it shrinks.

Method (each step is a plain function below):
 1. Prediction. Every row is an operating point (γ_cmd, ω1 and the lateral load τ⊥ = −τ1 sin γ + τ2 cos γ
    from the measured torques, Kim eq 17: the load the rig controls); the model with a set of effects
    (the effect vocabulary) predicts the slip angle α, the parallel torque τ∥ = τ1 cos γ + τ2 sin γ (the other,
    orthogonal torque component: ω1 τ∥ / cos γ is the power loss, so it carries the efficiency) and the axis
    angle γ_axis. Residuals = measured − predicted, in ° and N·m. Both torque components see the same
    torque noise, so the channels' noise does not grow with tan γ as τ1 given τ2 would.
 2. Noise. From replicates (pooled within-point scatter) or, without replicates, from second differences of
    the base fit's residuals along the load at each γ (a gap that is smooth in load cancels, noise does not),
    robust (MAD) and pooled over neighbouring γ, since the noise of α and τ1 depends on γ through the
    kinematics. Residuals divided by it are z-scores; they weight the fit.
 3. Fit. The effect parameters (effects.py bounds) by bounded Gauss-Newton (scipy least_squares) with
    the model's exact Jacobian (CasADi, through the Newton solves). Uncertainty from (JᵀJ)⁻¹; a parameter
    whose standard deviation exceeds its own scale is flagged as not identifiable.
 4. Where. Per operating point the mean α residual and its z; cells beyond 3σ form regions (connected on
    the γ × load grid, one sign); the gap is "structured" when the residual field is spatially
    autocorrelated (Moran-type lag-1 statistic over γ and load neighbours, z > 3.1: p < 0.001), which does
    not depend on the noise estimate.
 5. Which. Each candidate effect is added in turn and refitted; scored by K-fold cross-validation grouped by
    operating point (replicates stay together, so no point scores its own fit); the held-out gain is tested
    point by point (one-sided Wilcoxon signed-rank, Bonferroni over the candidates) and by BIC. The best
    significant candidate is accepted and the search repeats (greedy), so two effects can be found.
 6. Verdict. The first accepted effect; `none` when nothing is accepted and the base residual is not
    structured; `unexplained` when a structured gap remains that no candidate removes.
"""
from __future__ import annotations

import functools
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np
import pandas as pd
from scipy import ndimage
from scipy.optimize import least_squares
from scipy.stats import f_oneway, wilcoxon

from cvtdesign.core.effects import EFFECTS
from cvtdesign.core.contact.laws import candidates as effect_candidates
from cvtdesign.core.layout import Layout
from cvtdesign.core.metrics import efficiency
from cvtdesign.core.model import STATUS, compile_model, status_counts
from cvtdesign.diagnosis.measured import MEASURED_CHANNELS, Measured, merge_points

CHANNELS = ("alpha", "tau_par", "axis")        # [deg], [N m], [deg]
UNITS = {"alpha": "deg", "tau_par": "N*m", "axis": "deg"}
FAIL_Z = 1e3           # z-score of a row whose model solve fails (gross slip where the rig measured creep):
                       # far above any misfit, so a fit never buys its way out of residuals by failing rows
FOLDS = 5
P_ACCEPT = 0.01        # family-wise significance of accepting an effect (Bonferroni over candidates)
MIN_GAIN = 0.05        # and at least this relative drop of the held-out mean squared z
AUTO_Z = 3.1           # spatial autocorrelation z above which a residual field is structured (p < 0.001)
REGION_Z = 3.0         # operating points whose mean residual is beyond this many σ form the gap's regions
MAX_ADDED = 2          # greedy rounds: at most two effects are accepted (each round refits every candidate)
SHRINK_MIN = 0.8       # an effect is named only if the accepted effects remove this much of the gap beyond noise
MAX_FAIL = 0.05        # a candidate that fails (gross slip, lost contact) at more of the points is not accepted
FORM_BINS = 8          # quantile bins of a variable in the model-form checks (one-way ANOVA of the residual)


# ---------------------------------------------------------------------------------------------- predictor

class Predictor:
    """The model with `effects` evaluated at a dataset's rows: θ → predictions and their Jacobian."""

    def __init__(self, layout: Layout, effects, data: Measured):
        self.effects = tuple(effects)
        self.model = compile_model(layout, self.effects)
        self.names = list(self.model.param_names)
        self.defaults = np.array(self.model.param_values, float)
        r = data.rows
        g = np.radians(r["gamma_cmd_deg"].to_numpy())
        n = len(r)
        phi0, _ = self.model.steering_guess(g)
        th = ca.MX.sym("theta", len(self.names))
        F = self.model.point.map(n, "thread", 2)
        out = dict(zip(self.model.point.name_out(), F(g, r["omega_1"].to_numpy(), r["tau_perp"].to_numpy(), 0.0,
                                                     phi0, th, np.zeros(0))))
        _, tau_par = self.model.frame.load_split(g, out["tau_1"].T, out["tau_2"].T)
        y = ca.vertcat(out["alpha"].T, tau_par, out["gamma_axis"].T, out["omega_2"].T, out["tau_1"].T, out["tau_2"].T)
        self.n = n
        self._f = ca.Function("predict", [th], [y, out["status"].T])
        self._fj = ca.Function("predict_jac", [th], [y, out["status"].T, ca.jacobian(y, th)])

    def __call__(self, theta, jacobian=False):
        """Predictions {alpha [deg], tau_par [N m], axis [deg], omega_2 [rad/s], tau_1, tau_2 [N m]}, converged
        mask: the points where the model's physics holds (and dY/dθ, shape (6, n, p), with `jacobian`)."""
        theta = np.asarray(theta, float)
        outs = (self._fj if jacobian else self._f)(theta)
        y = np.asarray(outs[0]).reshape(6, self.n)
        ok = np.asarray(outs[1]).ravel() == 0      # the model's status: converged, in contact, no gross slip
        pred = {"alpha": np.degrees(y[0]), "tau_par": y[1], "axis": np.degrees(y[2]), "omega_2": y[3],
                "tau_1": y[4], "tau_2": y[5]}
        if not jacobian:
            return pred, ok
        J = np.asarray(outs[2]).reshape(6, self.n, -1)
        J[[0, 2]] = np.degrees(J[[0, 2]])
        return pred, ok, J


def _wrap_deg(x):
    return (x + 90.0) % 180.0 - 90.0


def residuals(data: Measured, pred: dict) -> dict:
    """Measured − predicted per channel (the axis only when measured)."""
    r = data.rows
    out = {"alpha": _wrap_deg(r["alpha_deg"].to_numpy() - pred["alpha"]),
           "tau_par": r["tau_par"].to_numpy() - pred["tau_par"]}
    if data.has_axis:
        out["axis"] = _wrap_deg(r["gamma_axis_deg"].to_numpy() - pred["axis"])
    return out


# ------------------------------------------------------------------------------------------------- noise

def _mad_std(x):
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if x.size < 3:
        return np.nan
    return 1.4826 * float(np.median(np.abs(x - np.median(x))))


def noise_levels(data: Measured, resid: dict) -> dict:
    """σ per channel and row [channel units]: from replicates if there are any (each row's deviation from
    its point's mean, √(n/(n−1)) scaled), else from second differences of `resid` along the load at each
    γ level (÷√6 for white noise); robust (MAD), pooled over the γ level and its two neighbours, then
    floored at 1e-9 of the largest so no row gets an infinite weight."""
    r = data.rows
    gb = r["gamma_bin"].to_numpy()
    levels = np.unique(gb)
    count = r.groupby("point")["point"].transform("size").to_numpy()
    out = {}
    for ch, res in resid.items():
        if data.replicated:
            dev = np.asarray(res, float) - pd.Series(res).groupby(r["point"].to_numpy()).transform("mean").to_numpy()
            dev = dev * np.sqrt(count / np.maximum(count - 1, 1))
            samples = {gl: dev[(gb == gl) & (count > 1)] for gl in levels}
        else:
            samples = {gl: _second_differences(r, res, np.flatnonzero(gb == gl)) for gl in levels}
        sig = {}
        for k, gl in enumerate(levels):
            pool = np.concatenate([samples[levels[j]] for j in range(max(0, k - 1), min(len(levels), k + 2))])
            sig[gl] = _mad_std(pool)
        s = np.array([sig[g] for g in gb])
        if not np.all(np.isfinite(s)):   # a γ level with too few samples near it: the pooled estimate
            # (over every replicate's deviation; never the scatter of the values themselves, which is the
            # whole signal: 4.3° for α where replicates at other γ gave 0.1°)
            pooled = np.concatenate(list(samples.values())) if data.replicated else res
            s = np.where(np.isfinite(s), s, _mad_std(pooled))
        out[ch] = np.maximum(s, 1e-9 * np.nanmax(s) + 1e-15)
    return out


def _noise_source(points: Measured, raw: Measured) -> str:
    """Where the noise estimate comes from (noise_levels): replicates, second differences along the load, or,
    where no γ level has 3 loads, the residuals' own scatter, which holds any gap as well."""
    if raw.replicated:
        return "replicates"
    loads = points.rows.groupby(["gamma_bin", "speed_bin"]).size()
    if (loads >= 3).any():
        return "second differences along load"
    return "scatter of the residuals, an upper bound: no replicates, and no γ with 3 loads"


def _second_differences(r, res, idx) -> np.ndarray:
    """(v[k] − 2 v[k+1] + v[k+2])/√6 of the residuals along the load, per motor-speed level, at rows idx."""
    parts = []
    for sb in np.unique(r["speed_bin"].to_numpy()[idx]):
        sub = idx[r["speed_bin"].to_numpy()[idx] == sb]
        v = res[sub[np.argsort(r["tau_perp"].to_numpy()[sub])]]
        if v.size >= 3:
            parts.append((v[:-2] - 2 * v[1:-1] + v[2:]) / np.sqrt(6))
    return np.concatenate(parts) if parts else np.array([])


def estimate_noise(P: Predictor, points: Measured, raw: Measured | None = None) -> dict:
    """σ of each channel at each operating point of `points` (merged replicates, measured.merge_points).

    The model predicts at the measured load, so the noise of a residual is the channel's own noise plus the
    load's noise carried through the model's slope, σ² = σ_c² + (∂c/∂τ⊥)² σ_τ⊥² (errors in variables).
    With replicates in `raw`, σ_c and σ_τ⊥ are the pooled scatter of the rows about their point's mean, the
    slope that of an unweighted first fit of P along the load, and the point's σ is divided by √count;
    without replicates, the second differences of that fit's residuals along the load hold both terms."""
    prelim = fit(P, points, {c: np.ones(P.n) for c in _channels(points)})
    if raw is None or not raw.replicated:
        return noise_levels(points, residuals(points, prelim.pred))
    cols = {c: col for c, col in MEASURED_CHANNELS.items() if c in _channels(raw)} | {"load": "tau_perp"}
    per_row = noise_levels(raw, {c: raw.rows[col].to_numpy() for c, col in cols.items()})
    first = raw.rows.reset_index(drop=True).groupby("point").head(1)
    idx = first.index.to_numpy()[np.argsort(first["point"].to_numpy())]
    n = points.rows["count"].to_numpy()
    out = {}
    for c in cols:
        if c != "load":
            slope = _load_slope(points, prelim.pred[c])
            out[c] = np.sqrt(per_row[c][idx] ** 2 + (slope * per_row["load"][idx]) ** 2) / np.sqrt(n)
    return out


def _load_slope(points: Measured, values: np.ndarray) -> np.ndarray:
    """∂values/∂τ⊥ at each point, by finite differences along the load at its γ and speed level."""
    r = points.rows
    out = np.zeros(len(r))
    for _, idx in r.groupby(["gamma_bin", "speed_bin"]).indices.items():
        if idx.size > 1:
            order = idx[np.argsort(r["tau_perp"].to_numpy()[idx])]
            t = r["tau_perp"].to_numpy()[order]
            if np.all(np.diff(t) > 0):
                out[order] = np.gradient(np.nan_to_num(values[order]), t)
    return out


def fit_model(layout: Layout, data: Measured, effects) -> tuple[Predictor, Fit]:
    """Fit the model with `effects` to the data (noise-weighted): the fitted model of resteering."""
    points = merge_points(data)
    P = Predictor(layout, effects, points)
    return P, fit(P, points, estimate_noise(P, points, data))


def zscores(resid: dict, noise: dict) -> np.ndarray:
    """(channels, rows) residuals in units of their noise."""
    return np.array([resid[c] / noise[c] for c in resid])


# --------------------------------------------------------------------------------------------------- fit

@dataclass
class Fit:
    effects: tuple
    names: list
    theta: np.ndarray
    std: np.ndarray
    identifiable: list
    pred: dict
    ok: np.ndarray
    chi2: float

    def params(self):
        return {n: {"value": float(v), "std": float(s), "identifiable": bool(i)}
                for n, v, s, i in zip(self.names, self.theta, self.std, self.identifiable)}


def _bounds(names):
    lo, hi = [], []
    for n in names:
        e, p = n.split(".")
        spec = EFFECTS[e].params[p]
        lo.append(spec.lower)
        hi.append(spec.upper)
    return np.array(lo), np.array(hi)


def _starts(P: Predictor, x0):
    """Start points: the given one, and each parameter that may take either sign started on the other side."""
    lo, _ = _bounds(P.names)
    starts = [np.array(x0, float)]
    for j in range(len(x0)):
        if lo[j] < 0 and x0[j] != 0:
            s = np.array(x0, float)
            s[j] = -s[j]
            starts.append(s)
    return starts


def fit(P: Predictor, data: Measured, noise: dict, rows=None, x0=None, multistart=True, max_nfev=40) -> Fit:
    """Least-squares fit of P's parameters to the z-scored residuals of `rows` (default: all); from x0 and,
    with `multistart`, from sign-flipped starts (`_starts`)."""
    rows = np.arange(P.n) if rows is None else np.asarray(rows)
    chans = [c for c in CHANNELS if c in noise]
    x0 = P.defaults if x0 is None else np.asarray(x0, float)
    lo, hi = _bounds(P.names)

    def zfun(theta, jac=False):
        out = P(theta, jacobian=jac)
        pred, ok = out[0], out[1]
        res = residuals(data, pred)
        z = np.array([res[c] / noise[c] for c in chans])[:, rows]
        okr = ok[rows]
        z[:, ~okr] = FAIL_Z
        if not jac:
            return z.ravel(), pred, ok
        J = out[2]
        Jz = -np.array([J[CHANNELS.index(c)] / noise[c][:, None] for c in chans])[:, rows]
        Jz[:, ~okr] = 0.0
        return z.ravel(), Jz.reshape(-1, len(theta))

    if len(x0) == 0:
        z, pred, ok = zfun(x0)
        return Fit(P.effects, [], x0, x0, [], pred, ok, float(z @ z))

    def f(theta):
        return zfun(theta)[0]

    def j(theta):
        return zfun(theta, True)[1]

    scale = np.maximum(np.abs(P.defaults), 1e-12)
    best = None
    for s in (_starts(P, x0) if multistart else [x0]):
        s = np.clip(s, lo + 1e-12 * scale, hi - 1e-12 * scale)
        sol = least_squares(f, s, jac=j, bounds=(lo, hi), x_scale=scale, method="trf", xtol=1e-8,
                            ftol=1e-8, max_nfev=max_nfev)
        if best is None or sol.cost < best.cost:
            best = sol
    theta = best.x
    z, pred, ok = zfun(theta)
    # σ from the points where the model holds: a failed point's FAIL_Z is a penalty, not a misfit
    held = np.tile(ok[rows], len(chans))
    std, ident = _uncertainty(best.jac, theta, P.defaults, float(z[held] @ z[held]), int(held.sum()))
    return Fit(P.effects, P.names, theta, std, ident, pred, ok, float(z @ z))


def _failed_points(P: Predictor, data: Measured, f: Fit) -> dict:
    """Where the fitted model has no physical solution (status ≠ ok), by status with the contacts named
    (model.status_counts), and those points' (γ [deg], τ⊥ [N m]): left out of the gap, its regions and map."""
    bad = ~f.ok
    r = data.rows
    g, t = r["gamma_cmd_deg"].to_numpy()[bad], r["tau_perp"].to_numpy()[bad]
    counts = {"points": 0} | {k: 0 for k in STATUS[1:]}
    if bad.any():
        res = P.model.evaluate(np.radians(g), t, speeds=r["omega_1"].to_numpy()[bad], theta=f.theta)
        counts = {"points": int(bad.sum())} | {k: v for k, v in status_counts(res, P.model.roller_names).items()
                                                 if k != "ok"}
    return counts | {"at": [{"gamma_cmd_deg": float(a), "tau_perp_Nm": float(b)} for a, b in zip(g, t)]}


def _uncertainty(J, theta, defaults, chi2, n):
    """Standard deviations from (JᵀJ)⁻¹ (z-scored residuals, so σ² = 1; inflated by the reduced χ² when the
    model does not fit to noise). Not identifiable: std above the parameter's own scale (max of |value|
    and |default|), or a singular JᵀJ."""
    p = len(theta)
    s2 = max(1.0, chi2 / max(n - p, 1))
    u, sv, vt = np.linalg.svd(J, full_matrices=False)
    if sv.size == 0 or sv[-1] <= 1e-10 * max(sv[0], 1e-300):
        std = np.full(p, np.inf)
        good = sv > 1e-10 * max(sv[0] if sv.size else 0, 1e-300)
        if good.any():
            cov = (vt[good].T / sv[good] ** 2) @ vt[good] * s2
            std = np.where(np.abs(vt[~good]).max(axis=0) > 1e-3, np.inf, np.sqrt(np.diag(cov)))
    else:
        cov = (vt.T / sv ** 2) @ vt * s2
        std = np.sqrt(np.diag(cov))
    ident = [bool(np.isfinite(s) and s <= max(abs(t), abs(d))) for s, t, d in zip(std, theta, defaults)]
    return std, ident


# ---------------------------------------------------------------------------------------- cross-validation

def folds(data: Measured, k: int = FOLDS, seed: int = 0) -> np.ndarray:
    """Fold index per row, grouped by operating point (replicates share a fold)."""
    pts = data.rows["point"].to_numpy()
    uniq = np.unique(pts)
    perm = np.random.default_rng(seed).permutation(uniq.size)
    fold_of_point = np.empty(uniq.size, int)
    fold_of_point[perm] = np.arange(uniq.size) % k
    return fold_of_point[np.searchsorted(uniq, pts)]


def heldout(P: Predictor, data: Measured, noise: dict, full: Fit, fold: np.ndarray) -> dict:
    """Held-out predictions: each fold predicted by the fit on the other folds (warm-started at the full fit)."""
    pred = {c: np.full(P.n, np.nan) for c in ("alpha", "tau_par", "axis", "omega_2", "tau_1", "tau_2")}
    ok = np.zeros(P.n, bool)
    for k in np.unique(fold):
        test = fold == k
        f = fit(P, data, noise, rows=np.flatnonzero(~test), x0=full.theta, multistart=False, max_nfev=15)
        for c in pred:
            pred[c][test] = f.pred[c][test]
        ok[test] = f.ok[test]
    return {"pred": pred, "ok": ok}


# ------------------------------------------------------------------------------------------- where

def autocorrelation_z(data: Measured, z: np.ndarray) -> float:
    """Lag-1 spatial autocorrelation of the per-point mean z over the γ × load grid (neighbours in γ and
    in load), as a z-statistic: ≈ N(0, 1) for white residuals, large for a smooth structured gap."""
    grid = point_grid(data, z)
    v = grid - np.nanmean(grid)
    prods = []
    for a, b in ((v[1:, :], v[:-1, :]), (v[:, 1:], v[:, :-1])):
        m = np.isfinite(a) & np.isfinite(b)
        prods.append((a * b)[m])
    prods = np.concatenate(prods)
    var = np.nanmean(v ** 2)
    if prods.size < 4 or not var > 0:
        return 0.0
    rho = prods.mean() / var
    return float(rho * np.sqrt(prods.size))


def neighbour_pairs(data: Measured, ok: np.ndarray) -> int:
    """Neighbouring pairs of points (γ or load neighbours on the grid) where both are `ok`."""
    grid = np.isfinite(point_grid(data, np.where(ok, 0.0, np.nan)))
    return int((grid[1:, :] & grid[:-1, :]).sum() + (grid[:, 1:] & grid[:, :-1]).sum())


def structured_power(data: Measured, z: np.ndarray) -> float:
    """Power of the smooth (structured) part of a residual field (channels, points) in z units: the sum over
    the channels of the mean product of neighbouring points' residuals on the γ × load grid. Independent
    noise has zero expected product, so this estimates the gap's power whatever the noise level, and a
    wrong noise scale cancels in a ratio of two powers. Points that are NaN are left out."""
    total = 0.0
    for zc in z:
        grid = point_grid(data, zc)
        prods = [(a * b)[np.isfinite(a) & np.isfinite(b)] for a, b in
                 ((grid[1:, :], grid[:-1, :]), (grid[:, 1:], grid[:, :-1]))]
        prods = np.concatenate(prods)
        total += float(prods.mean()) if prods.size else 0.0
    return total


def point_grid(data: Measured, values: np.ndarray, reduce=np.nanmean) -> np.ndarray:
    """Per-row values → (γ level, load level) grid of their mean over replicates and speed levels (NaN where
    no point, or no finite value)."""
    r = data.rows
    grid = np.full((len(data.gamma_levels), len(data.load_levels)), np.nan)
    for (i, j), idx in r.groupby(["gamma_bin", "load_bin"]).indices.items():
        v = values[idx]
        if np.isfinite(v).any():
            grid[i, j] = reduce(v)
    return grid


def regions(data: Measured, resid_alpha: np.ndarray, noise_alpha: np.ndarray) -> list[dict]:
    """Where the α gap stands out: operating points whose mean residual exceeds REGION_Z standard errors,
    grouped into connected same-sign regions of the γ × load grid, largest |mean residual|·size first."""
    mean = point_grid(data, resid_alpha)
    count = point_grid(data, np.ones_like(resid_alpha), np.nansum)
    se = point_grid(data, noise_alpha) / np.sqrt(np.maximum(count, 1))
    z = mean / se
    out = []
    for sign in (1, -1):
        mask = np.nan_to_num(sign * z) > REGION_Z
        lab, n = ndimage.label(mask)
        for k in range(1, n + 1):
            cells = np.argwhere(lab == k)
            g = data.gamma_levels[cells[:, 0]]
            t = data.load_levels[cells[:, 1]]
            vals = mean[lab == k]
            out.append({"gamma_deg": [float(g.min()), float(g.max())], "load_Nm": [float(t.min()), float(t.max())],
                        "mean_residual_deg": float(np.mean(vals)), "points": int(len(cells)),
                        "_cells": cells})
    out.sort(key=lambda r: -abs(r["mean_residual_deg"]) * r["points"])
    return out


def _in_regions(data: Measured, regs) -> np.ndarray:
    r = data.rows
    m = np.zeros(len(r), bool)
    for reg in regs:
        cells = {tuple(c) for c in reg["_cells"]}
        m |= np.array([(a, b) in cells for a, b in zip(r["gamma_bin"], r["load_bin"])])
    return m


# ------------------------------------------------------------------------------------------ scoring

def _rms(x, mask=None):
    x = np.asarray(x, float)
    if mask is not None:
        x = x[mask]
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x ** 2))) if x.size else float("nan")


def _efficiency_mask(data: Measured):
    r = data.rows
    big = np.abs(r["tau_perp"].to_numpy()) >= 0.25 * np.abs(r["tau_perp"]).max()
    return big & (np.abs(r["gamma_cmd_deg"].to_numpy()) >= 5)


def model_efficiency(data: Measured, pred: dict):
    r = data.rows
    return efficiency(pred["tau_1"] * r["omega_1"].to_numpy(), pred["tau_2"] * pred["omega_2"])


@dataclass
class Score:
    """A model's performance on a dataset's operating points: its full fit, and each point predicted by the
    fit on the other folds (held out). Where the model fails (no converged physical solution: gross slip,
    lost contact, no convergence) a point has no prediction: it counts in `failed`, never as a misfit."""
    effects: tuple
    fit: Fit
    pred: dict              # held-out predictions
    ok: np.ndarray          # the model has a held-out prediction and a full-fit prediction at the point
    z: np.ndarray           # held-out z per channel and point (channels, points)
    per_point: np.ndarray   # held-out Σz² over the channels per point (NaN where not ok)
    fit_per_point: np.ndarray  # the full fit's Σz² per point (NaN where not ok)
    failed: float           # fraction of the points where the model fails
    rms_alpha: float        # held-out RMS α residual over the ok points [deg]
    rms_efficiency: float   # held-out RMS efficiency residual over the ok points [-]


def score(P: Predictor, data: Measured, noise: dict, fold, x0=None) -> Score:
    full = fit(P, data, noise, x0=x0)
    ho = heldout(P, data, noise, full, fold)
    ok = ho["ok"] & full.ok
    res = residuals(data, ho["pred"])
    z = zscores(res, noise)
    z2 = np.where(ok, (z ** 2).sum(axis=0), np.nan)
    zf2 = np.where(ok, (zscores(residuals(data, full.pred), noise) ** 2).sum(axis=0), np.nan)
    eff_d = data.rows["efficiency"].to_numpy()
    eff_m = model_efficiency(data, ho["pred"])
    return Score(P.effects, full, ho["pred"], ok, z, z2, zf2, float(np.mean(~ok)), _rms(res["alpha"], ok),
                 _rms(eff_d - eff_m, _efficiency_mask(data) & ok))


@dataclass
class Comparison:
    """Two models compared on the operating points where both predict (held out)."""
    points: int
    msz: tuple          # held-out mean squared z per channel (before, after)
    gain: float         # 1 − msz_after/msz_before
    p: float            # one-sided Wilcoxon p-value that `after` predicts the points better
    dbic: float         # BIC(after) − BIC(before) of the full fits, on the same points
    power: tuple        # structured power of the held-out residuals (before, after), structured_power
    power_se: float     # its standard error for white residuals: √(channels/neighbour pairs)


def compare(before: Score, after: Score, channels: int, data: Measured) -> Comparison:
    common = before.ok & after.ok
    b, a = before.per_point[common], after.per_point[common]
    if not common.any():
        return Comparison(0, (np.nan, np.nan), -np.inf, 1.0, np.inf, (0.0, 0.0), np.inf)
    d = b - a
    p = 1.0 if np.allclose(d, 0) else float(wilcoxon(d, alternative="greater", zero_method="zsplit").pvalue)
    n = common.sum() * channels
    dk = len(after.fit.theta) - len(before.fit.theta)
    dbic = float(np.sum(after.fit_per_point[common]) - np.sum(before.fit_per_point[common]) + dk * np.log(n))
    msz = (float(b.sum() / n), float(a.sum() / n))
    power = tuple(structured_power(data, np.where(common, x.z, np.nan)) for x in (before, after))
    se = np.sqrt(channels / max(neighbour_pairs(data, common), 1))
    return Comparison(int(common.sum()), msz, 1 - msz[1] / msz[0], p, dbic, power, float(se))


def _shrink(before, after, floor):
    """Fraction of the gap removed: the gap is the RMS error beyond the noise floor (in quadrature)."""
    gb = np.sqrt(max(before ** 2 - floor ** 2, 0.0))
    ga = np.sqrt(max(after ** 2 - floor ** 2, 0.0))
    return float(1 - ga / gb) if gb > 0 else 0.0


def gap_shrink(c: Comparison) -> float:
    """Fraction of the structured gap removed, over every channel (held out): 1 − √(P_after/P_before) with P
    the structured power (structured_power), which does not depend on the noise estimate; 0 when there was
    no structured gap."""
    before, after = c.power
    if not before > 0:
        return 0.0
    return float(1 - np.sqrt(max(after, 0.0) / before))


# ------------------------------------------------------------------------------------------ diagnosis

class Models:
    """Predictors of one dataset, compiled once per effect set."""

    def __init__(self, layout, data):
        self.layout, self.data = layout, data

    @functools.lru_cache(maxsize=None)
    def get(self, effects: tuple) -> Predictor:
        return Predictor(self.layout, effects, self.data)


def _x0(P: Predictor, prev: Fit | None):
    """Start at the previous accepted fit's values for the parameters it had, defaults for the new ones."""
    x0 = P.defaults.copy()
    if prev is not None:
        for n, v in zip(prev.names, prev.theta):
            if n in P.names:
                x0[P.names.index(n)] = v
    return x0


def _signature(base: Score, cand: Score, noise) -> np.ndarray:
    """A candidate's fitted change of the predictions (all three channels, z units, axis even if not measured)."""
    out = []
    for c in CHANNELS:
        s = noise.get(c, noise["alpha"])
        out.append((cand.fit.pred[c] - base.fit.pred[c]) / s)
    return np.nan_to_num(np.array(out))


def search(models: Models, data: Measured, noise: dict, fold, base: Score, candidates, tick) -> tuple:
    """Greedy forward search: each remaining candidate added to the current model and scored held out; the
    best one is accepted when its held-out gain is significant (Wilcoxon p below P_ACCEPT/candidates), above
    MIN_GAIN, lowers the BIC, the candidate fails at no more than MAX_FAIL of the points (where the rig
    measured a steady state), and no channel gets clearly worse (_worsens_a_channel). Returns (accepted
    effects, rounds, the final score, the score after each accepted effect)."""
    nch = len(_channels(data))
    current, accepted, rounds, steps = base, [], [], []
    remaining = list(candidates)
    while remaining and len(accepted) < MAX_ADDED:
        rows = []
        for e in remaining:
            P = models.get(current.effects + (e,))
            sc = score(P, data, noise, fold, x0=_x0(P, current.fit))
            c = compare(current, sc, nch, data)
            rows.append({"effect": e, "score": sc, "cmp": c, "significant": bool(
                c.p < P_ACCEPT / len(remaining) and c.gain > MIN_GAIN and c.dbic < 0 and sc.failed <= MAX_FAIL
                and not _worsens_a_channel(current, sc))})
            tick(f"round {len(rounds) + 1}: {e}")
        rows.sort(key=lambda r: (not r["significant"], -r["cmp"].gain))
        rounds.append(rows)
        if not rows[0]["significant"]:
            break
        accepted.append(rows[0]["effect"])
        current = rows[0]["score"]
        steps.append(current)
        remaining.remove(rows[0]["effect"])
    return accepted, rounds, current, steps


def _worsens_a_channel(before: Score, after: Score, factor: float = 2.0) -> bool:
    """Whether `after` fits some channel clearly worse held out than `before`: its mean squared z there more
    than `factor` times before and above `factor` (noise is 1), on the points both predict. A gain in one
    channel bought with another is no explanation: a 1° offset of the axis encoder alone (outside the
    vocabulary) made steering_offset "accepted" on the axis while α got 10× worse."""
    both = before.ok & after.ok
    if not both.any():
        return False
    msz_before, msz_after = (np.mean(s.z[:, both] ** 2, axis=1) for s in (before, after))
    return bool(np.any((msz_after > factor * msz_before) & (msz_after > factor)))


def _structure(data: Measured, z: np.ndarray) -> float:
    """The largest spatial-autocorrelation z over the channels of a residual field (channels, points)."""
    return max(autocorrelation_z(data, zc) for zc in z)


def verdict(data: Measured, accepted, base: Score, steps, structured_after: float, nch: int,
            form_structured: bool) -> tuple[str, list]:
    """The verdict and the partial explanation. An effect is named only when the accepted effects leave no
    structured gap: the spatial structure z of the final residuals is ≤ AUTO_Z, the model-form checks find
    no variable the residual depends on (form_checks), and they remove at least SHRINK_MIN of the
    structured gap (gap_shrink, held out) unless what remains is within 3 standard errors of none.
    Otherwise a structured gap remains: `unexplained`, with each accepted effect's cumulative share of the
    gap (`partial`). Without accepted effects: `unexplained` if the base residual is spatially structured in
    any channel (structured_after, the base being the final model), else `none` (the gap is noise). The form
    checks only stop a name: alone, their nominal p-values proved too optimistic on null data to call a gap."""
    if not accepted:
        return ("unexplained" if structured_after > AUTO_Z else "none"), []
    c = compare(base, steps[-1], nch, data)
    remains = c.power[1] > 3 * c.power_se
    if structured_after <= AUTO_Z and not form_structured and (gap_shrink(c) >= SHRINK_MIN or not remains):
        return accepted[0], []
    return "unexplained", [{"effect": e, "shrink": gap_shrink(compare(base, st, nch, data))}
                           for e, st in zip(accepted, steps)]


def diagnose(layout: Layout, data: Measured, base, candidates=None, progress=None) -> dict:
    """Run the whole diagnosis; returns the report (JSON-ready except the keys starting with '_')."""
    t0 = time.perf_counter()
    base = tuple(base)
    candidates = [e for e in (candidates or effect_candidates(layout.contact_law)) if e not in base]
    raw, data = data, merge_points(data)
    models = Models(layout, data)
    fold = folds(data)
    total, done = 1 + len(candidates) * (1 + MAX_ADDED), [0]

    def tick(what):
        done[0] += 1
        if progress:
            progress(min(done[0], total), total, what)

    P0 = models.get(base)
    noise = estimate_noise(P0, data, raw)
    base_score = score(P0, data, noise, fold)
    tick(f"base {'+'.join(base) or '(none)'}")
    # the base model's gap only where its physics holds: elsewhere its "prediction" is an unconverged or
    # slipping solve's last iterate (a region of 14.1° at a point the model had in gross slip)
    res_fit = {c: np.where(base_score.fit.ok, v, np.nan) for c, v in residuals(data, base_score.fit.pred).items()}
    structured = autocorrelation_z(data, zscores(res_fit, noise)[0])
    regs = regions(data, res_fit["alpha"], noise["alpha"])
    accepted, rounds, final, steps = search(models, data, noise, fold, base_score, candidates, tick)
    if progress:
        progress(total, total, "done")
    z_final = zscores(residuals(data, final.fit.pred), noise)
    structured_after = _structure(data, np.where(final.ok, z_final, np.nan))
    nch = len(_channels(data))
    ctx = dict(data=data, raw=raw, noise=noise, base=base_score, final=final, regs=regs, nch=nch)
    form = form_checks(models, ctx)
    name, partial = verdict(data, accepted, base_score, steps, structured_after, nch, form["lies_along"] is not None)
    report = {
        "verdict": name, "accepted": accepted, "partial": partial, "base": list(base), "candidates": candidates,
        "rows": int(len(raw.rows)), "operating_points": int(len(data.rows)), "dropped_rows": data.dropped,
        "noise": {c: {"rms": _rms(v), "min": float(np.min(v)), "max": float(np.max(v)), "unit": UNITS[c]}
                  for c, v in _row_noise(data, noise).items()} | {"source": _noise_source(data, raw)},
        "base_fit": base_score.fit.params(), "final_fit": final.fit.params(),
        "base_failed": _failed_points(P0, data, base_score.fit),
        "gap": {"rms_alpha_deg": _rms(res_fit["alpha"], base_score.fit.ok),
                "heldout_rms_alpha_deg": base_score.rms_alpha, "rms_efficiency": base_score.rms_efficiency,
                "structure_z": structured, "structured": bool(structured > AUTO_Z),
                "structure_z_after": structured_after, "structured_after": bool(structured_after > AUTO_Z),
                "regions": [{k: v for k, v in r.items() if not k.startswith("_")} for r in regs]},
        "ranking": _ranking(rounds[0] if rounds else [], ctx, accepted),
        "rounds": [[{"effect": r["effect"], "heldout_msz": r["cmp"].msz[1], "p_value": r["cmp"].p,
                     "gain": r["cmp"].gain, "failed_fraction": r["score"].failed, "significant": r["significant"]}
                    for r in rd] for rd in rounds],
        "how_far": _how_far(ctx),
        "form": form,
        "by_speed": _by_speed(data, res_fit["alpha"], residuals(data, final.pred)["alpha"]),
        "confounded": _confounded(rounds[0], base_score, noise, data, models) if rounds else [],
        "seconds": time.perf_counter() - t0,
        "_base": base_score, "_final": final, "_noise": noise, "_data": data,
    }
    return report


def _heldout_errors(data: Measured, noise: dict, before: Score, after: Score) -> dict:
    """Held-out RMS α [deg] and efficiency [-] of two models on the points both predict, and the fraction of
    each gap beyond its noise floor that `after` removes."""
    both = before.ok & after.ok
    eff, effm = data.rows["efficiency"].to_numpy(), _efficiency_mask(data) & both
    ra = [_rms(residuals(data, x.pred)["alpha"], both) for x in (before, after)]
    re = [_rms(eff - model_efficiency(data, x.pred), effm) for x in (before, after)]
    return {"alpha": ra, "shrink_alpha": _shrink(*ra, _rms(noise["alpha"], both)),
            "efficiency": re, "shrink_efficiency": _shrink(*re, _efficiency_noise(data, noise))}


def _ranking(first_round, ctx, accepted) -> list:
    """The first round's candidates, best first: held-out RMS α and efficiency before and after (on the
    points where both models predict), shrink, p-value, ΔBIC, the fraction of points where the candidate
    fails, and its fitted parameters."""
    out = []
    for r in first_round:
        s, c = r["score"], r["cmp"]
        e = _heldout_errors(ctx["data"], ctx["noise"], ctx["base"], s)
        out.append({
            "effect": r["effect"], "heldout_rms_before": e["alpha"][0], "heldout_rms_after": e["alpha"][1],
            "shrink": e["shrink_alpha"], "gap_shrink": gap_shrink(c),
            "heldout_rms_efficiency_before": e["efficiency"][0], "heldout_rms_efficiency_after": e["efficiency"][1],
            "shrink_efficiency": e["shrink_efficiency"],
            "heldout_msz_before": c.msz[0], "heldout_msz_after": c.msz[1], "p_value": c.p,
            "bic_change": c.dbic, "failed_fraction": s.failed, "params": s.fit.params(),
            "accepted": r["effect"] in accepted})
    return out


def _how_far(ctx) -> dict:
    """Held-out RMS α and efficiency of the base and the diagnosed model on the points both predict, the
    shrinks (α, efficiency, and over every channel in z units), and the shrink in the gap's largest regions."""
    data, base, final, noise = ctx["data"], ctx["base"], ctx["final"], ctx["noise"]
    e = _heldout_errors(data, noise, base, final)
    res_b, res_a = residuals(data, base.pred)["alpha"], residuals(data, final.pred)["alpha"]
    in_reg = (_in_regions(data, ctx["regs"][:3]) & base.ok & final.ok) if ctx["regs"] else np.zeros(len(data.rows), bool)
    region = [_rms(res_b, in_reg), _rms(res_a, in_reg)] if in_reg.any() else None
    return {
        "heldout_rms_alpha_deg": e["alpha"], "shrink_alpha": e["shrink_alpha"],
        "heldout_rms_efficiency": e["efficiency"], "shrink_efficiency": e["shrink_efficiency"],
        "shrink": gap_shrink(compare(base, final, ctx["nch"], data)) if final is not base else 0.0,
        "region_rms_alpha_deg": region,
        "shrink_region": _shrink(*region, _rms(noise["alpha"], in_reg)) if region else None,
    }


def _row_noise(points: Measured, noise: dict) -> dict:
    """The noise of one row (σ of a point's mean × √count): what the report calls the rig's noise."""
    n = np.sqrt(points.rows["count"].to_numpy())
    return {c: v * n for c, v in noise.items()}


def _by_speed(data: Measured, before, after):
    """The α residual per motor-speed level (only when the speed varies): where in speed the gap lies."""
    if len(data.speed_levels) < 2:
        return []
    sb = data.rows["speed_bin"].to_numpy()
    return [{"omega_1": float(w), "rows": int((sb == k).sum()), "mean_residual_deg": float(np.mean(before[sb == k])),
             "rms_residual_deg": [_rms(before, sb == k), _rms(after, sb == k)]} for k, w in enumerate(data.speed_levels)]


def _channels(data: Measured):
    return [c for c in CHANNELS if c != "axis" or data.has_axis]


def _efficiency_noise(data, noise):
    """Noise floor of the efficiency residual, propagated from the torque noise: |∂η/∂τ1| σ with σ the
    τ∥ channel's noise (both torque components see the same torque noise)."""
    r = data.rows
    m = _efficiency_mask(data)
    eta = r["efficiency"].to_numpy()
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.abs(eta / r["tau_1"].to_numpy()) * noise["tau_par"]
    return _rms(d, m)


def _confounded(first_rows, base: Score, noise, data, models: Models, cos_limit=0.9):
    """Pairs of candidates whose fitted signatures (changes of the predictions, z units, measured channels)
    are nearly parallel (cosine ≥ cos_limit) and both above noise, with their held-out scores, where they
    differ most and which measurement would tell them apart (`suggest_points`)."""
    out = []
    sig = {r["effect"]: _signature(base, r["score"], noise) for r in first_rows}
    meas = np.array([c in noise for c in CHANNELS])
    for i, a in enumerate(first_rows):
        for b in first_rows[i + 1:]:
            sa, sb = sig[a["effect"]], sig[b["effect"]]
            va, vb = sa[meas].ravel(), sb[meas].ravel()
            na, nb = np.linalg.norm(va), np.linalg.norm(vb)
            if na < 3 or nb < 3:        # a signature within noise is not a rival
                continue
            cos = float(va @ vb / (na * nb))
            if cos < cos_limit:
                continue
            diff = np.abs(sa - sb)            # (channel, point)
            by_channel = {c: float(np.sqrt(np.mean(diff[k] ** 2))) for k, c in enumerate(CHANNELS)}
            points = suggest_points(models, data, noise, a["score"].fit, b["score"].fit)
            axis = not data.has_axis and by_channel["axis"] > 2 * max(by_channel["alpha"], by_channel["tau_par"])
            hint = ("measure the axis angle (gamma_axis_deg), or " if axis else "") + "measure at " + "; ".join(
                f"γ = {p['gamma_deg']:.0f}°, τ⊥ = {p['load_Nm']:+.2f} N·m" for p in points[:3])
            out.append({"effects": [a["effect"], b["effect"]], "cosine": cos, "separation_z_rms": by_channel,
                        "heldout_msz": [a["cmp"].msz[1], b["cmp"].msz[1]], "suggested_points": points,
                        "separate_by": hint})
    return out


def suggest_points(models: Models, data: Measured, noise: dict, fa: Fit, fb: Fit, n: int = 5) -> list[dict]:
    """The operating points that best separate two fitted models: over the variant's whole envelope (its γ
    range at 5° steps, its loads, the data's mean motor speed), the points where their predictions of the
    measured channels differ most, in units of each channel's typical noise per row; `n` of them, at least
    15° apart in γ."""
    L = models.layout
    g = np.radians(np.arange(np.degrees(L.gamma_grid.min()), np.degrees(L.gamma_grid.max()) + 1e-9, 5.0))
    G, T = np.meshgrid(g, L.load_grid, indexing="ij")
    w = float(np.mean(data.rows["omega_1"]))
    sigma = {c: float(np.median(v * np.sqrt(data.rows["count"].to_numpy()))) for c, v in noise.items()}
    preds = []
    for f in (fa, fb):
        m = models.get(f.effects).model
        r = m.evaluate(G, T, speeds=w, theta=f.theta)
        preds.append({"alpha": np.degrees(r["alpha"]), "axis": np.degrees(r["gamma_axis"]),
                      "tau_par": m.frame.load_split(G, r["tau_1"], r["tau_2"])[1]})
    sep = np.sqrt(sum(((preds[0][c] - preds[1][c]) / sigma[c]) ** 2 for c in sigma))
    sep = np.where(np.isfinite(sep), sep, -1.0)
    out = []
    for i in np.argsort(-sep.max(axis=1)):          # best γ first, at least 15° from those already chosen
        j = int(np.argmax(sep[i]))
        g_i = float(np.degrees(G[i, j]))
        if sep[i, j] > 0 and all(abs(g_i - p["gamma_deg"]) >= 15 - 1e-9 for p in out):
            out.append({"gamma_deg": g_i, "load_Nm": float(T[i, j]), "separation_z": float(sep[i, j])})
        if len(out) == n:
            break
    return out


def form_checks(models: Models, ctx) -> dict:
    """Where a remaining gap lies beyond the vocabulary: the final model's full-fit residuals (z units) tested
    for structure along each input (commanded γ, the load level τ⊥, the motor-speed level ω1: levels, not the
    measured values, whose noise is already in the residual) and along the model's own derived quantities at
    each point (the drive rollers' spin ratio |Ω·n|/V [1/m], their rolling speed V [m/s], the smallest normal
    force [N] and the largest traction utilisation). Per variable and channel, the points are put in FORM_BINS
    quantile bins and the bin means compared by a one-way ANOVA F-test (scale-free, so a misestimated noise
    level does not matter). Returns each variable's smallest p-value over the channels, and the variable
    along which the gap lies: the smallest p, if it is below 0.001 after Bonferroni over every test."""
    data, final, noise = ctx["data"], ctx["final"], ctx["noise"]
    r = data.rows
    ok = final.ok
    z = zscores(residuals(data, final.fit.pred), noise)[:, ok]
    m = models.get(final.effects).model
    ev = m.evaluate(np.radians(r["gamma_cmd_deg"].to_numpy()[ok]), r["tau_perp"].to_numpy()[ok],
                    speeds=r["omega_1"].to_numpy()[ok], theta=final.fit.theta)
    drive = np.array([x.role != "steering" for x in m.layout.rollers])
    r2 = float(next(x.radius for x in m.layout.rollers if x.role == "drive" and x.shaft == 2))
    variables = {"gamma_cmd_deg": r["gamma_cmd_deg"].to_numpy()[ok],
                 "tau_perp_Nm": data.load_levels[r["load_bin"].to_numpy()[ok]],
                 "omega_1_rad_s": data.speed_levels[r["speed_bin"].to_numpy()[ok]],
                 "drive_spin_ratio_1_m": np.nanmean(np.abs(ev["spin"][drive]), axis=0),
                 "rolling_speed_m_s": np.abs(ev["omega_2"]) * r2, "min_normal_force_N": np.nanmin(ev["N"], axis=0),
                 "max_utilisation": np.nanmax(ev["utilisation"], axis=0)}
    p = {}
    for name, v in variables.items():
        bins = _quantile_bins(v)
        good = np.isfinite(v) & np.all(np.isfinite(z), axis=0)
        if bins is None:
            p[name] = 1.0
            continue
        groups = [[zc[good & (bins == k)] for k in np.unique(bins[good])] for zc in z]
        p[name] = float(min(f_oneway(*g).pvalue for g in groups if len(g) > 1)) if len(groups[0]) > 1 else 1.0
    top = min(p, key=p.get)
    return {"p": p, "lies_along": top if p[top] < 1e-3 / (len(p) * len(z)) else None}


def _quantile_bins(v: np.ndarray):
    """Bin index of each value in FORM_BINS quantile bins; None when v does not vary (or is too short)."""
    fin = np.isfinite(v)
    if fin.sum() < 2 * FORM_BINS or np.ptp(v[fin]) <= 1e-12 * max(1.0, np.max(np.abs(v[fin]))):
        return None
    edges = np.unique(np.quantile(v[fin], np.linspace(0, 1, FORM_BINS + 1)))
    return np.clip(np.searchsorted(edges, v, side="right") - 1, 0, len(edges) - 2)


# ------------------------------------------------------------------------------------------ report

def public(rep: dict) -> dict:
    """The JSON-ready part of a report."""
    return {k: v for k, v in rep.items() if not k.startswith("_")}


