"""The designer's dynamic figures from the dynamic model: a step response and its times, the fastest ratio change
the steering can drive and what limits it, and the ratio error while a cobot renders a constraint.

Definitions (of the axis angle γ_axis, from its steady value before the step y0 to the one after, y1):
rise time 10 % → 90 % of y1 − y0; settling time the last time |y − y1| exceeds 2 % of |y1 − y0|; overshoot the
largest excursion past y1 in % of |y1 − y0|; lag the time to 50 % (the delay a controller sees).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cvtdesign.core.dynamics.model import OUTPUTS, DynamicModel
from cvtdesign.core.dynamics.simulate import Trajectory, linkage_angle, simulate, steady_state

SAT_LIMIT = 0.999          # traction utilisation at which a contact is in gross slip (as core.model's)
SETTLE_BAND = 0.02         # settling band, a fraction of the step
RATE_RANGE = (1.0, 1e5)    # [deg/s] the rates the fastest-change search brackets (a ramp at 1 deg/s is
                           # quasi-static on every shipped layout; slower ones cost simulated time, not insight)
RATE_REL = 0.01            # the search stops when the bracket is this narrow (relative)


@dataclass
class Step:
    """A step response (module docstring); times in s, overshoot in %. `ok` False where the run left the
    physics (a contact in gross slip, or no steady state to start from or end at): `reason` says which."""
    trajectory: Trajectory | None
    rise_s: float | None
    settle_s: float | None
    overshoot_pct: float | None
    lag_s: float | None
    ok: bool
    reason: str = ""


def command(model: DynamicModel, gamma, load, t0=0.0, gamma_rate=0.0, load_is_tau_2=False, contacts=True):
    """INPUTS of a segment commanding γ [rad] at t0 [s], moving at gamma_rate [rad/s] (the linkage's angle and its
    rate follow by the inverse kinematics, linear over the segment)."""
    phi = linkage_angle(model, gamma)[0]
    slope = linkage_slope(model, gamma)
    return model.inputs(gamma, phi, load=load, gamma_rate=gamma_rate, phi_rate=slope * gamma_rate, t0=t0,
                        load_is_tau_2=load_is_tau_2, contacts=contacts)


def start(model: DynamicModel, gamma, load, load_is_tau_2=False) -> tuple[np.ndarray | None, float]:
    """(the steady state at command γ [rad] and load [N m], the torque τ2 [N m] on shaft 2 there). A transient
    holds that τ2: what loads shaft 2 (a brake, the operator's push on the joint) stays as it was while the
    ratio changes. The load stated as τ⊥ is the steady model's definition, which in a transient would make
    shaft 2's torque follow the motor's instantly (core.dynamics.model); it fixes the start only."""
    u = command(model, gamma, load, load_is_tau_2=load_is_tau_2)
    x = steady_state(model, u)
    if x is None or load_is_tau_2:
        return x, float(load)
    return x, float(model.outputs(0, x, u, model.param_values)[OUTPUTS.index("tau_2")])


def step_response(model: DynamicModel, gamma_from, gamma_to, load, duration=None, load_is_tau_2=False) -> Step:
    """The response to a step of the command from γ_from to γ_to [rad] at t = 0 from the steady state at γ_from
    and the load [N m] there, shaft 2's torque then held (`start`); run for `duration` [s] (default: 20 servo
    periods)."""
    x0, tau2 = start(model, gamma_from, load, load_is_tau_2)
    u0, u1 = (command(model, g, tau2, load_is_tau_2=True) for g in (gamma_from, gamma_to))
    x1 = None if x0 is None else steady_state(model, u1)
    if x0 is None or x1 is None:
        return Step(None, None, None, None, None, False, "no steady state at " + ("γ_from" if x0 is None else "γ_to"))
    T = 20.0 / model.parameters.servo_bandwidth if duration is None else duration
    tr = simulate(model, x0, [u1], T, 1000)
    if np.nanmax(tr.out["utilisation"]) >= SAT_LIMIT:
        return Step(tr, None, None, None, None, False, "gross slip during the step")
    y = tr.out["gamma_axis"]
    ends = [float(model.outputs(0, x, u, model.param_values)[0]) for x, u in ((x0, u0), (x1, u1))]
    return Step(tr, *step_times(tr.t, y, *ends), True)


def step_times(t, y, y0, y1) -> tuple:
    """(rise, settle, overshoot %, lag) of a response y(t) from y0 to y1 (module docstring); None where not
    reached within the run."""
    d = y1 - y0
    frac = (y - y0) / d

    def first(level):
        i = np.nonzero(frac >= level)[0]
        if i.size == 0:
            return None
        k = i[0]
        return float(t[k]) if k == 0 else float(np.interp(level, frac[k - 1:k + 1], t[k - 1:k + 1]))
    t10, t50, t90 = first(0.1), first(0.5), first(0.9)
    outside = np.nonzero(np.abs(frac - 1) > SETTLE_BAND)[0]
    settled = outside.size == 0 or outside[-1] < len(t) - 1
    settle = (float(t[outside[-1] + 1]) if outside.size else float(t[0])) if settled else None
    rise = None if t10 is None or t90 is None else t90 - t10
    return rise, settle, float(max(0.0, np.max(frac) - 1) * 100), t50


@dataclass
class FastestChange:
    """The largest dγ/dt [deg/s] a ramp of the command can have with no contact in gross slip and the steering
    motor within its curve; `limit` names what stops a faster one ('gross slip at <roller>', 'motor torque',
    'motor speed', or 'none' when even the bracket's top rate passes)."""
    rate_deg_s: float
    limit: str


def ramp_limit(model: DynamicModel, gamma_from, gamma_to, load, rate_deg_s, load_is_tau_2=False) -> str | None:
    """What a ramp of the command from γ_from to γ_to [rad] at rate_deg_s meets first (FastestChange's limit
    words), or None if it runs within every limit until a settling time after the ramp."""
    rate = np.radians(rate_deg_s) * np.sign(gamma_to - gamma_from)
    x0, tau2 = start(model, gamma_from, load, load_is_tau_2)
    if x0 is None:
        return "no steady state at γ_from"
    t_ramp = abs(gamma_to - gamma_from) / abs(rate)
    segments = _ramp_segments(model, gamma_from, gamma_to, rate, t_ramp, tau2)
    tr = simulate(model, x0, segments, t_ramp + 5.0 / model.parameters.servo_bandwidth, 400)
    util = tr.out["utilisation"]
    over = np.nonzero(np.nanmax(util, axis=0) >= SAT_LIMIT)[0]
    clipped = np.nonzero(np.abs(tr.out["motor_demand"]) > tr.out["motor_available"] * (1 + 1e-9))[0]
    if over.size == 0 and clipped.size == 0:
        return None
    if over.size and (clipped.size == 0 or over[0] <= clipped[0]):
        return f"gross slip at {model.roller_names[int(np.nanargmax(util[:, over[0]]))]}"
    k = clipped[0]
    slow = abs(tr.out["phi_rate"][k]) < 0.5 * model.parameters.motor_speed
    return "motor torque" if slow else "motor speed"


def fastest_change(model: DynamicModel, gamma_from, gamma_to, load, load_is_tau_2=False) -> FastestChange:
    """The FastestChange of a ramp from γ_from to γ_to [rad] at a load [N m]: bisection in log(rate) within
    RATE_RANGE to RATE_REL."""
    lo, hi = RATE_RANGE
    if ramp_limit(model, gamma_from, gamma_to, load, hi, load_is_tau_2) is None:
        return FastestChange(hi, "none")
    first = ramp_limit(model, gamma_from, gamma_to, load, lo, load_is_tau_2)
    if first is not None:
        return FastestChange(0.0, first)
    limit = None
    while hi / lo > 1 + RATE_REL:
        mid = np.sqrt(lo * hi)
        got = ramp_limit(model, gamma_from, gamma_to, load, mid, load_is_tau_2)
        lo, hi, limit = (mid, hi, limit) if got is None else (lo, mid, got)
    return FastestChange(float(lo), limit or ramp_limit(model, gamma_from, gamma_to, load, hi, load_is_tau_2))


def _ramp_segments(model, gamma_from, gamma_to, rate, t_ramp, tau2, pieces: int = 8) -> list:
    """Segments of a ramp at `rate` [rad/s] for t_ramp [s], then the command held at γ_to, shaft 2's torque τ2
    [N m] held: the linkage's angle linear within each of `pieces` pieces (exact for a linkage with φ = γ)."""
    times = np.linspace(0.0, t_ramp, pieces + 1)
    segs = [command(model, gamma_from + rate * t, tau2, t, rate, True) for t in times[:-1]]
    for k, s in enumerate(segs):       # the linkage's angle as the chord of each piece
        phi_end = linkage_angle(model, gamma_from + rate * times[k + 1])[0]
        s[3] = (phi_end - s[2]) / (times[k + 1] - times[k])
    return segs + [command(model, gamma_to, tau2, t_ramp, 0.0, True)]


def linkage_slope(model: DynamicModel, gamma, h: float = 1e-6) -> float:
    """dφ/dγ [-] of the linkage at γ, by a central difference of its inverse kinematics."""
    return float((linkage_angle(model, gamma + h)[0] - linkage_angle(model, gamma - h)[0]) / (2 * h))
