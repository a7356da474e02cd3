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
a limit of the model: where the search ends on one, the capacity is unknown and no number is returned,
unless the CVT ran away there (below). Two limits are the cobot's:
 * usable_ratio: at a point that holds, the CVT slip angle |α| passes `max_slip` (MAX_SLIP by default). α is
   the angle between the shaft-speed vector (ω1, ω2) and the commanded direction (Kim et al., "Causes of
   microslip in a continuously variable transmission", sec. 2.2), the direction error of the cobot's virtual
   constraint; it is defined at every γ, where the speed-ratio error is not (the ratio is 0 at γ = 0 and
   without bound towards ±90°);
 * runaway: the search ends where the model has no steady state, and at the last load that held the apparent
   axis γ + α (the axis that turns the shafts at their speeds) was within POLE_TOL of ±90°, the pole of the
   speed ratio: ω2/ω1 grows without bound as the load approaches it and no steady state is left beyond (the
   box at γ = 80°: 4.4725 N·m). The capacity is that last load; the output shaft runs away past it.

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

from cvtdesign.core.contact import hertz
from cvtdesign.core.kinematics import wrap_axis_angle
from cvtdesign.core.metrics import allowable_pressures
from cvtdesign.core.model import CompiledModel
from cvtdesign.core.status import STATUS, Status

LIMITS = ("gross_slip", "lost_contact", "pressure", "usable_ratio", "runaway")   # the limits a capacity can end at
SCAN_STEPS = 128      # steps of the load scan up to the search bound
SCAN_BLOCK = 16       # load steps evaluated per call of the scan
RTOL = 1e-6           # relative width of the final bracket
PRESSURE = len(STATUS)    # code of a point that holds with some contact over its allowable pressure
USABLE = len(STATUS) + 1  # code of a point that holds with |α| over the usable-ratio bound
RUNAWAY = len(STATUS) + 2  # code of a search that ended with the speed ratio at its pole (module docstring)
NO_LIMIT = -1             # code where no limit was met up to the search bound
MODEL_STOPS = (Status.NOT_CONVERGED, Status.REVERSED, Status.MULTIPLE_ROOTS)
# The default usable-ratio bound |α| ≤ 2°. Brokowski et al. ("Toward improved CVTs: theoretical and experimental
# results", sec. 5.2.1, eq. 23) judge a resteered CVT by its speed-ratio error over the ratios 0.4–2.5 and accept
# an average under 10 %. On Kim's law ω2/ω1 = tan γ an error α in the axis gives a relative ratio error
# 2α/sin 2γ to first order, largest at the ends of that range (sin 2γ = 0.69): 10 % there is α = 1.98°. So 2°
# keeps the ratio within about 10 % everywhere in 0.4–2.5 (exactly: −9.3 to +11.1 %, 7 % at ratio 1).
MAX_SLIP = float(np.radians(2.0))
POLE_TOL = float(np.radians(1.0))   # apparent axis within this of ±90° where the model stops: runaway (on the
#                                     shipped variants every stop is within 0.12°, ω2/ω1 ≥ 4900)
PIVOT_SHARE = 0.95    # a drive contact whose spin moment reaches this share of μNℓ pivots (pivoting)


def limit_codes(model: CompiledModel, res: dict, allow: np.ndarray, safety: float = 1.0,
                max_slip: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per point of an `evaluate` result: (code, contact). code is 0 where the point holds within every
    limit, its STATUS code where the model flags it, gross_slip too where it holds but a contact's traction
    utilisation |F|/(μN) has reached 1/`safety`, PRESSURE where it holds but a contact's Hertz peak pressure is
    over its allowable `allow` [Pa] (NaN: not checked), USABLE where it holds within those but |α| is over
    `max_slip` [rad] (None: no bound); contact is the index of the roller behind gross_slip (the most
    utilised), lost_contact or pressure (the one most over its allowable), −1 otherwise."""
    code, contact = res["status"].copy(), res["failed_contact"].copy()
    shape = (-1, *([1] * code.ndim))
    used = np.where(np.isfinite(res["utilisation"]), res["utilisation"], -np.inf)
    with np.errstate(invalid="ignore"):
        over = res["p_max"] / allow.reshape(shape)
    over = np.where(np.isfinite(over), over, -np.inf)
    slipping = (code == Status.OK) & (used.max(axis=0) >= 1 / safety)
    code[slipping] = Status.GROSS_SLIP
    contact[slipping] = np.argmax(used[:, slipping], axis=0)
    pressed = (code == Status.OK) & (over.max(axis=0) > 1)
    code[pressed] = PRESSURE
    contact[pressed] = np.argmax(over[:, pressed], axis=0)
    if max_slip is not None:
        with np.errstate(invalid="ignore"):
            code[(code == Status.OK) & (np.abs(res["alpha"]) > max_slip)] = USABLE
    return code, contact


def capacity(model: CompiledModel, gammas, bound: float, safety: float = 1.0, max_slip: float | None = MAX_SLIP,
             progress=None, design=None, theta=None) -> dict:
    """The load capacity of `model` at each commanded γ [rad] (module docstring), searched up to |τ⊥| =
    `bound` [N m] (e.g. io.limits.load_capacity: all the traction the preloads allow), a contact counted as
    slipping grossly once its utilisation |F|/(μN) reaches 1/`safety` (safety ≥ 1), the ratio no longer usable
    once |α| passes `max_slip` [rad] (None: not bounded).

    Returns a dict of arrays over γ, for side in ('max', 'min') (τ⊥ > 0 and τ⊥ < 0):
     * tau_perp_<side> [N m]: the capacity (NaN where unknown; 0 where a limit is met without load);
     * tau_1_<side>, tau_2_<side> [N m], alpha_<side>, alpha_steering_<side> [rad]: the shaft torques, the slip
       angle and its steering part (the sphere's axis off the command) at that load;
     * limit_<side>: a LIMITS name, 'not_converged', 'reversed' or 'multiple_roots' (the model has no number
       where the search ended, and the ratio was not at its pole: capacity unknown), or 'none' (no limit up to
       `bound`: capacity unknown);
     * contact_<side>: the index of the limiting roller (−1 where none, as for usable_ratio and runaway, which
       are the machine's), the one the model names; sharing_<side> (contacts × γ): every contact that
       reaches the limit with it (_sharing);
     * held_<side> [N m]: where the search ended on no limit (limit not in LIMITS), the largest load at which
       the point was evaluated and held (NaN elsewhere), for saying how far the model went, and
       held_axis_<side> [rad] the sphere's axis angle γ_axis there.
    Also max_slip (NaN where not bounded) and pivoting (`pivoting`, at zero load).
    `progress(done, total, item)` is called after each evaluation. `design` and `theta` (rows: one per γ),
    where given, are the model's design vector and θ at each γ: a sampled capacity (core.capacity_interval)
    searches many draws of the inputs in one call."""
    g = np.atleast_1d(np.asarray(gammas, float))
    n = g.size
    allow = allowable_pressures(model.layout)
    G = np.concatenate([g, g])
    sign = np.repeat([1.0, -1.0], n)
    h = float(bound) / SCAN_STEPS
    at = {k: None if v is None else np.concatenate([v, v]) for k, v in (("design", design), ("theta", theta))}

    def per_point(columns):
        return {k: None if v is None else np.repeat(v, columns, axis=0) for k, v in at.items()}

    def judge(loads):
        loads = np.atleast_2d(loads)
        res = model.evaluate(G[:, None], sign[:, None] * loads, **per_point(loads.shape[1]))
        return limit_codes(model, res, allow, safety, max_slip)

    steps = SCAN_STEPS // SCAN_BLOCK + int(np.ceil(np.log2(1 / RTOL))) + 1
    lo, hi, code, contact = _scan(judge, 2 * n, h, progress, steps)
    lo, hi, code, contact = _bisect(judge, lo, hi, code, contact, progress, steps)
    res = model.evaluate(G, sign * lo, **per_point(1))      # the last load that held (0 where none)
    code = np.where(_ran_away(res, code, lo), RUNAWAY, code)
    limited = np.isin(code, [Status.GROSS_SLIP, Status.LOST_CONTACT, PRESSURE, USABLE, RUNAWAY])
    known = limited & (hi > 0)          # failing without load: the limit is named, there is no capacity
    shared = _sharing(res, code, allow, model.layout) & known
    names = {**dict(enumerate(STATUS)), PRESSURE: "pressure", USABLE: "usable_ratio", RUNAWAY: "runaway",
             NO_LIMIT: "none"}
    out = {"gamma": g, "bound": float(bound), "safety": float(safety),
           "max_slip": np.nan if max_slip is None else float(max_slip),
           "pivoting": pivoting(model, g) if design is None and theta is None else {"modelled": False}}
    for side, part in (("max", slice(0, n)), ("min", slice(n, 2 * n))):
        held = known[part] & res["ok"][part]
        at_zero = limited[part] & (hi[part] == 0)        # a limit met without load: the capacity is 0
        out[f"tau_perp_{side}"] = np.where(held, sign[part] * lo[part], np.where(at_zero, 0.0, np.nan))
        for k in ("tau_1", "tau_2", "alpha", "alpha_steering"):     # where it held, or holds without load
            out[f"{k}_{side}"] = np.where(held | (at_zero & res["ok"][part]), res[k][part], np.nan)
        out[f"limit_{side}"] = np.array([names[int(c)] for c in code[part]], dtype=object)
        out[f"contact_{side}"] = np.where(limited[part], contact[part], -1)
        out[f"sharing_{side}"] = shared[:, part]
        stopped = ~limited[part] & (lo[part] > 0)
        out[f"held_{side}"] = np.where(stopped, sign[part] * lo[part], np.nan)
        out[f"held_axis_{side}"] = np.where(stopped, res["gamma_axis"][part], np.nan)
    if progress:
        progress(steps, steps, None)
    return out


def _ran_away(res: dict, code, lo) -> np.ndarray:
    """Where the search ended on a model stop (MODEL_STOPS) after holding some load, with the apparent axis
    γ + α at that load within POLE_TOL of ±90° (an axis is a line: γ + α wrapped to ±90°): the speed ratio's
    pole, the CVT's runaway (module docstring). Its contact is none."""
    with np.errstate(invalid="ignore"):
        pole = np.pi / 2 - np.abs(wrap_axis_angle(res["gamma_cmd"] + res["alpha"]))
        return np.isin(code, MODEL_STOPS) & (lo > 0) & res["ok"] & (pole < POLE_TOL)


def pivoting(model: CompiledModel, gammas) -> dict:
    """The drive and follower rollers that pivot on the sphere with no load, at each commanded γ [rad]: their
    spin moment |Mz| at PIVOT_SHARE or more of μNℓ, the moment of a patch that slides all over in pure spin
    (ℓ the Hertz pressure's mean lever, core.contact.hertz.pivot_lever). Where the shaft of a drive roller
    stands still (the box's B and B' at γ = 0) the sphere spins about that roller's contact normal; under a
    law with spin (FASTSIM) the patch then slides, dissipating power that reaches no output at any load.
    That is a loss and wear, not a limit of the load: the roller still carries its tangential force (the
    capacity at γ = 0 ends on a limit like elsewhere), so it is reported, not counted as a capacity.

    Returns {'modelled': False} where the law gives no spin moment at any contact although the drive contacts
    spin (a law without spin moment: the pivoting is not modelled, which is not 'none'); else {'modelled':
    True, 'share': (contacts × γ) |Mz|/(μNℓ) of the drive and follower rollers (NaN for steering rollers and
    where the point fails), 'pivots' (contacts × γ) share ≥ PIVOT_SHARE, 'loss' (contacts × γ) [W] each
    contact's power loss, 'power_loss' (γ) [W] the whole loss}."""
    g = np.atleast_1d(np.asarray(gammas, float))
    res = model.evaluate(g, np.zeros_like(g))
    drive = np.array([r.role != "steering" for r in model.layout.rollers])
    spins = np.nan_to_num(np.abs(res["spin"][drive])).max(initial=0) > 0
    if spins and not np.any(np.nan_to_num(res["M_spin"])):
        return {"modelled": False}
    lever = np.vectorize(lambda a, b: float(hertz.pivot_lever(a, b)))(res["a"], res["b"])
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.abs(res["M_spin"]) / (res["mu"] * res["N"] * lever)
    share[~drive] = np.nan
    return {"modelled": True, "share": share, "pivots": np.nan_to_num(share) >= PIVOT_SHARE, "loss": res["loss"],
            "power_loss": res["power_loss"]}


SHARE_TOL = 1e-3      # contacts within this of the limiting one's (normalised) measure reach the limit together


def _sharing(res: dict, code, allow, layout) -> np.ndarray:
    """(contacts × points) which contacts reach the point's limit together with the limiting one, at the
    capacity: within SHARE_TOL of the largest utilisation |F|/(μN) (gross_slip), of the smallest N/P
    (lost_contact) or of the largest p_max/p_allow (pressure). A pair of coupled rollers that share a
    tractive force equally (the box's A and A') reaches gross slip at the same load."""
    preload = np.array([r.preload for r in layout.rollers], float)[:, None]
    with np.errstate(invalid="ignore"):
        measures = {Status.GROSS_SLIP: res["utilisation"], Status.LOST_CONTACT: -res["N"] / preload,
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
