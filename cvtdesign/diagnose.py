"""The sim-to-real gap: where it lies, which unmodelled effect causes it, how far it shrinks.

Method (each step is a plain function below):
 1. Prediction. Every row is an operating point (γ_cmd, ω1 and the lateral load τ⊥ = −τ1 sin γ + τ2 cos γ
    from the measured torques, Kim eq 17: the load the rig controls); the model with a set of effects
    (DESIGN.md sec. 3) predicts the slip angle α, the parallel torque τ∥ = τ1 cos γ + τ2 sin γ (the other,
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

from .effects import EFFECTS
from .measured import Measured
from .model import compile_model
from .variant import Layout

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
    """σ per channel and row [channel units]: from replicates if there are any, else from second differences
    of `resid` along the load at each γ level (÷√6 for white noise); pooled over the γ level and its two
    neighbours, then floored at 1e-9 of the largest so no row gets an infinite weight."""
    r = data.rows
    gb = r["gamma_bin"].to_numpy()
    levels = np.unique(gb)
    out = {}
    for ch, res in resid.items():
        samples = {}
        for gl in levels:
            idx = np.flatnonzero(gb == gl)
            if data.replicated:
                pts = r["point"].to_numpy()[idx]
                dev = []
                for p in np.unique(pts):
                    v = res[idx[pts == p]]
                    if v.size > 1:
                        dev.extend((v - v.mean()) * np.sqrt(v.size / (v.size - 1)))
                samples[gl] = np.array(dev)
            else:
                parts = []
                for sb in np.unique(r["speed_bin"].to_numpy()[idx]):
                    sub = idx[r["speed_bin"].to_numpy()[idx] == sb]
                    v = res[sub[np.argsort(r["tau_perp"].to_numpy()[sub])]]
                    if v.size >= 3:
                        parts.append((v[:-2] - 2 * v[1:-1] + v[2:]) / np.sqrt(6))
                samples[gl] = np.concatenate(parts) if parts else np.array([])
        sig = {}
        for k, gl in enumerate(levels):
            pool = np.concatenate([samples[levels[j]] for j in range(max(0, k - 1), min(len(levels), k + 2))])
            sig[gl] = _mad_std(pool)
        s = np.array([sig[g] for g in gb])
        if not np.all(np.isfinite(s)):
            s = np.where(np.isfinite(s), s, _mad_std(res))
        out[ch] = np.maximum(s, 1e-9 * np.nanmax(s) + 1e-15)
    return out


def estimate_noise(P: Predictor, data: Measured) -> dict:
    """Noise levels for `data`, with the residuals of an unweighted first fit of P (only needed without
    replicates)."""
    prelim = fit(P, data, {c: np.ones(P.n) for c in _channels(data)})
    return noise_levels(data, residuals(data, prelim.pred))


def fit_model(layout: Layout, data: Measured, effects) -> tuple[Predictor, Fit]:
    """Fit the model with `effects` to the data (noise-weighted): the fitted model of resteering."""
    P = Predictor(layout, effects, data)
    return P, fit(P, data, estimate_noise(P, data))


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
    from scipy.optimize import least_squares

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
    J = best.jac
    std, ident = _uncertainty(J, theta, P.defaults, float(z @ z), z.size)
    return Fit(P.effects, P.names, theta, std, ident, pred, ok, float(z @ z))


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


def point_grid(data: Measured, values: np.ndarray, reduce=np.nanmean) -> np.ndarray:
    """Per-row values → (γ level, load level) grid of their mean over replicates (NaN where no point)."""
    r = data.rows
    grid = np.full((len(data.gamma_levels), len(data.load_levels)), np.nan)
    for (i, j), idx in r.groupby(["gamma_bin", "load_bin"]).indices.items():
        grid[i, j] = reduce(values[idx])
    return grid


def regions(data: Measured, resid_alpha: np.ndarray, noise_alpha: np.ndarray) -> list[dict]:
    """Where the α gap stands out: operating points whose mean residual exceeds REGION_Z standard errors,
    grouped into connected same-sign regions of the γ × load grid, largest |mean residual|·size first."""
    from scipy import ndimage

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


def _model_efficiency(data: Measured, pred: dict):
    from .evaluate import efficiency
    r = data.rows
    return efficiency(pred["tau_1"] * r["omega_1"].to_numpy(), pred["tau_2"] * pred["omega_2"])


@dataclass
class Score:
    """A model's held-out performance."""
    effects: tuple
    fit: Fit
    pred: dict              # held-out predictions
    ok: np.ndarray
    z: np.ndarray           # (channels, rows) held-out z-scores (failed rows: FAIL_Z)
    per_point: np.ndarray   # held-out Σz² per operating point
    msz: float              # held-out mean squared z
    rms_alpha: float        # [deg]
    rms_efficiency: float   # [-]
    bic: float


def score(P: Predictor, data: Measured, noise: dict, fold, x0=None) -> Score:
    full = fit(P, data, noise, x0=x0)
    ho = heldout(P, data, noise, full, fold)
    res = residuals(data, ho["pred"])
    z = zscores(res, noise)
    z[:, ~ho["ok"]] = FAIL_Z
    pts = data.rows["point"].to_numpy()
    per_point = np.bincount(pts, weights=(z ** 2).sum(axis=0))
    eff_d = data.rows["efficiency"].to_numpy()
    eff_m = _model_efficiency(data, ho["pred"])
    n = z.size
    return Score(P.effects, full, ho["pred"], ho["ok"], z, per_point, float(np.mean(z ** 2)),
                 _rms(res["alpha"]), _rms(eff_d - eff_m, _efficiency_mask(data)),
                 full.chi2 + len(full.theta) * np.log(n))


def _gain_test(before: Score, after: Score) -> float:
    """One-sided p-value that `after` predicts held-out operating points better than `before`."""
    from scipy.stats import wilcoxon

    d = before.per_point - after.per_point
    if np.allclose(d, 0):
        return 1.0
    return float(wilcoxon(d, alternative="greater", zero_method="zsplit").pvalue)


def _shrink(before, after, floor):
    """Fraction of the gap removed: the gap is the RMS error beyond the noise floor (in quadrature)."""
    gb = np.sqrt(max(before ** 2 - floor ** 2, 0.0))
    ga = np.sqrt(max(after ** 2 - floor ** 2, 0.0))
    return float(1 - ga / gb) if gb > 0 else 0.0


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


def diagnose(layout: Layout, data: Measured, base, candidates=None, progress=None) -> dict:
    """Run the whole diagnosis; returns the report (JSON-ready except the keys starting with '_')."""
    t0 = time.perf_counter()
    base = tuple(base)
    candidates = [e for e in (candidates or EFFECTS) if e not in base]
    models = Models(layout, data)
    fold = folds(data)
    tick = progress or (lambda *a: None)
    total = 1 + len(candidates) * (1 + MAX_ADDED)
    done = 0

    P0 = models.get(base)
    noise = estimate_noise(P0, data)
    current = score(P0, data, noise, fold)
    done += 1
    tick(done, total, f"base {'+'.join(base) or '(none)'}")
    base_score = current
    res_fit = residuals(data, base_score.fit.pred)
    structured = autocorrelation_z(data, zscores(res_fit, noise)[0])
    regs = regions(data, res_fit["alpha"], noise["alpha"])

    accepted, rounds = [], []
    remaining = list(candidates)
    while remaining and len(accepted) < MAX_ADDED:
        scores = {}
        for e in remaining:
            P = models.get(current.effects + (e,))
            scores[e] = score(P, data, noise, fold, x0=_x0(P, current.fit))
            done += 1
            tick(done, total, f"round {len(rounds) + 1}: {e}")
        alpha = P_ACCEPT / max(len(remaining), 1)
        rows = []
        for e, s in scores.items():
            p = _gain_test(current, s)
            gain = 1 - s.msz / current.msz
            rows.append({"effect": e, "score": s, "p": p, "gain": gain,
                         "significant": bool(p < alpha and gain > MIN_GAIN and s.bic < current.bic)})
        rows.sort(key=lambda r: r["score"].msz)
        rounds.append(rows)
        best = rows[0]
        if not best["significant"]:
            break
        accepted.append(best["effect"])
        current = best["score"]
        remaining.remove(best["effect"])
    tick(total, total, "done")

    final = current
    z_final = zscores(residuals(data, final.fit.pred), noise)
    structured_after = autocorrelation_z(data, z_final[0])
    if accepted:
        verdict = accepted[0]
    else:
        verdict = "unexplained" if structured > AUTO_Z and regs else "none"

    # ranking: the first round's candidates, best first; accepted ones flagged
    first = rounds[0] if rounds else []
    floor_alpha = _rms(noise["alpha"])
    floor_eff = _efficiency_noise(data, noise)
    ranking = []
    for r in first:
        s = r["score"]
        ranking.append({
            "effect": r["effect"],
            "heldout_rms_before": base_score.rms_alpha, "heldout_rms_after": s.rms_alpha,
            "shrink": _shrink(base_score.rms_alpha, s.rms_alpha, floor_alpha),
            "heldout_rms_efficiency_before": base_score.rms_efficiency,
            "heldout_rms_efficiency_after": s.rms_efficiency,
            "shrink_efficiency": _shrink(base_score.rms_efficiency, s.rms_efficiency, floor_eff),
            "heldout_msz_before": base_score.msz, "heldout_msz_after": s.msz,
            "p_value": r["p"], "bic_change": s.bic - base_score.bic,
            "params": s.fit.params(),
            "accepted": r["effect"] in accepted,
        })
    # region shrink for the accepted model
    in_reg = _in_regions(data, regs[:3]) if regs else np.zeros(len(data.rows), bool)
    res_b = residuals(data, base_score.pred)
    res_a = residuals(data, final.pred)
    how_far = {
        "heldout_rms_alpha_deg": [base_score.rms_alpha, final.rms_alpha],
        "shrink_alpha": _shrink(base_score.rms_alpha, final.rms_alpha, floor_alpha),
        "heldout_rms_efficiency": [base_score.rms_efficiency, final.rms_efficiency],
        "shrink_efficiency": _shrink(base_score.rms_efficiency, final.rms_efficiency, floor_eff),
        "region_rms_alpha_deg": [_rms(res_b["alpha"], in_reg), _rms(res_a["alpha"], in_reg)] if in_reg.any() else None,
        "shrink_region": _shrink(_rms(res_b["alpha"], in_reg), _rms(res_a["alpha"], in_reg),
                                 _rms(noise["alpha"], in_reg)) if in_reg.any() else None,
    }
    confounded = _confounded(first, base_score, noise, data) if first else []
    report = {
        "verdict": verdict,
        "accepted": accepted,
        "base": list(base),
        "candidates": candidates,
        "rows": int(len(data.rows)), "operating_points": int(data.rows["point"].nunique()),
        "dropped_rows": data.dropped,
        "noise": {c: {"rms": _rms(v), "min": float(np.min(v)), "max": float(np.max(v)), "unit": UNITS[c]}
                  for c, v in noise.items()} | {"source": "replicates" if data.replicated else
                                                 "second differences along load"},
        "base_fit": base_score.fit.params(),
        "final_fit": final.fit.params(),
        "gap": {"rms_alpha_deg": _rms(res_fit["alpha"]), "heldout_rms_alpha_deg": base_score.rms_alpha,
                "rms_efficiency": base_score.rms_efficiency,
                "structure_z": structured, "structured": bool(structured > AUTO_Z),
                "structure_z_after": structured_after, "structured_after": bool(structured_after > AUTO_Z),
                "regions": [{k: v for k, v in r.items() if not k.startswith("_")} for r in regs]},
        "ranking": ranking,
        "rounds": [[{"effect": r["effect"], "heldout_msz": r["score"].msz, "p_value": r["p"],
                     "gain": r["gain"], "significant": r["significant"]} for r in rd] for rd in rounds],
        "how_far": how_far,
        "by_speed": _by_speed(data, res_b["alpha"], res_a["alpha"]),
        "confounded": confounded,
        "seconds": time.perf_counter() - t0,
        "_base": base_score, "_final": final, "_noise": noise, "_data": data,
    }
    return report


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


def _confounded(first_rows, base: Score, noise, data, cos_limit=0.9):
    """Pairs of candidates whose fitted signatures (changes of the predictions, z units, measured channels)
    are nearly parallel (cosine ≥ cos_limit) and both above noise, with their held-out scores, where they
    differ most and which measurement would tell them apart."""
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
            diff = np.abs(sa - sb)            # (channel, row)
            by_channel = {c: float(np.sqrt(np.mean(diff[k] ** 2))) for k, c in enumerate(CHANNELS)}
            row = int(np.argmax(diff[:2].max(axis=0)))
            r = data.rows.iloc[row]
            hint = ("measure the axis angle (gamma_axis_deg)" if not data.has_axis and
                    by_channel["axis"] > 2 * max(by_channel["alpha"], by_channel["tau_par"]) else
                    f"more points near γ = {r['gamma_cmd_deg']:.0f}°, τ⊥ = {r['tau_perp']:.2f} N·m")
            out.append({"effects": [a["effect"], b["effect"]], "cosine": cos,
                        "separation_z_rms": by_channel,
                        "heldout_msz": [a["score"].msz, b["score"].msz],
                        "separate_by": hint})
    return out


# ------------------------------------------------------------------------------------------ report

def public(rep: dict) -> dict:
    """The JSON-ready part of a report."""
    return {k: v for k, v in rep.items() if not k.startswith("_")}


def print_report(rep: dict, console):
    """A short human report: data and noise, the base fit, where the gap is, the ranking, the verdict."""
    from rich.table import Table

    n = rep["noise"]
    dropped = sum(rep["dropped_rows"].values())
    console.print(f"{rep['rows']} rows, {rep['operating_points']} operating points"
                  + (f", {dropped} bad rows dropped ({rep['dropped_rows']})" if dropped else "")
                  + f"; noise ({n['source']}): α {n['alpha']['rms']:.3f}°, τ∥ {n['tau_par']['rms']:.4f} N·m"
                  + (f", axis {n['axis']['rms']:.3f}°" if "axis" in n else ""))
    t = Table(title=f"base model fit: {' + '.join(rep['base']) or 'ideal CVT'}")
    for c in ("parameter", "value", "±1σ", "identifiable"):
        t.add_column(c)
    for name, p in rep["base_fit"].items():
        t.add_row(name, f"{p['value']:.5g}", f"{p['std']:.2g}", "yes" if p["identifiable"] else "[red]no[/red]")
    if rep["base_fit"]:
        console.print(t)
    g = rep["gap"]
    console.print(f"gap: RMS α residual {g['rms_alpha_deg']:.3f}° (held out {g['heldout_rms_alpha_deg']:.3f}°), "
                  f"efficiency {g['rms_efficiency']:.4f}; spatial structure z = {g['structure_z']:.1f} "
                  f"({'structured' if g['structured'] else 'like noise'})")
    if g["regions"]:
        rt = Table(title="where the α gap stands out (> 3σ per operating point)")
        for c in ("region", "γ \\[deg]", "τ⊥ \\[N·m]", "points", "mean residual \\[deg]"):
            rt.add_column(c, justify="right")
        for k, r in enumerate(g["regions"][:6]):
            rt.add_row(f"R{k + 1}", f"{r['gamma_deg'][0]:.0f} .. {r['gamma_deg'][1]:.0f}",
                       f"{r['load_Nm'][0]:+.2f} .. {r['load_Nm'][1]:+.2f}", str(r["points"]),
                       f"{r['mean_residual_deg']:+.3f}")
        console.print(rt)
    if rep["by_speed"]:
        console.print("by motor speed: " + "; ".join(
            f"ω1 = {b['omega_1']:.3g} rad/s: RMS α residual {b['rms_residual_deg'][0]:.3f}° → {b['rms_residual_deg'][1]:.3f}°"
            for b in rep["by_speed"]))
    k = Table(title="candidates, added one at a time to the base (held-out, cross-validated by operating point)")
    for c in ("effect", "RMS α \\[deg] before → after", "shrink", "RMS η before → after", "p", "ΔBIC", "fitted", "accepted"):
        k.add_column(c)
    for r in rep["ranking"]:
        new = {n: p for n, p in r["params"].items() if n.split(".")[0] == r["effect"]}
        fitted = ", ".join(f"{n.split('.')[1]} = {p['value']:.3g}" + ("" if p["identifiable"] else " (n.i.)")
                           for n, p in new.items())
        k.add_row(r["effect"], f"{r['heldout_rms_before']:.3f} → {r['heldout_rms_after']:.3f}", f"{r['shrink']:.2f}",
                  f"{r['heldout_rms_efficiency_before']:.4f} → {r['heldout_rms_efficiency_after']:.4f}",
                  f"{r['p_value']:.1e}", f"{r['bic_change']:+.1f}", fitted, "[green]yes[/green]" if r["accepted"] else "")
    console.print(k)
    for c in rep["confounded"]:
        console.print(f"[yellow]confounded: {c['effects'][0]} and {c['effects'][1]} change the predictions alike "
                      f"(cosine {c['cosine']:.2f}); to separate them: {c['separate_by']}[/yellow]")
    h = rep["how_far"]
    console.print(f"[bold]verdict: {rep['verdict']}[/bold]" + (f" (accepted: {', '.join(rep['accepted'])})"
                                                                if len(rep["accepted"]) > 1 else ""))
    if rep["accepted"]:
        reg = (f"; in the gap's regions {h['region_rms_alpha_deg'][0]:.3f}° → {h['region_rms_alpha_deg'][1]:.3f}° "
               f"(shrink {h['shrink_region']:.2f})" if h["region_rms_alpha_deg"] else "")
        console.print(f"how far: held-out RMS α {h['heldout_rms_alpha_deg'][0]:.3f}° → {h['heldout_rms_alpha_deg'][1]:.3f}° "
                      f"(gap shrinks by {h['shrink_alpha']:.0%}), efficiency {h['heldout_rms_efficiency'][0]:.4f} → "
                      f"{h['heldout_rms_efficiency'][1]:.4f} (shrink {h['shrink_efficiency']:.0%}){reg}")
        if rep["gap"]["structured_after"]:
            console.print("[yellow]a structured gap remains after the accepted effects[/yellow]")
    console.print(f"({rep['seconds']:.1f} s)")


def plot_report(rep: dict, out_dir) -> list:
    """Residual maps (base and diagnosed model) and the fit curves; returns the files written."""
    from pathlib import Path

    from . import plots

    out_dir = Path(out_dir)
    data, base, final = rep["_data"], rep["_base"], rep["_final"]
    rb, rf = residuals(data, base.fit.pred), residuals(data, final.fit.pred)
    maps = [(f"α residual, base ({' + '.join(base.effects) or 'ideal'})", point_grid(data, rb["alpha"]))]
    if final is not base:
        maps.append((f"α residual, with {' + '.join(rep['accepted'])}", point_grid(data, rf["alpha"])))
    f1 = out_dir / "residual_map.png"
    plots.residual_map_figure(data.gamma_levels, data.load_levels, maps, rep["gap"]["regions"][:6], f1)
    r = data.rows
    eb, ef = _model_efficiency(data, base.pred), _model_efficiency(data, final.pred)
    picks = sorted({int(np.argmin(np.abs(data.load_levels - x))) for x in
                    (data.load_levels.min(), 0.5 * data.load_levels.min(), 0.5 * data.load_levels.max(),
                     data.load_levels.max())})
    panels = [("slip angle α", "α [deg]", []), ("efficiency", "efficiency [-]", [])]
    for j in picks:
        idx = np.flatnonzero(r["load_bin"].to_numpy() == j)
        idx = idx[np.argsort(r["gamma_cmd_deg"].to_numpy()[idx])]
        g = r["gamma_cmd_deg"].to_numpy()[idx]
        lv = float(data.load_levels[j])
        panels[0][2].append((lv, g, r["alpha_deg"].to_numpy()[idx], base.pred["alpha"][idx], final.pred["alpha"][idx]))
        panels[1][2].append((lv, g, r["efficiency"].to_numpy()[idx], eb[idx], ef[idx]))
    f2 = out_dir / "fit.png"
    plots.diagnosis_fit_figure({"panels": panels}, f2)
    return [f1, f2]
