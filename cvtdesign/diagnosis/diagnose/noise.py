"""The noise level of each channel at each operating point, from the data's own structure.

* Replicates (rows that repeat an operating point): each row's deviation from its point's mean. The model
  predicts at the measured load, so a residual's noise also holds the load's noise carried through the
  model's slope, σ² = σ_c² + (∂c/∂τ⊥)² σ_τ⊥² (errors in variables); the slope is the model's own, by central
  differences at each point (`load_slopes`), whatever the protocol: local fits over a point's neighbours
  could not give it where those neighbours all sit at one load (a grid of few load levels), and read the
  loads' noise as a slope of hundreds of degrees per N·m.
* Otherwise, neighbours: each point's residual against a local quadratic fit of its neighbours' residuals in
  (γ, τ⊥) (spatial.Neighbours.loo). A gap that is smooth at the scale of the neighbours cancels, noise does
  not; where the gap bends sharply between neighbours the estimate is an upper bound, so once the diagnosis
  has a model that removes the gap, the noise is estimated again from its residuals (`refine`).

Either way the deviations are pooled over the POOL samples nearest in γ (the noise of α and τ∥ depends on γ
through the kinematics) with a robust scale (MAD), so a few wild rows do not set it. Residuals divided by the
noise are z-scores; they weight the fit.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from cvtdesign.diagnosis.diagnose.fitting import Fit
from cvtdesign.diagnosis.diagnose.predictor import Predictor, channels, residuals, rms
from cvtdesign.diagnosis.diagnose.spatial import Neighbours
from cvtdesign.diagnosis.measured import MEASURED_CHANNELS, Measured

POOL = 30              # deviations pooled for each point's noise: the ones nearest to it in γ
LOAD_STEP = 1e-3       # share of the envelope's load range of the central differences of the model's load slope
REFINE = 0.8           # noise from the diagnosed model's residuals replaces the first estimate below this ratio
REPLICATES = "replicates"
NEIGHBOURS = "neighbours in (γ, τ⊥): local fits of the base model's residuals"
REFINED = "neighbours in (γ, τ⊥): local fits of the diagnosed model's residuals"


def pooled_scale(gamma: np.ndarray, samples: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Robust σ (1.4826 × median |x|, the samples having zero mean) of the POOL finite `samples` nearest
    in γ to each γ of `at` [deg]; floored at 1e-9 of the largest, so no point gets an infinite weight."""
    ok = np.isfinite(samples)
    g, x = np.asarray(gamma, float)[ok], np.abs(np.asarray(samples, float)[ok])
    if x.size == 0:
        return np.full(len(at), np.nan)
    order = np.argsort(g, kind="stable")
    g, x = g[order], x[order]
    want = min(POOL, x.size)
    lo = np.clip(np.searchsorted(g, at) - want // 2, 0, x.size - want)
    s = 1.4826 * np.median(x[lo[:, None] + np.arange(want)], axis=1)
    return np.maximum(s, 1e-9 * np.max(s) + 1e-15)


def neighbour_noise(points: Measured, resid: dict, fits: dict[str, Neighbours]) -> dict:
    """σ of each channel's point means from the local-fit deviations of `resid` (NaN where a model fails),
    each channel over its own neighbourhoods (spatial.local_fits); pooled as a row's noise (× √count), so
    points of one row and means of a few are read alike."""
    g = points.rows["gamma_cmd_deg"].to_numpy()
    n = np.sqrt(points.rows["count"].to_numpy())
    return {c: pooled_scale(g, fits[c].loo(v) * n, g) / n for c, v in resid.items()}


def replicate_noise(raw: Measured, values: dict) -> dict:
    """σ of one row of each channel of `values` (per raw row) from its scatter about its operating point's
    mean (√(n/(n−1)) scaled), pooled over the replicated rows nearest in γ; per raw row."""
    r = raw.rows
    count = r.groupby("point")["point"].transform("size").to_numpy()
    g = r["gamma_cmd_deg"].to_numpy()
    out = {}
    for c, v in values.items():
        v = np.asarray(v, float)
        dev = v - pd.Series(v).groupby(r["point"].to_numpy()).transform("mean").to_numpy()
        dev = np.where(count > 1, dev * np.sqrt(count / np.maximum(count - 1, 1)), np.nan)
        out[c] = pooled_scale(g, dev, g)
    return out


def estimate_noise(prelim: Fit, points: Measured, raw: Measured, fits: dict[str, Neighbours], P: Predictor) -> dict:
    """σ of each channel at each operating point of `points` (merged replicates of `raw`, measured.merge_points),
    the noise of the point's mean: a row's σ over √count (module docstring). `prelim`: a first (unweighted)
    fit of the base model `P`."""
    if not raw.replicated:
        return neighbour_noise(points, held(points, prelim), fits)
    cols = {c: col for c, col in MEASURED_CHANNELS.items() if c in channels(raw)} | {"load": "tau_perp"}
    per_row = replicate_noise(raw, {c: raw.rows[col].to_numpy() for c, col in cols.items()})
    first = raw.rows.reset_index(drop=True).groupby("point").head(1)
    idx = first.index.to_numpy()[np.argsort(first["point"].to_numpy())]
    n = points.rows["count"].to_numpy()
    slopes = load_slopes(P, points, prelim.theta)
    return {c: np.sqrt(per_row[c][idx] ** 2 + (slopes[c] * per_row["load"][idx]) ** 2) / np.sqrt(n)
            for c in cols if c != "load"}


def load_slopes(P: Predictor, points: Measured, theta) -> dict:
    """∂c/∂τ⊥ of each channel's prediction at each operating point [° or N·m per N·m], the model with `P`'s
    effects at `theta`, by central differences over ±LOAD_STEP of the envelope's load range (one-sided where
    the model fails on one side, 0 where it fails on both: no slope is read where its physics stops)."""
    r, model = points.rows, P.model
    g, t = np.radians(r["gamma_cmd_deg"].to_numpy()), r["tau_perp"].to_numpy()
    h = LOAD_STEP * max(float(np.ptp(model.layout.load_grid)), 1e-3)
    sides = []
    for dt in (-h, 0.0, h):
        res = P.evaluate(g, t + dt, r["omega_1"].to_numpy(), theta)
        _, tau_par = model.frame.load_split(g, res["tau_1"], res["tau_2"])
        sides.append({"alpha": np.degrees(res["alpha"]), "tau_par": tau_par, "axis": np.degrees(res["gamma_axis"])})
    out = {}
    for c in sides[0]:
        lo, mid, hi = (s[c] for s in sides)
        d = np.where(np.isfinite(lo) & np.isfinite(hi), (hi - lo) / (2 * h),
                     np.where(np.isfinite(hi), (hi - mid) / h, (mid - lo) / h))
        out[c] = np.nan_to_num(d, nan=0.0)
    return out


def refine(points: Measured, raw: Measured, fits: dict[str, Neighbours], noise: dict, final: Fit) -> tuple[dict, bool]:
    """The noise from the diagnosed model's residuals where that is clearly lower (below REFINE of the
    first estimate's RMS in some channel): (noise, whether it changed). Replicates' noise does not depend on
    a model and stays."""
    if raw.replicated:
        return noise, False
    new = neighbour_noise(points, held(points, final), fits)
    lower = any(rms(new[c]) < REFINE * rms(noise[c]) for c in noise)
    return (new, True) if lower else (noise, False)


def noise_source(raw: Measured, refined: bool) -> str:
    """Where the noise estimate comes from (module docstring)."""
    return REPLICATES if raw.replicated else REFINED if refined else NEIGHBOURS


def held(points: Measured, f: Fit) -> dict:
    """A fit's residuals where its physics holds (NaN elsewhere: an unconverged solve is no prediction)."""
    return {c: np.where(f.ok, v, np.nan) for c, v in residuals(points, f.pred).items()}


def row_noise(points: Measured, noise: dict) -> dict:
    """The noise of one row (σ of a point's mean × √count): what the report calls the rig's noise."""
    n = np.sqrt(points.rows["count"].to_numpy())
    return {c: v * n for c, v in noise.items()}
