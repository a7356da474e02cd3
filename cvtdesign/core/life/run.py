"""Heat, wear and life of every contact of a variant over a duty cycle (docs/life.md); units SI.

At each duty point the model (core.model) gives each contact's normal force, patch, rolling speed, and the
power its creep and spin dissipate. To that this adds the rolling resistance of hysteresis (Johnson;
core.life.hysteresis), which the motor supplies. Each roller takes its share of both as heat (all of its
own hysteresis, its effusivity's share of the friction: core.life.thermal), and its lumped temperature over
the repeated cycle follows. The temperature feeds back: a softer roller creeps more (Hertz + Kalker: the
creep compliance at a given load goes as E^(−1/3), applied to each side's creep scale at its hottest
roller), its patch grows (a ∝ E^(−1/3)) and its μ falls; the model is evaluated again until the cycle-mean
temperatures agree to TOL_K. Where they run away instead (the loss grows with temperature faster than the
roller sheds it), or the model stops holding at the hot state (gross slip, lost contact), the limit is
`runaway`. Then, per contact: wear from the frictional work (core.life.wear), the temperature against the
materials' maximum, and for steel on steel the L10 over the cycle by Miner's rule (core.life.fatigue); its
life is the hours to the first of these limits.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from cvtdesign.core.effects import CALIBRATION, EFFECTS
from cvtdesign.core.geometry import roller_pose
from cvtdesign.core.inputs import model_inputs
from cvtdesign.core.life import fatigue, hysteresis, thermal, wear
from cvtdesign.core.life.duty import WEAR_LIMIT_RATIO, DutyCycle
from cvtdesign.core.life.props import friction_factor, modulus_factor
from cvtdesign.core.model import CompiledModel, compile_model
from cvtdesign.core.status import STATUS

TOL_K = 1e-3            # [K] the temperatures' change at which the feedback has converged
MAX_ITER = 100
RUNAWAY_K = 573.15      # [K] 300 °C: a roller this hot has run away whatever its material
CREEP_SCALES = {side: f"{effect}.scale" for side, effect in CALIBRATION.items()}   # each side's creep scale


class DutyOutsideModel(Exception):
    """A duty point where the model does not hold at the ambient temperature (its status and contact)."""


@dataclass
class ContactLife:
    """One contact's figures over the cycle (arrays: one entry per duty point)."""
    name: str
    loss: np.ndarray          # [W] creep, spin and hysteresis
    friction: np.ndarray      # [W] creep and spin
    hysteresis: np.ndarray    # [W]
    heat: np.ndarray          # [W] into the roller
    T_mean: float             # [K] the cycle-mean temperature
    T_peak: float             # [K] the cycle's highest, with the flash temperature
    wear_rate: float          # [m/s] mean depth rate
    wear_limit: float         # [m]
    life: float               # [s] to the first limit
    limit: str                # temperature, wear, fatigue or runaway
    lives: dict               # [s] each limit's own time
    curve: tuple = ()         # (times [s], temperatures [K]) over one cycle, the flash left out
    warm_up: tuple = ()       # (times [s], cycle-mean temperatures [K]) from a cold start
    why: str = ""             # what ran away


@dataclass
class MachineLife:
    contacts: list
    life: float               # [s]
    limit: str
    contact: str
    iterations: int
    power_in: np.ndarray      # [W] per duty point: the shafts' input, hysteresis included
    power_out: np.ndarray     # [W] per duty point


def rolling_speeds(model: CompiledModel, res: dict) -> np.ndarray:
    """Each contact's rolling speed R |Ω·a| [m/s] at each point (contacts × points), a the axle at the point's
    steering angle (core.geometry.roller_pose, mapped over the points)."""
    L = model.layout
    phi = ca.SX.sym("phi")
    axles = ca.Function("axles", [phi], [ca.horzcat(*[roller_pose(r, phi)[1] for r in L.rollers])])
    n = np.size(res["phi"])
    a = np.asarray(axles.map(n)(np.reshape(res["phi"], (1, n)))).reshape(3, n, len(L.rollers))
    om = np.stack([np.ravel(res["Omega_x"]), np.ravel(res["Omega_y"]), np.ravel(res["Omega_z"])])
    return L.sphere_radius * np.abs(np.einsum("jk,jki->ik", om, a))


def _theta(model: CompiledModel, scales: dict, theta=None) -> np.ndarray:
    th = np.array(model.param_values if theta is None else theta, float)
    for side, name in CREEP_SCALES.items():
        if name in model.param_names:
            th[model.param_names.index(name)] *= scales[side]
    return th


def _softening(model, ageing, T) -> tuple[dict, np.ndarray]:
    """Each side's creep-scale factor (its hottest roller's E^(−1/3)) and each roller's E(T)/E factor."""
    f = np.array([modulus_factor(a[0], t) for a, t in zip(ageing, T)])
    sides = {"drive": [i for i, r in enumerate(model.layout.rollers) if r.role != "steering"],
             "steering": [i for i, r in enumerate(model.layout.rollers) if r.role == "steering"]}
    return {s: float(np.max(f[ix] ** (-1 / 3))) if ix else 1.0 for s, ix in sides.items()}, f


def _evaluate(model, duty, theta, design=None):
    res = model.evaluate(duty.gamma, duty.load, speeds=duty.speed, theta=theta, design=design)
    return res, rolling_speeds(model, res) if np.all(res["ok"]) else None


def _not_ok(model, res) -> tuple[int, str, str]:
    k = int(np.flatnonzero(~res["ok"])[0])
    c = int(res["failed_contact"][k])
    return k, STATUS[int(res["status"][k])], (model.roller_names[c] if c >= 0 else "")


def _heat(model, ageing, res, V, Efac):
    """Per contact and point: (friction loss, hysteresis loss, heat into the roller) [W]."""
    L = model.layout
    fr = np.maximum(np.asarray(res["loss"], float), 0.0)
    own_resistance = any("resistance" in EFFECTS[e].hooks for e in L.effects)
    hy, heat = np.zeros_like(fr), np.zeros_like(fr)
    for i, r in enumerate(L.rollers):
        ra, sa = ageing[i]
        s_r, s_s = hysteresis.energy_shares(r.material.E * Efac[i], r.material.nu, L.sphere_material.E,
                                            L.sphere_material.nu)
        alpha = hysteresis.contact_loss_fraction(ra["loss_fraction"], s_r, sa["loss_fraction"], s_s)
        if not own_resistance:              # else the model's own rolling resistance (an effect) holds it
            a = res["a"][i] * Efac[i] ** (-1 / 3)
            hy[i] = hysteresis.rolling_resistance(alpha, res["N"][i], a, hysteresis.rolling_radius(
                L.sphere_radius, r.radius)) * V[i]
        own = ra["loss_fraction"] * s_r / alpha if alpha > 0 else 1.0
        e_r = thermal.effusivity(ra["conductivity"], ra["density"], ra["specific_heat"])
        e_s = thermal.effusivity(sa["conductivity"], sa["density"], sa["specific_heat"])
        heat[i] = own * hy[i] + thermal.heat_share(e_r, e_s) * fr[i]
    return fr, hy, heat


def _thermal(model, ageing, duty, heat, V):
    """Per roller: (C, G per point, cycle temperatures (starts, means, mean))."""
    out = []
    for i, r in enumerate(model.layout.rollers):
        ra = ageing[i][0]
        C = thermal.heat_capacity(ra["density"], ra["specific_heat"], r.radius, r.width, duty.hub_ratio)
        G = thermal.convection_coefficient(V[i] / r.radius, r.radius) * thermal.surface_area(
            r.radius, r.width, duty.hub_ratio) + thermal.hub_conductance(ra["conductivity"], r.width, duty.hub_ratio)
        out.append((C, G, thermal.cycle_temperatures(heat[i], G, duty.seconds, C, duty.ambient)))
    return out


def consistent_state(model: CompiledModel, duty: DutyCycle, ageing: list, theta=None, design=None) -> dict:
    """Iterate model ⇄ temperatures to the consistent state (module docstring). `theta` (the model's θ at
    25 °C, default its own) and `design` (an uncertain_model's deviations of its physical inputs, core.inputs)
    move the model's own inputs. Returns the state's arrays, with `runaway` (None, or (contact index, why))
    and the iterations taken."""
    T = np.full(len(model.layout.rollers), duty.ambient)
    runaway, last = None, None
    for it in range(1, MAX_ITER + 1):
        scales, Efac = _softening(model, ageing, T)
        res, V = _evaluate(model, duty, _theta(model, scales, theta), design)
        if V is None:
            k, status, contact = _not_ok(model, res)
            if it == 1:
                raise DutyOutsideModel(f"duty point {k + 1}: {status.replace('_', ' ')}"
                                       + (f" at {contact}" if contact else ""))
            runaway = (model.roller_names.index(contact) if contact else 0, f"{status} when hot")
            break
        fr, hy, heat = _heat(model, ageing, res, V, Efac)
        th = _thermal(model, ageing, duty, heat, V)
        last = dict(res=res, V=V, friction=fr, hysteresis=hy, heat=heat, thermal=th, T=T, iterations=it)
        T_new = np.array([t[2][2] for t in th])
        mu = np.array([[friction_factor(a[0], t)] for a, t in zip(ageing, T_new)])
        slips = np.nanmax(res["utilisation"] / mu, axis=1) >= 1
        if np.any(T_new > RUNAWAY_K) or np.any(slips):
            i = int(np.argmax(slips)) if np.any(slips) else int(np.argmax(T_new))
            runaway = (i, "gross slip when hot" if slips[i] else "temperature beyond 300 °C")
            break
        if np.max(np.abs(T_new - T)) < TOL_K:
            break
        T = T_new
    else:
        runaway = (int(np.argmax(T)), f"no consistent temperature in {MAX_ITER} iterations")
    return {**last, "runaway": runaway}


def warm_theta(model: CompiledModel, duty: DutyCycle, ageing: list, design=None) -> tuple[np.ndarray, np.ndarray]:
    """(the model's θ with each side's creep scale at its rollers' consistent temperatures, those temperatures
    [K]) over the duty cycle, at the design `design` (consistent_state); the ambient's θ and temperatures
    where the model does not hold on the duty at the ambient. Where it runs away, its last iterate's."""
    try:
        T = consistent_state(model, duty, ageing, design=design)["T"]
    except DutyOutsideModel:
        T = np.full(len(model.layout.rollers), duty.ambient)
    scales, _ = _softening(model, ageing, T)
    return _theta(model, scales), T


def fatigue_reference(m) -> tuple | None:
    """A steel's fatigue test contact (semi-axis along rolling, across, track) [m], or None where its material
    does not give it (core.life.fatigue: the contact is then taken at the test's size and shape)."""
    keys = ("fatigue_rolling", "fatigue_across", "fatigue_track")
    return tuple(m[k] for k in keys) if m.has(*keys) else None


def _contact(model, duty, ageing, state, i) -> ContactLife:
    """One contact's figures and life from the consistent state."""
    r, (ra, sa) = model.layout.rollers[i], ageing[i]
    res, V, s = state["res"], state["V"], duty.shares
    C, G, (starts, _, T_mean) = state["thermal"][i]
    e_r = thermal.effusivity(ra["conductivity"], ra["density"], ra["specific_heat"])
    e_s = thermal.effusivity(sa["conductivity"], sa["density"], sa["specific_heat"])
    flash = thermal.flash_temperature(thermal.heat_share(e_r, e_s) * state["friction"][i], res["a"][i],
                                      res["b"][i], V[i], ra["conductivity"], ra["density"], ra["specific_heat"],
                                      duty.seconds)
    ends = np.roll(starts, -1)
    T_peak = float(np.max(np.maximum(starts, ends) + flash))
    rate = wear.wear_rate(ra["wear_coefficient"], state["friction"][i], r.radius, res["b"][i])
    mean_rate = float(np.sum(s * rate))
    limit = duty.wear_limit if duty.wear_limit is not None else WEAR_LIMIT_RATIO * r.radius
    lives = {"wear": limit / mean_rate if mean_rate > 0 else math.inf}
    T_max = ra["max_temperature"]
    G_mean = float(np.sum(s * G))
    lives["temperature"] = thermal.warm_up_time(T_max - (T_peak - T_mean), T_mean, duty.ambient, C, G_mean)
    if ra.has("fatigue_pressure") and sa.has("fatigue_pressure"):
        patch = (res["a"][i], res["b"][i], 2 * math.pi * r.radius)      # both bodies on the roller's track
        l10 = np.minimum(*(fatigue.l10_seconds(res["p_max"][i], V[i], r.radius, m["fatigue_pressure"],
                                               m["fatigue_cycles"], m["fatigue_exponent"], patch,
                                               fatigue_reference(m)) for m in (ra, sa)))
        lives["fatigue"] = fatigue.miner_life(l10, s)
    limit_name = min(lives, key=lives.get)
    curve = thermal.cycle_curve(starts, state["heat"][i], G, duty.seconds, C, duty.ambient)
    warm = thermal.warm_up_curve(T_mean, duty.ambient, C, G_mean)
    return ContactLife(model.roller_names[i], state["friction"][i] + state["hysteresis"][i], state["friction"][i],
                       state["hysteresis"][i], state["heat"][i], T_mean, T_peak, mean_rate, limit,
                       lives[limit_name], limit_name, lives, curve, warm)


def machine_life(model: CompiledModel, duty: DutyCycle, ageing: list, theta=None, design=None) -> MachineLife:
    """Every contact's life over the duty cycle and the machine's: its first contact's (module docstring).
    `ageing`: per roller, in the layout's order, (its material's Ageing, the sphere's); `theta`, `design`: the
    model's own inputs moved (consistent_state)."""
    state = consistent_state(model, duty, ageing, theta, design)
    contacts = [_contact(model, duty, ageing, state, i) for i in range(len(model.layout.rollers))]
    if state["runaway"] is not None:
        i, why = state["runaway"]
        c = contacts[i]
        c.life, c.limit, c.lives = 0.0, "runaway", {**c.lives, "runaway": 0.0}
        c.why = why
    first = min(contacts, key=lambda c: c.life)
    res = state["res"]
    p1, p2 = res["tau_1"] * res["omega_1"], res["tau_2"] * res["omega_2"]
    hyst = np.sum(state["hysteresis"], axis=0)
    p_in = np.maximum(p1, 0) + np.maximum(p2, 0) + hyst
    p_out = -np.minimum(p1, 0) - np.minimum(p2, 0)
    return MachineLife(contacts, first.life, first.limit, first.name, state["iterations"], p_in, p_out)


RATIO_RANGE = (0.4, 2.5)   # |ω2/ω1| where a relative ratio error means something (Brokowski's resteering range)


def worn_ratio_error(model: CompiledModel, duty: DutyCycle, life: MachineLife) -> tuple[float, int | None]:
    """The speed ratio's error (requested − achieved)/requested that wear alone causes by the machine's life:
    the model compiled again with every roller's radius less what it has lost by then (each its own, so
    rollers of one shaft that wear differently fight, as built), against the unworn model, at the duty
    points whose ideal |ω2/ω1| lies in RATIO_RANGE. Returns the largest in size and its duty point (NaN,
    None where the life is not finite or no duty point is in the range)."""
    T = life.life
    ideal = np.abs(model.frame.ideal_ratio(duty.gamma))
    at = np.flatnonzero((ideal >= RATIO_RANGE[0]) & (ideal <= RATIO_RANGE[1]))
    if not (math.isfinite(T) and T > 0) or at.size == 0:
        return math.nan, None
    L = model.layout
    worn = dataclasses.replace(L, rollers=tuple(dataclasses.replace(r, radius=r.radius - c.wear_rate * T)
                                                for r, c in zip(L.rollers, life.contacts)))
    ratios = [m.evaluate(duty.gamma[at], duty.load[at], speeds=duty.speed[at]) for m in
              (model, compile_model(worn, effects=model.effects))]
    new, old = (r["omega_2"] / r["omega_1"] for r in ratios[::-1])
    err = (old - new) / old
    k = int(np.nanargmax(np.abs(err))) if np.any(np.isfinite(err)) else None
    return (math.nan, None) if k is None else (float(err[k]), int(at[k]))


def moves(model: CompiledModel, ageing: list) -> list[tuple[str, object]]:
    """Every uncertain input of the life chain, each with its +1σ move: (label, move). The materials' ageing
    constants with a σ (a move: (material, key, relative σ)), and the model's own inputs (core.inputs
    model_inputs: the creep calibration's σ and fitted effect parameters in θ; on an uncertain_model also the
    preloads, moduli, friction and the law's spin moment as its design vector), one move per input key
    (inputs that share a key are one quantity and move together): (θ, design)."""
    out = [(f"{m}: {k}", (m, k, sd)) for m, k, sd in
           sorted({(a.material, k, a.std[k]) for pair in ageing for a in pair for k in a.values if a.std.get(k)})]
    inputs = model_inputs(model)
    design_inputs = [i for i in inputs if not i.in_theta]
    for key in dict.fromkeys(i.key for i in inputs):
        th = np.array(model.param_values, float)
        d = np.zeros(model.design.numel())
        for i in inputs:
            if i.key == key and i.in_theta:
                th[model.param_names.index(i.target)] += i.std
        for j, i in enumerate(design_inputs):
            if i.key == key:
                d[j] = i.std
        out.append((key, (th, d)))
    return out


def moved_life(model, duty, ageing, move) -> MachineLife:
    """The machine's life with one input moved (a move of `moves`)."""
    if len(move) == 3:
        material, key, sd = move
        return machine_life(model, duty, [tuple(a.scaled(key, 1 + sd) if a.material == material else a
                                                for a in pair) for pair in ageing])
    return machine_life(model, duty, ageing, *move)


def life_interval(model, duty, ageing, base: MachineLife, z: float = 1.96, progress=None) -> dict:
    """Intervals [s] of the machine's life ('machine') and of each contact's (by name) from every uncertain
    input of the chain (`moves`: the materials' ageing constants and the model's own inputs): each moved by
    +1σ alone, the changes in log life added in quadrature (first order), ± z of that about the life. Each
    move re-runs the whole chain (model ⇄ temperature). `progress(done, total)` is told after each. A life
    that is 0 or infinite keeps itself as its interval."""
    todo = moves(model, ageing)
    names = ["machine"] + [c.name for c in base.contacts]
    lives0 = [base.life] + [c.life for c in base.contacts]
    var = np.zeros(len(names))
    for j, (_, move) in enumerate(todo):
        try:
            m = moved_life(model, duty, ageing, move)
            lives = [m.life] + [c.life for c in m.contacts]
        except DutyOutsideModel:
            lives = [0.0] * len(names)
        for i, (l0, l1) in enumerate(zip(lives0, lives)):
            if math.isfinite(l0) and l0 > 0 and math.isfinite(l1):
                var[i] += math.log(max(l1, 1e-300) / l0) ** 2
        if progress:
            progress(j + 1, len(todo))
    return {n: (l0 * math.exp(-z * math.sqrt(v)), l0 * math.exp(z * math.sqrt(v))) if math.isfinite(l0) and l0 > 0
            else (l0, l0) for n, l0, v in zip(names, lives0, var)}
