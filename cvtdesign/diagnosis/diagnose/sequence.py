"""How the test was run: the direction each γ was approached from, and the drift over the test.

The rows' order in time is the `time_s` column when the data have one, else the order of the rows.

* Direction of approach (hysteresis: backlash in the steering linkage, friction in the forks). A row's γ was
  approached from below when the last different commanded γ before it was lower, from above when it was
  higher. Where operating points were measured from both directions, each direction is first taken as a
  point of its own, and the difference between the two readings of each point is tested against their noise
  (a χ² over the points and channels). The readings depend on the direction when that difference is both
  significant (p < P_SEQUENCE) and at least RESIDUE of one reading's noise (RMS over the points, beyond
  the noise's share): then the two directions stay separate points, so the noise is not the hysteresis, and
  the report says so. Otherwise they are replicates of each other.
* Drift (the rig warming up, wear). The diagnosed model is fitted again on the first and on the second half
  of the rows in time. A drift shows as parameters that differ between the halves by more than their
  uncertainty (χ², p < P_SEQUENCE), changing the predictions by at least RESIDUE of a reading's noise. It is
  only testable when both halves cover the same operating points (their middle 90 % of γ and of τ⊥ overlap
  by half of the whole range): a protocol run in order of γ cannot tell a drift from a γ-dependent effect.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from cvtdesign.diagnosis.diagnose.fitting import Fit, fit
from cvtdesign.diagnosis.diagnose.predictor import Models, Predictor, channels
from cvtdesign.diagnosis.diagnose.significance import chi2_sf
from cvtdesign.diagnosis.diagnose.verdict import RESIDUE
from cvtdesign.diagnosis.measured import MIN_POINTS, Measured, merge_points

TIME = "time_s"          # the optional time column of the measured data [s]
P_SEQUENCE = 1e-3        # significance of a direction dependence or a drift
OVERLAP = 0.5            # the halves of a drift test must share this much of the range of γ and of τ⊥


def row_order(raw: Measured) -> np.ndarray:
    """Each row's rank in time: by `time_s` when the data have it, else by its line."""
    r = raw.rows
    t = r[TIME].to_numpy() if TIME in r.columns else r["line"].to_numpy()
    return np.argsort(np.argsort(t, kind="stable"), kind="stable")


def approach(raw: Measured) -> np.ndarray:
    """+1 where a row's γ was approached from below, −1 from above, 0 before the first change of γ."""
    order = np.argsort(row_order(raw))
    g = raw.rows["gamma_cmd_deg"].to_numpy()[order]
    d = np.sign(np.diff(g, prepend=g[0]))
    d = pd.Series(np.where(d == 0, np.nan, d)).ffill().fillna(0).to_numpy()
    out = np.empty(len(g), int)
    out[order] = d
    return out


def split_by_direction(raw: Measured) -> Measured | None:
    """`raw` with each operating point split by the direction it was approached from (an `approach`
    column), or None when no point was measured from both directions."""
    a = approach(raw)
    r = raw.rows.assign(approach=a, origin=raw.rows["point"])
    both = r[a != 0].groupby("point")["approach"].nunique()
    if not (both > 1).any():
        return None
    r["point"] = pd.factorize(pd.Series(list(zip(r["point"], a))))[0]
    return Measured(raw.file, r, raw.has_axis, raw.dropped, raw.gamma_levels, raw.load_levels, raw.speed_levels)


@dataclass
class Direction:
    """The direction-of-approach test: the points measured both ways, per channel the mean and the RMS (beyond
    noise) of the difference from below − from above [unit], the largest RMS in a reading's noise, p."""
    points: int
    mean: dict
    rms: dict
    readings: float
    p: float
    found: bool

    def to_json(self) -> dict:
        return {"points": self.points, "mean_difference": self.mean, "rms_difference": self.rms,
                "in_reading_noise": self.readings, "p_value": self.p, "found": self.found}


def direction_test(points: Measured, resid: dict, noise: dict) -> Direction | None:
    """Test the operating points of `points` (split_by_direction, merged) measured from both directions:
    the difference of a first fit's residuals `resid` between the two readings of each, against the noise
    σ of each reading (`noise`, per point)."""
    r = points.rows
    if "approach" not in r.columns:
        return None
    up = {k: i for i, (k, a) in enumerate(zip(r["origin"], r["approach"])) if a > 0}
    pairs = [(up[k], i) for i, (k, a) in enumerate(zip(r["origin"], r["approach"])) if a < 0 and k in up]
    if not pairs:
        return None
    i, j = np.array(pairs).T
    stat, dof, mean, size, reading = 0.0, 0, {}, {}, 0.0
    count = r["count"].to_numpy()
    for c in channels(points):
        d = resid[c][i] - resid[c][j]
        var = noise[c][i] ** 2 + noise[c][j] ** 2
        ok = np.isfinite(d)
        stat, dof = stat + float(np.sum(d[ok] ** 2 / var[ok])), dof + int(ok.sum())
        mean[c] = float(np.mean(d[ok]))
        size[c] = float(np.sqrt(max(np.mean(d[ok] ** 2 - var[ok]), 0.0)))
        one = np.sqrt(np.mean(noise[c][i] ** 2 * count[i]))            # one reading's noise
        reading = max(reading, size[c] / one)
    p = chi2_sf(stat, dof) if dof else 1.0
    return Direction(len(pairs), mean, size, reading, p, bool(p < P_SEQUENCE and reading >= RESIDUE))


@dataclass
class Drift:
    """The drift test: whether it could be made (and why not), the diagnosed model's parameters fitted on
    the first and on the second half of the rows, the change of the predictions between them per channel
    (RMS [unit]) and in a reading's noise, p."""
    testable: bool
    why: str = ""
    early: dict | None = None
    late: dict | None = None
    change: dict | None = None
    readings: float = 0.0
    p: float = 1.0
    found: bool = False

    def to_json(self) -> dict:
        return {"testable": self.testable, "why_not": self.why, "early_fit": self.early, "late_fit": self.late,
                "prediction_change": self.change, "in_reading_noise": self.readings, "p_value": self.p,
                "found": self.found}


def drift_test(models: Models, raw: Measured, final: Fit, row_noise: dict, points: Measured) -> Drift:
    """Fit the final model on each half of the rows in time and compare (module docstring). `row_noise`:
    one reading's σ per channel at the operating points of `points`."""
    if not final.names:
        return Drift(False, "the model has no parameter to drift")
    order = row_order(raw)
    halves = [raw.rows[order < len(order) / 2], raw.rows[order >= len(order) / 2]]
    if min(h["point"].nunique() for h in halves) < MIN_POINTS:
        return Drift(False, f"a half of the test has fewer than {MIN_POINTS} operating points")
    if not _overlap(halves):
        return Drift(False, "the halves of the test cover different operating points (the order follows γ or "
                            "τ⊥), so a drift cannot be told from an effect of where it was measured")
    fits = []
    for rows in halves:
        half = merge_points(Measured(raw.file, rows, raw.has_axis, raw.dropped, raw.gamma_levels, raw.load_levels,
                                     raw.speed_levels))
        P = Predictor(models.layout, final.effects, half, models.shared)
        noise = {c: np.interp(half.rows["gamma_cmd_deg"], *_by_gamma(points, row_noise[c]))
                 / np.sqrt(half.rows["count"].to_numpy()) for c in channels(half)}
        fits.append(fit(P, half, noise, x0=final.theta, multistart=False))
    return _compare_halves(models, final, fits, row_noise)


def _compare_halves(models: Models, final: Fit, fits: list[Fit], row_noise: dict) -> Drift:
    a, b = fits
    good = np.isfinite(a.std) & np.isfinite(b.std) & (a.std > 0) & (b.std > 0)
    stat = float(np.sum((a.theta - b.theta)[good] ** 2 / (a.std ** 2 + b.std ** 2)[good]))
    p = chi2_sf(stat, int(good.sum())) if good.any() else 1.0
    P = models.get(final.effects)
    pa, pb = P(a.theta)[0], P(b.theta)[0]
    change = {c: float(np.sqrt(np.nanmean((pb[c] - pa[c]) ** 2))) for c in row_noise}
    reading = max(change[c] / np.sqrt(np.mean(row_noise[c] ** 2)) for c in change)
    return Drift(True, "", a.params(), b.params(), change, float(reading), p,
                 bool(p < P_SEQUENCE and reading >= RESIDUE))


def _overlap(halves: list[pd.DataFrame]) -> bool:
    """Whether the halves' middle 90 % of γ and of τ⊥ overlap by OVERLAP of the whole range."""
    for col in ("gamma_cmd_deg", "tau_perp"):
        lo = [np.percentile(h[col], 5) for h in halves]
        hi = [np.percentile(h[col], 95) for h in halves]
        whole = max(hi) - min(lo)
        if whole > 0 and (min(hi) - max(lo)) < OVERLAP * whole:
            return False
    return True


def _by_gamma(points: Measured, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(γ sorted, values in that order) for np.interp."""
    g = points.rows["gamma_cmd_deg"].to_numpy()
    order = np.argsort(g)
    return g[order], np.asarray(values)[order]
