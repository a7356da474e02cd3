"""The effect vocabulary: each effect's name, parameters and the terms it adds to the model, in one place.

The names are fixed (the project's effect vocabulary, used on the command line, in variant files, in
measured-data studies and in diagnosis verdicts). The model (model.py) is one set of equations; an effect
contributes through one or more *hooks*, plain functions that the compiler calls for the effects that are
on, in the order of the vocabulary:

| hook | signature | what it changes |
| --- | --- | --- |
| `steering_angle` | (φ, p) → φ | the linkage's actual steering angle [rad] |
| `rolling_radius` | (roller, r, p) → r | a roller's effective rolling radius [m] |
| `creep_normal` | (N, (N_c, n), p) → (N_c, n) | the normal force N_c the creep law follows [N] (default: the preload) and the exponent n of ε ∝ N_c^(−n) (default 2/3), given the force balance's N |
| `friction` | (μ, p) → μ | the friction coefficient of a contact [-] |
| `compliance` | (c, p) → (c_t, c_a) | creep compliance added along the rolling direction t and the axle a [s/kg] |
| `saturation` | (c, p) → (g, u) | a factor g on the compliances and the traction utilisation u it used |
| `resistance` | (c, p) → M | resisting moment on the roller about its axle [N m] (the sphere gets −M·a) |
| `calibration` | (c, p) → k | a factor on the calibration of the contact's creep coefficients (laws on Kalker's coefficients, with calibration factors) [-] |

`c` is a `ContactState`: the CasADi expressions of one contact while the model is assembled; `p` maps the
effect's parameter names to their (symbolic) values. Adding an effect means adding one `Effect` below: its
parameters with their bounds, its hooks, how the diagnosis's self-check withholds it (`SelfCheck`), whether it
acts at zero load, and the name of its parameter in the independent simulator (which writes every effect a
second time, in its own form, by design: cvtdesign.verification.independent_sim); nothing else changes, and
test_every_effect_entry_is_complete (tests/unit/test_architecture.py) fails when an entry lacks any of these.
Each creep law is written for slip velocity s and tangential force F on the sphere, s + c·F = 0 (dissipative),
with c = ε·V for Kim's creep constant ε [1/N] and rolling speed V.

References: Kim et al., "Causes of microslip in a continuously variable transmission" (eqs 19-32, fitted
ε_S and ε_D); Brokowski et al., "Toward improved CVTs: theoretical and experimental results" (Gillespie's
creep/spin model, eqs 14-19; rolling resistance, sec. 4.4.2).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import casadi as ca

from cvtdesign.errors import InputError, suggest


HOOKS = ("steering_angle", "rolling_radius", "creep_normal", "friction", "compliance", "saturation", "resistance",
         "calibration")   # the hook table above, in its order
SWITCH = ":on"        # the suffix of an effect's switch in a switched model's parameters (parameter_vector)
# what a `collect` hook of an effect that is switched off contributes (core.equations.Hooks): no compliance, a
# saturation gain of 1 at utilisation 0, no resisting moment, a calibration factor of 1
NEUTRAL = {"compliance": (0.0, 0.0), "saturation": (1.0, 0.0), "resistance": 0.0, "calibration": 1.0}


@dataclass(frozen=True)
class Param:
    """One parameter of an effect: its default, its kind of quantity (an io.units KINDS key), and the bounds
    within which a variant may set it and the diagnosis fits it; `positive`: the lower bound is exclusive."""
    default: float
    kind: str
    doc: str
    lower: float = float("-inf")
    upper: float = float("inf")
    positive: bool = False


@dataclass(frozen=True)
class SelfCheck:
    """How the diagnosis's self-check (cvtdesign.verification.selfcheck) withholds an effect from data of the
    virtual rig: at `values` of `param` (two values a rig would plausibly show; None: the self-check sets them
    for each variant, see its module), at `weak` (a value whose signature is at or below the rig's noise, where
    the right verdict is `none` or the effect itself; None: no such case), and together with each effect of
    `told_from` (effects whose signature resembles this one's: the pair must be told apart)."""
    param: str
    values: tuple | None
    weak: float | None = None
    told_from: tuple = ()


@dataclass(frozen=True)
class Effect:
    """One effect of the vocabulary (module docstring). `calibrates`: 'drive' or 'steering' when the effect's
    `scale` parameter is the calibration of that side's creep (Kim's fitted creep model is the effects that
    calibrate); `at_zero_load`: whether it acts when no load is transmitted (the papers' zero-load checks
    leave these out); `independent`: its parameter's name in the independent simulator."""
    name: str
    doc: str
    params: dict
    hooks: dict[str, Callable]
    selfcheck: SelfCheck
    at_zero_load: bool
    independent: str
    calibrates: str | None = None


@dataclass
class ContactState:
    """One contact's expressions while the model is assembled (CasADi scalars and 3-vectors)."""
    roller: object        # variant.Roller
    drive: bool           # drive or follower roller (else a steering idler)
    V: object             # rolling speed |R Ω·a| [m/s]
    spin: object          # spin Ω·n [rad/s]
    spin_floor: object    # [rad/s] smoothing scale of |spin|
    speed_floor: object   # [rad/s] smoothing scale of the sign of Ω·a
    roll: object          # Ω·a [rad/s]
    N: object             # normal force of the force balance [N]
    N_creep: object       # normal force that the creep law follows [N]
    eps: object           # creep constant ε at N_creep [1/N]
    b: object             # lateral Hertz half-width at the preload [m]
    mu: object            # friction coefficient [-]
    Ft: object            # tangential force on the sphere along t [N]
    Fa: object            # along a [N]
    constants: dict = field(default_factory=dict)   # the contact law's constants of this patch (core.contact.laws)


def smooth_abs(x, eps):
    """|x| smoothed on the scale eps: √(x² + eps²)."""
    return ca.sqrt(x * x + eps * eps)


def atanh_ratio(u):
    """atanh(u)/u, → 1 as u → 0 (series below 1e-4): the compliance amplification of tanh saturation."""
    return ca.if_else(u < 1e-4, 1 + u * u / 3, ca.atanh(u) / ca.fmax(u, 1e-4))


# ---------------------------------------------------------------------------------------------- the hooks

def _drive_longitudinal(c: ContactState, p):
    """Kim eqs 25-30: slip ratio ψ = ε_D F_t at drive and follower rollers, c_t = scale·ε_D·V."""
    return (p["scale"] * c.eps * c.V, 0) if c.drive else (0, 0)


def _steering_lateral(c: ContactState, p):
    """Kim eqs 19-24: slip angle α⊥ = ε_S F_a at steering rollers, c_a = scale·ε_S·V."""
    return (0, p["scale"] * c.eps * c.V) if not c.drive else (0, 0)


def _drive_spin(c: ContactState, p):
    """Gillespie's creep/spin model (Brokowski eqs 14-19): slip velocity (b/(μN))·|Ω·n|·F along t at drive
    and follower rollers, b the lateral Hertz half-width at N (∝ N^(1/3))."""
    if not c.drive:
        return 0, 0
    b_n = c.b * (c.N_creep / c.roller.preload) ** (1.0 / 3.0)
    return p["scale"] * b_n / (c.mu * c.N_creep) * smooth_abs(c.spin, c.spin_floor), 0


def _normal_force_variation(N, default, p):
    """Creep follows the force-balanced normal force N, ε ∝ N^(−exponent) (Hertz + Kalker: 2/3)."""
    return N, p["exponent"]


def _rolling_resistance(c: ContactState, p):
    """Brokowski sec. 4.4.2: the pressure centre sits `offset` ahead of the contact, a moment offset·N that
    resists rolling: on the roller about its axle M = −offset·σ·N with σ the sign of −Ω·a (the direction the
    sphere's surface moves along t); the sphere gets the opposite moment −M·a."""
    sigma = -c.roll / smooth_abs(c.roll, c.speed_floor)
    return -p["offset"] * sigma * c.N_creep


def _traction_saturation(c: ContactState, p):
    """Creep force levelling off towards μN: F = μN·tanh(creepage/(ε μN)), i.e. compliance ×atanh(u)/u with
    u = |F|/(μN); u is held just below 1 while Newton iterates (a solution that needs u → 1 is gross slip)."""
    u = ca.fmin(ca.sqrt(c.Ft * c.Ft + c.Fa * c.Fa + 1e-18) / (c.mu * c.N_creep), 1 - 1e-9)
    return atanh_ratio(u), u


EFFECTS = {e.name: e for e in [
    Effect("drive_longitudinal_creep",
           "Longitudinal microslip at drive and follower rollers, slip ratio ψ = ε_D·F (Kim eqs 25-30).",
           {"scale": Param(1.0, "dimensionless", "multiplier on ε_D (the variant's contact.creep_drive, "
                                                   "else Hertz + Kalker C11)", 0.0, 50.0, positive=True)},
           {"compliance": _drive_longitudinal, "calibration": lambda c, p: p["scale"] if c.drive else 1.0},
           SelfCheck("scale", (1.0, 0.5)),                  # Kim's ε_D and half of it
           at_zero_load=False, independent="scale", calibrates="drive"),
    Effect("steering_lateral_creep",
           "Lateral microslip at steering rollers, slip angle α⊥ = ε_S·F⊥ (Kim eqs 19-24).",
           {"scale": Param(1.0, "dimensionless", "multiplier on ε_S (the variant's contact.creep_steering, "
                                                   "else Hertz + Kalker C22)", 0.0, 50.0, positive=True)},
           {"compliance": _steering_lateral, "calibration": lambda c, p: 1.0 if c.drive else p["scale"]},
           SelfCheck("scale", (1.0, 0.5), told_from=("rolling_resistance",)),   # Kim's ε_S and half of it
           at_zero_load=False, independent="scale", calibrates="steering"),
    Effect("drive_spin_creep",
           "Longitudinal creep at drive and follower rollers proportional to the contact's spin, Gillespie's "
           "line-contact creep/spin model (Brokowski eqs 14-19): slip velocity = (b/(μN))·|Ω·n|·F.",
           {"scale": Param(1.0, "dimensionless", "multiplier on b/(μN) with b the lateral Hertz half-width "
                                                   "(not Gillespie's measured width)", 0.0, 200.0, positive=True)},
           {"compliance": _drive_spin},
           SelfCheck("scale", (4.0, 9.0)),                  # Brokowski's fitted k / nominal: 4.0 and 9.0
           at_zero_load=False, independent="half_width"),
    Effect("normal_force_variation",
           "Creep compliances, spin creep, rolling resistance and saturation follow the normal forces of the "
           "sphere's force balance on its compliant mounts (Hertz patch: ε ∝ N^(-2/3)) instead of the preload.",
           {"exponent": Param(2.0 / 3.0, "dimensionless", "ε ∝ N^(-exponent); Hertz + Kalker gives 2/3", 0.0, 3.0)},
           {"creep_normal": _normal_force_variation},
           # second order in the existing CVT (its steering pair's normal forces move in opposite directions, so
           # their compliances compensate to first order): at the Hertz exponent 2/3 it changes α by 0.013° RMS,
           # below the rig noise, so the visible cases use amplified exponents and 2/3 is a weak case
           SelfCheck("exponent", (2.0, 3.0), weak=2.0 / 3.0),
           at_zero_load=False, independent="exponent"),
    Effect("rolling_resistance",
           "Hysteresis: each contact's pressure centre sits `offset` ahead of the contact point, a resisting "
           "moment offset·N on sphere and roller (Brokowski sec. 4.4.2).",
           {"offset": Param(1e-4, "length", "pressure-centre offset [m]", 0.0, 5e-3, positive=True)},
           {"resistance": _rolling_resistance},
           SelfCheck("offset", (1e-4, 3e-4)),               # 0.1 and 0.3 mm pressure-centre offset
           at_zero_load=True, independent="c_rr"),          # the contacts are loaded whatever τ⊥ is
    Effect("steering_offset",
           "The steering linkage's actual angle is the commanded one plus a constant (calibration, backlash).",
           {"offset": Param(0.00873, "angle", "steering angle offset [rad]", -0.2, 0.2)},
           {"steering_angle": lambda phi, p: phi + p["offset"]},
           SelfCheck("offset", (math.radians(0.5), math.radians(-1.0)),
                     told_from=("drive_radius_mismatch", "drive_spin_creep")),
           at_zero_load=True, independent="offset"),        # kinematic
    Effect("drive_radius_mismatch",
           "Shaft 2's rollers roll on an effective radius (1 + delta)·r instead of r (wear, durometer, crown); "
           "only the ratio of the two shafts' radii is observable, so shaft 1 stays nominal.",
           {"delta": Param(0.01, "dimensionless", "relative radius error of shaft 2's rollers", -0.2, 0.2)},
           {"rolling_radius": lambda roller, r, p: r * (1 + p["delta"])
            if roller.role != "steering" and roller.shaft == 2 else r},
           SelfCheck("delta", (0.01, -0.02), weak=0.0005),
           at_zero_load=True, independent="delta"),         # kinematic
    Effect("traction_saturation",
           "Creep force levels off towards μN: creepage = ε·F·atanh(u)/u with u = |F|/(μN) (inverse of "
           "F = μN·tanh(creepage/(ε μN))).",
           {"mu_scale": Param(1.0, "dimensionless", "multiplier on the materials' friction coefficient", 0.05, 5.0)},
           {"friction": lambda mu, p: mu * p["mu_scale"], "saturation": _traction_saturation},
           # μ scaled per variant so that the base model's largest traction utilisation reaches set levels
           SelfCheck("mu_scale", None, told_from=("rolling_resistance",)),
           at_zero_load=False, independent="mu_scale"),
]}
# Kim's model: the effects whose scales are the two creep calibrations (his fitted ε_D and ε_S); the default
# effects of a variant, the base of the diagnosis and of its self-check
KIM_MODEL = tuple(e.name for e in EFFECTS.values() if e.calibrates)
CALIBRATION = {e.calibrates: e.name for e in EFFECTS.values() if e.calibrates}   # side → its effect


def check_names(names, where: str) -> tuple:
    """The names, checked against the vocabulary: an unknown one is an InputError naming `where`, with the
    near name (or the list of names when none is near). core.contact.laws.check_effects adds the law's check."""
    for e in names:
        if e not in EFFECTS:
            hint = suggest(e, EFFECTS) or f" (effects: {', '.join(EFFECTS)})"
            raise InputError(f"{where}: unknown effect '{e}'{hint}")
    return tuple(names)


def friction_factor(effects, parameters: dict) -> object:
    """The factor the `friction` hooks of the effects that are on put on a friction coefficient [-], at their
    parameters (`parameters`: effect → {param: value}; a parameter not given is at its default)."""
    mu = 1.0
    for e in effects:
        hook = EFFECTS[e].hooks.get("friction")
        if hook is not None:
            mu = hook(mu, {k: parameters.get(e, {}).get(k, spec.default) for k, spec in EFFECTS[e].params.items()})
    return mu


def parameter_vector(effects, overrides: dict | None = None, switched: bool = False):
    """Ordered (names, values) of the parameters of the effects that are on; overrides: {effect: {param: v}}.
    `switched`: then each effect's switch, 'effect:on' (SWITCH), at 1: a model compiled with them holds every
    subset of the effects, with each subset's own numbers (core.equations.Hooks)."""
    names, values = [], []
    for e in effects:
        for p, spec in EFFECTS[e].params.items():
            names.append(f"{e}.{p}")
            values.append(float((overrides or {}).get(e, {}).get(p, spec.default)))
    if switched:
        names, values = names + [f"{e}{SWITCH}" for e in effects], values + [1.0] * len(effects)
    return names, values
