"""Load capacity: at each commanded γ, the largest lateral load τ⊥ of each sign that the CVT carries before its
first contact reaches a limit, which contact that is and which limit.

The limits are the model's own (core.model, `status`), so that capacity and `compare` judge a point alike:
 * gross_slip: some contact's tangential force reaches its friction, |F| > μN (under a saturation law, its
   utilisation |F|/(μN) passes model.SAT_LIMIT); with a safety factor S > 1, once some contact's utilisation
   reaches 1/S;
 * lost_contact: some contact's normal force N falls to zero;
 * pressure: at a point that holds, some contact's Hertz peak pressure p_max exceeds its allowable pressure,
   the smaller allowable_pressure of its roller's and the sphere's materials (core.metrics.allowable_pressures;
   a contact whose materials give none is not checked).
A point where the model has no number (not_converged, reversed, multiple_roots) is no limit of the CVT but
a limit of the model: where the search ends on one, the capacity is unknown and no number is returned.

Method, vectorised over γ and both signs (one `evaluate` call per step): the load is raised from zero in
steps of `bound`/SCAN_STEPS (a continuation in load: the first step that fails brackets the first limit,
not some later one), then the bracket is halved until it is narrower than RTOL of the load. The capacity is
the bracket's lower end, a load at which the point was evaluated and held; the limit and the contact are
those at its upper end, within RTOL beyond it. Brokowski et al. ("Toward improved CVTs", sec. 6.2.3) name this
figure: "the torque that can be transmitted before gross slip occurs"; Kim et al. ("Causes of microslip in a
continuously variable transmission", sec. 5.1) give why a layout whose drive and steering rollers share the
tractive forces among more contacts carries more.
"""
from __future__ import annotations

import numpy as np

from cvtdesign.core.metrics import allowable_pressures
from cvtdesign.core.model import STATUS, CompiledModel

LIMITS = ("gross_slip", "lost_contact", "pressure")   # the limits of the CVT a capacity can end at
SCAN_STEPS = 128      # steps of the load scan up to the search bound
SCAN_BLOCK = 16       # load steps evaluated per call of the scan
RTOL = 1e-6           # relative width of the final bracket
PRESSURE = len(STATUS)    # code of a point that holds with some contact over its allowable pressure
NO_LIMIT = -1             # code where no limit was met up to the search bound


def limit_codes(model: CompiledModel, res: dict, allow: np.ndarray, safety: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Per point of an `evaluate` result: (code, contact). code is 0 where the point holds within every
    limit, its STATUS code where the model flags it, gross_slip too where it holds but a contact's traction
    utilisation |F|/(μN) has reached 1/`safety`, PRESSURE where it holds but a contact's Hertz peak pressure is
    over its allowable `allow` [Pa] (NaN: not checked); contact is the index of the roller behind gross_slip
    (the most utilised), lost_contact or pressure (the one most over its allowable), −1 otherwise."""
    code, contact = res["status"].copy(), res["failed_contact"].copy()
    shape = (-1, *([1] * code.ndim))
    used = np.where(np.isfinite(res["utilisation"]), res["utilisation"], -np.inf)
    with np.errstate(invalid="ignore"):
        over = res["p_max"] / allow.reshape(shape)
    over = np.where(np.isfinite(over), over, -np.inf)
    slipping = (code == 0) & (used.max(axis=0) >= 1 / safety)
    code[slipping] = STATUS.index("gross_slip")
    contact[slipping] = np.argmax(used[:, slipping], axis=0)
    pressed = (code == 0) & (over.max(axis=0) > 1)
    code[pressed] = PRESSURE
    contact[pressed] = np.argmax(over[:, pressed], axis=0)
    return code, contact


def capacity(model: CompiledModel, gammas, bound: float, safety: float = 1.0, progress=None) -> dict:
    """The load capacity of `model` at each commanded γ [rad] (module docstring), searched up to |τ⊥| =
    `bound` [N m] (e.g. io.limits.load_capacity: all the traction the preloads allow), a contact counted as
    slipping grossly once its utilisation |F|/(μN) reaches 1/`safety` (safety ≥ 1).

    Returns a dict of arrays over γ, for side in ('max', 'min') (τ⊥ > 0 and τ⊥ < 0):
     * tau_perp_<side> [N m]: the capacity (NaN where unknown, and where the point fails without load);
     * tau_1_<side>, tau_2_<side> [N m]: the shaft torques at that load (the model evaluated there);
     * limit_<side>: a LIMITS name, 'not_converged', 'reversed' or 'multiple_roots' (the model has no number
       where the search ended: capacity unknown), or 'none' (no limit up to `bound`: capacity unknown);
     * contact_<side>: the index of the limiting roller (−1 where none), the one the model names;
       sharing_<side> (contacts × γ): every contact that reaches the limit with it (_sharing);
     * held_<side> [N m]: where the search ended on no limit of the CVT (limit not in LIMITS), the largest
       load at which the point was evaluated and held (NaN elsewhere), for saying how far the model went, and
       held_axis_<side> [rad] the sphere's axis angle γ_axis there: near ±90° the load has turned the axis
       to the pole of the speed ratio, where ω2/ω1 grows without bound and no steady state is left (the box
       at γ = 80°: γ_axis 89.99° and ω2/ω1 = 13642 at 4.47 N·m, not converged at 4.48 N·m).
    `progress(done, total, item)` is called after each evaluation."""
    g = np.atleast_1d(np.asarray(gammas, float))
    n = g.size
    allow = allowable_pressures(model.layout)
    G = np.concatenate([g, g])
    sign = np.repeat([1.0, -1.0], n)
    h = float(bound) / SCAN_STEPS

    def judge(loads):
        return limit_codes(model, model.evaluate(G[:, None], sign[:, None] * np.atleast_2d(loads)), allow, safety)

    steps = SCAN_STEPS // SCAN_BLOCK + int(np.ceil(np.log2(1 / RTOL))) + 1
    lo, hi, code, contact = _scan(judge, 2 * n, h, progress, steps)
    lo, hi, code, contact = _bisect(judge, lo, hi, code, contact, progress, steps)
    limited = np.isin(code, [STATUS.index("gross_slip"), STATUS.index("lost_contact"), PRESSURE])
    known = limited & (hi > 0)          # failing without load: the limit is named, there is no capacity
    res = model.evaluate(G, sign * lo)      # the last load that held (0 where none)
    shared = _sharing(res, code, allow, model.layout) & known
    names = {**dict(enumerate(STATUS)), PRESSURE: "pressure", NO_LIMIT: "none"}
    out = {"gamma": g, "bound": float(bound), "safety": float(safety)}
    for side, part in (("max", slice(0, n)), ("min", slice(n, 2 * n))):
        held = known[part] & res["ok"][part]
        out[f"tau_perp_{side}"] = np.where(held, sign[part] * lo[part], np.nan)
        for k in ("tau_1", "tau_2"):
            out[f"{k}_{side}"] = np.where(held, res[k][part], np.nan)
        out[f"limit_{side}"] = np.array([names[int(c)] for c in code[part]], dtype=object)
        out[f"contact_{side}"] = np.where(limited[part], contact[part], -1)
        out[f"sharing_{side}"] = shared[:, part]
        stopped = ~limited[part] & (lo[part] > 0)
        out[f"held_{side}"] = np.where(stopped, sign[part] * lo[part], np.nan)
        out[f"held_axis_{side}"] = np.where(stopped, res["gamma_axis"][part], np.nan)
    if progress:
        progress(steps, steps, None)
    return out


SHARE_TOL = 1e-3      # contacts within this of the limiting one's (normalised) measure reach the limit together


def _sharing(res: dict, code, allow, layout) -> np.ndarray:
    """(contacts × points) which contacts reach the point's limit together with the limiting one, at the
    capacity: within SHARE_TOL of the largest utilisation |F|/(μN) (gross_slip), of the smallest N/P
    (lost_contact) or of the largest p_max/p_allow (pressure). A pair of coupled rollers that share a
    tractive force equally (the box's A and A') reaches gross slip at the same load."""
    preload = np.array([r.preload for r in layout.rollers], float)[:, None]
    with np.errstate(invalid="ignore"):
        measures = {STATUS.index("gross_slip"): res["utilisation"], STATUS.index("lost_contact"): -res["N"] / preload,
                    PRESSURE: res["p_max"] / allow[:, None]}
    out = np.zeros(res["utilisation"].shape, bool)
    for c, m in measures.items():
        m = np.where(np.isfinite(m), m, -np.inf)
        on = code == c
        out[:, on] = m[:, on] >= m[:, on].max(axis=0, initial=-np.inf) - SHARE_TOL
    return out


def _scan(judge, m: int, h: float, progress, steps):
    """Raise |τ⊥| from zero in steps h, SCAN_BLOCK steps per call, until every point has failed: (lo, hi,
    code, contact) with hi the first failing load (code and contact its limit) and lo the one before (0 at
    the first step); hi NaN and code NO_LIMIT where no step up to SCAN_STEPS·h failed. A point that fails at
    zero load has hi = 0 and the limit it fails at."""
    lo, hi = np.zeros(m), np.full(m, np.nan)
    code, contact = np.full(m, NO_LIMIT), np.full(m, -1)
    c0, k0 = judge(np.zeros((1, 1)))
    failed = c0[:, 0] != 0
    hi[failed], code[failed], contact[failed] = 0.0, c0[failed, 0], k0[failed, 0]
    done = 0
    for start in range(1, SCAN_STEPS + 1, SCAN_BLOCK):
        if failed.all():
            break
        loads = h * np.arange(start, min(start + SCAN_BLOCK, SCAN_STEPS + 1))
        c, k = judge(loads[None, :])
        bad = c != 0
        first = np.argmax(bad, axis=1)
        new = ~failed & bad.any(axis=1)
        rows = np.flatnonzero(new)
        hi[new] = loads[first[new]]
        lo[new] = np.where(first[new] > 0, loads[first[new] - 1], loads[0] - h)
        code[new], contact[new] = c[rows, first[new]], k[rows, first[new]]
        failed |= new
        lo[~failed] = loads[-1]
        done += 1
        if progress:
            progress(done, steps, "scan")
    return lo, hi, code, contact


def _bisect(judge, lo, hi, code, contact, progress, steps):
    """Halve each bracket [lo, hi] (hi failing with `code`, lo holding) until hi − lo ≤ RTOL·hi; brackets
    at zero load (failing there) or without a failure are left as they are."""
    active = np.isfinite(hi) & (hi > 0)
    done = steps - int(np.ceil(np.log2(1 / RTOL))) - 1
    while active.any():
        mid = np.where(active, 0.5 * (lo + hi), 0.0)
        c, k = judge(mid[:, None])
        c, k = c[:, 0], k[:, 0]
        holds = active & (c == 0)
        fails = active & (c != 0)
        lo[holds] = mid[holds]
        hi[fails], code[fails], contact[fails] = mid[fails], c[fails], k[fails]
        active &= hi - lo > RTOL * hi
        done += 1
        if progress:
            progress(min(done, steps), steps, "bisection")
    return lo, hi, code, contact


def smallest_capacity(cap: dict) -> dict:
    """The smallest load capacity over γ and both signs of a `capacity` result: the largest |τ⊥| [N m] that every
    γ carries within the limits, and where it is reached; what an optimiser maximises or bounds from below
    (docs/capacity.md, "Capacity in a design study"). Returns {'tau_perp': |τ⊥| [N m], 'gamma' [rad], 'side'
    ('max' or 'min'), 'limit', 'contact' (roller index), 'unknown': the searches that ended on no limit of the
    CVT}. A point that fails without load carries 0. Where a search that ended on no limit held less than
    every known capacity, the smallest capacity is not known: tau_perp is NaN and gamma, side say where
    (limit None)."""
    best = {"tau_perp": np.inf, "gamma": np.nan, "side": None, "limit": None, "contact": -1, "unknown": 0}
    for side in ("max", "min"):
        for i, g in enumerate(cap["gamma"]):
            limit, tau = cap[f"limit_{side}"][i], abs(cap[f"tau_perp_{side}"][i])
            if limit in LIMITS:
                value, where = (tau if np.isfinite(tau) else 0.0), {"limit": limit, "contact": int(cap[f"contact_{side}"][i])}
            else:
                best["unknown"] += 1
                value, where = abs(cap[f"held_{side}"][i]), {"limit": None, "contact": -1}
                value = 0.0 if not np.isfinite(value) else value
            if value < best["tau_perp"]:
                best |= {"tau_perp": value, "gamma": float(g), "side": side, **where}
    if best["limit"] is None:
        best["tau_perp"] = np.nan
    return best
