"""The fit: the effect parameters (core.effects bounds) by bounded Gauss-Newton (scipy least_squares) on the
noise-weighted residuals, with the model's exact Jacobian (the implicit function theorem at the rows' solutions,
core.sensitivity). Uncertainty from (JᵀJ)⁻¹; a parameter whose standard deviation exceeds its own scale is
flagged as not identifiable."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from cvtdesign.core.effects import EFFECTS
from cvtdesign.core.model import status_counts
from cvtdesign.core.status import STATUS
from cvtdesign.diagnosis.diagnose.predictor import CHANNELS, Predictor, observed, residuals
from cvtdesign.diagnosis.measured import Measured

FAIL_Z = 1e3           # z-score of a row whose model solve fails (gross slip where the rig measured creep):
                       # far above any misfit, so a fit never buys its way out of residuals by failing rows


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
    at_bound: list = field(default_factory=list)    # per parameter: 'lower', 'upper' (`ends_at`) or None

    def params(self):
        """'effect.param' → {value, std, identifiable, at_bound}: at_bound 'lower' or 'upper' where the fit ended
        on that bound of the parameter (core.effects), which is then no result of the data but of the bound."""
        ends = self.at_bound or [None] * len(self.names)
        return {n: {"value": float(v), "std": float(s), "identifiable": bool(i), "at_bound": b}
                for n, v, s, i, b in zip(self.names, self.theta, self.std, self.identifiable, ends)}


AT_BOUND = 1e-3        # a fitted value within this share of its bounds' span (or of its scale) from a bound ends on it


def ends_at(theta, lo, hi, scale) -> list:
    """Per parameter, the bound the fit ended on ('lower', 'upper') or None: within AT_BOUND of the span
    between the bounds (of the parameter's scale where a bound is infinite)."""
    out = []
    for t, a, b, s in zip(theta, lo, hi, scale):
        tol = AT_BOUND * ((b - a) if np.isfinite(a) and np.isfinite(b) else max(abs(t), s))
        out.append("lower" if np.isfinite(a) and t - a <= tol else "upper" if np.isfinite(b) and b - t <= tol else None)
    return out


def bounds(names):
    """(lower, upper) bounds of the parameters `names` ('effect.param'), from core.effects."""
    lo, hi = [], []
    for n in names:
        e, p = n.split(".")
        spec = EFFECTS[e].params[p]
        lo.append(spec.lower)
        hi.append(spec.upper)
    return np.array(lo), np.array(hi)


def _starts(P: Predictor, x0):
    """Start points: the given one, and each parameter that may take either sign started on the other side."""
    lo, _ = bounds(P.names)
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
    lo, hi = bounds(P.names)
    measured = observed(data)

    def zfun(theta, jac=False):
        out = P(theta, jacobian=jac)
        pred, ok = out[0], out[1]
        res = residuals(data, pred, measured)
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
        P.pin(s)
        sol = least_squares(f, s, jac=j, bounds=(lo, hi), x_scale=scale, method="trf", xtol=1e-8,
                            ftol=1e-8, max_nfev=max_nfev)
        if best is None or sol.cost < best.cost:
            best = sol
    theta = best.x
    z, pred, ok = zfun(theta)
    # σ from the points where the model holds: a failed point's FAIL_Z is a penalty, not a misfit
    held = np.tile(ok[rows], len(chans))
    std, ident = _uncertainty(best.jac, theta, P.defaults, float(z[held] @ z[held]), int(held.sum()))
    return Fit(P.effects, P.names, theta, std, ident, pred, ok, float(z @ z), ends_at(theta, lo, hi, scale))


def failed_points(P: Predictor, data: Measured, f: Fit) -> dict:
    """Where the fitted model has no physical solution (status ≠ ok), by status with the contacts named
    (model.status_counts), and those points' (γ [deg], τ⊥ [N m]): left out of the gap, its regions and map."""
    bad = ~f.ok
    r = data.rows
    g, t = r["gamma_cmd_deg"].to_numpy()[bad], r["tau_perp"].to_numpy()[bad]
    counts = {"points": 0} | {k: 0 for k in STATUS[1:]}
    if bad.any():
        res = P.evaluate(np.radians(g), t, r["omega_1"].to_numpy()[bad], f.theta)
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
