"""Gross outliers: rows no smooth gap and no noise can explain, found before the fit and left out of it.

A row is a gross outlier when one of its channels is more than OUTLIER_Z noise σ off
* its replicates (the median of its operating point's rows, when the point has at least three), or
* the model and its neighbours: the point's residual against the median residual of its nearest points
  (spatial.Neighbours), beyond both its own noise and the neighbours' spread. A gap is smooth, so its
  points agree with their neighbours, and where it bends sharply the neighbours' spread grows with it; a
  wrong reading stands alone.
At most MAX_SHARE of the rows are taken for outliers: more than that is the data, not a few wrong readings.
Each is named with its CSV line and what is off, in the measured column's own terms (ω2 20 % off, ...), so
an outlier never becomes an effect or a region.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from cvtdesign.core.kinematics import ShaftFrame
from cvtdesign.diagnosis.diagnose.noise import neighbour_noise, replicate_noise
from cvtdesign.diagnosis.diagnose.spatial import Neighbours
from cvtdesign.diagnosis.measured import MEASURED_CHANNELS, Measured

OUTLIER_Z = 8.0        # a reading this many σ off is not noise (Gaussian odds below 1e-15)
MAX_SHARE = 0.05       # at most this share of the rows are gross outliers
MAX_ROUNDS = 4         # rounds of the search among neighbours, each with the outliers found so far left out


@dataclass
class Outlier:
    """A row left out: its CSV line, what is off in words, and by how many noise σ."""
    line: int
    what: str
    sigmas: float

    def to_json(self) -> dict:
        return {"line": self.line, "what": self.what, "sigmas": self.sigmas}


def gross_outliers(raw: Measured, points: Measured, resid: dict, noise: dict, fits: dict[str, Neighbours],
                   frame: ShaftFrame) -> list[Outlier]:
    """The gross outliers among the rows of `raw` (module docstring). `resid`: a first fit's residuals at
    the operating points of `points` (merged replicates of `raw`; NaN where the model fails), `noise` their σ."""
    found = _among_replicates(raw, frame) if raw.replicated else {}
    for row, item in _against_neighbours(raw, points, resid, noise, fits, frame).items():
        found.setdefault(row, item)
    worst = sorted(found.items(), key=lambda kv: -kv[1].sigmas)
    return [o for _, o in worst[:int(MAX_SHARE * len(raw.rows))]]


def _among_replicates(raw: Measured, frame: ShaftFrame) -> dict:
    """{row: Outlier} of the rows far off the median of their operating point's rows (points of 3 or more)."""
    r = raw.rows
    cols = {c: col for c, col in MEASURED_CHANNELS.items() if col in r.columns}
    sigma = replicate_noise(raw, {c: r[col].to_numpy() for c, col in cols.items()})
    count = r.groupby("point")["point"].transform("size").to_numpy()
    out = {}
    for c, col in cols.items():
        v = r[col].to_numpy()
        dev = v - pd.Series(v).groupby(r["point"].to_numpy()).transform("median").to_numpy()
        z = np.where(count >= 3, np.abs(dev) / sigma[c], 0.0)
        for i in np.flatnonzero(z > OUTLIER_Z):
            if i not in out or z[i] > out[i].sigmas:
                out[i] = Outlier(int(r["line"].iat[i]), _what(c, dev[i], r.iloc[i], frame), float(z[i]))
    return out


def _against_neighbours(raw: Measured, points: Measured, resid: dict, noise: dict, fits: dict[str, Neighbours],
                        frame: ShaftFrame) -> dict:
    """{row: Outlier} of the rows of the operating points far off the model and their neighbours. Repeated
    with the points found so far left out, whose deviations spoil their neighbours' local fits and so the
    noise around them (two wild rows at γ 30° and 40° raised it tenfold there and hid each other)."""
    rows_of = raw.rows.groupby("point").indices
    out, off = {}, np.zeros(len(points.rows), bool)
    for _ in range(MAX_ROUNDS):
        r = {c: np.where(off, np.nan, v) for c, v in resid.items()}
        sigma = noise if raw.replicated else neighbour_noise(points, r, fits)
        new = np.zeros_like(off)
        for c, v in r.items():
            near = v[fits[c].near]
            med = np.nanmedian(near, axis=1)
            spread = 1.4826 * np.nanmedian(np.abs(near - med[:, None]), axis=1)
            dev = v - med
            z = np.abs(dev) / np.maximum(sigma[c], spread)
            for k in np.flatnonzero(np.nan_to_num(z) > OUTLIER_Z):
                new[k] = True
                for i in rows_of[points.rows["point"].iat[k]]:
                    if i not in out or z[k] > out[i].sigmas:
                        out[i] = Outlier(int(raw.rows["line"].iat[i]), _what(c, dev[k], raw.rows.iloc[i], frame),
                                         float(z[k]))
        if not new.any():
            break
        off |= new
    return out


def _what(channel: str, dev: float, row, frame: ShaftFrame) -> str:
    """What is off, in the measured column's terms: an α error as the relative ω2 error that makes it, a
    torque error on τ∥, an axis-angle error in degrees."""
    if channel == "alpha":
        g, w1, w2 = np.radians(row["gamma_cmd_deg"]), row["omega_1"], row["omega_2"]
        h = 1e-6
        slope = np.degrees(frame.slip_angle(w1, w2 * (1 + h), g) - frame.slip_angle(w1, w2 * (1 - h), g)) / (2 * h)
        share = dev / slope if abs(slope) > 1e-12 else np.nan
        return f"ω2 {share:+.0%} off (α {dev:+.2f}°)" if np.isfinite(share) else f"α {dev:+.2f}° off"
    if channel == "tau_par":
        return f"τ1 or τ2 off (τ∥ {dev:+.3f} N·m)"
    return f"γ_axis {dev:+.2f}° off"
