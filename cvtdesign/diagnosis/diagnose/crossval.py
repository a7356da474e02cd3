"""Held-out scores: K-fold cross-validation grouped by operating point (replicates stay together, so no point
scores its own fit), and the comparison of two models on the points both predict."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cvtdesign.diagnosis.diagnose.fitting import Fit, fit
from cvtdesign.diagnosis.diagnose.predictor import (Predictor, efficiency_mask, model_efficiency, residuals, rms,
                                                    zscores)
from cvtdesign.diagnosis.diagnose.significance import wilcoxon_greater
from cvtdesign.diagnosis.diagnose.spatial import Neighbours, neighbour_pairs, structured_power
from cvtdesign.diagnosis.measured import FOLDS, Measured


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
    return Score(P.effects, full, ho["pred"], ok, z, z2, zf2, float(np.mean(~ok)), rms(res["alpha"], ok),
                 rms(eff_d - eff_m, efficiency_mask(data) & ok))


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


def compare(before: Score, after: Score, channels: int, nb: Neighbours) -> Comparison:
    """`after` against `before` on the points where both predict (held out)."""
    common = before.ok & after.ok
    b, a = before.per_point[common], after.per_point[common]
    if not common.any():
        return Comparison(0, (np.nan, np.nan), -np.inf, 1.0, np.inf, (0.0, 0.0), np.inf)
    d = b - a
    p = 1.0 if np.allclose(d, 0) else wilcoxon_greater(d)[1]
    n = common.sum() * channels
    dk = len(after.fit.theta) - len(before.fit.theta)
    dbic = float(np.sum(after.fit_per_point[common]) - np.sum(before.fit_per_point[common]) + dk * np.log(n))
    msz = (float(b.sum() / n), float(a.sum() / n))
    power = tuple(float(structured_power(nb, np.where(common, x.z, np.nan)).sum()) for x in (before, after))
    se = np.sqrt(channels / max(neighbour_pairs(nb, common), 1))
    return Comparison(int(common.sum()), msz, 1 - msz[1] / msz[0], p, dbic, power, float(se))


def gap_shrink(c: Comparison) -> float:
    """Fraction of the structured gap removed, over every channel (held out): 1 − √(P_after/P_before) with P
    the structured power (structured_power), which does not depend on the noise estimate; 0 when there was
    no structured gap."""
    before, after = c.power
    if not before > 0:
        return 0.0
    return float(1 - np.sqrt(max(after, 0.0) / before))
