"""The noise level of each channel at each operating point.

From replicates (pooled within-point scatter) or, without replicates, from second differences of the base
fit's residuals along the load at each γ (a gap that is smooth in load cancels, noise does not), robust
(MAD) and pooled over neighbouring γ, since the noise of α and τ1 depends on γ through the kinematics.
Residuals divided by it are z-scores; they weight the fit.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from cvtdesign.diagnosis.diagnose.fitting import fit
from cvtdesign.diagnosis.diagnose.predictor import Predictor, channels, efficiency_mask, residuals, rms
from cvtdesign.diagnosis.measured import MEASURED_CHANNELS, Measured


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


def noise_source(points: Measured, raw: Measured) -> str:
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
    prelim = fit(P, points, {c: np.ones(P.n) for c in channels(points)})
    if raw is None or not raw.replicated:
        return noise_levels(points, residuals(points, prelim.pred))
    cols = {c: col for c, col in MEASURED_CHANNELS.items() if c in channels(raw)} | {"load": "tau_perp"}
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


def row_noise(points: Measured, noise: dict) -> dict:
    """The noise of one row (σ of a point's mean × √count): what the report calls the rig's noise."""
    n = np.sqrt(points.rows["count"].to_numpy())
    return {c: v * n for c, v in noise.items()}


def efficiency_noise(data, noise):
    """Noise floor of the efficiency residual, propagated from the torque noise: |∂η/∂τ1| σ with σ the
    τ∥ channel's noise (both torque components see the same torque noise)."""
    r = data.rows
    m = efficiency_mask(data)
    eta = r["efficiency"].to_numpy()
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.abs(eta / r["tau_1"].to_numpy()) * noise["tau_par"]
    return rms(d, m)
