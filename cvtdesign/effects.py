"""The effect vocabulary of DESIGN.md sec. 3: names, parameters and defaults.

The model (model.py) is one set of equations; each effect switches a term of it on. This module holds
only the names and the parameters, so that the command line, files and the diagnosis share them. Where
each effect enters the equations is written in `model.py` next to the term (search for the name).
"""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Param:
    default: float
    kind: str          # a units.KINDS key
    doc: str
    lower: float = float("-inf")   # bounds for fitting
    upper: float = float("inf")


@dataclass(frozen=True)
class Effect:
    name: str
    doc: str
    params: dict = field(default_factory=dict)


EFFECTS = {e.name: e for e in [
    Effect("drive_longitudinal_creep",
           "Longitudinal microslip at drive and follower rollers, slip ratio ψ = ε_D·F (Kim eqs 25-30).",
           {"scale": Param(1.0, "dimensionless", "multiplier on ε_D (the variant's contact.creep_drive, "
                                                   "else Hertz + Kalker C11)", 0.0, 50.0)}),
    Effect("steering_lateral_creep",
           "Lateral microslip at steering rollers, slip angle α⊥ = ε_S·F⊥ (Kim eqs 19-24).",
           {"scale": Param(1.0, "dimensionless", "multiplier on ε_S (the variant's contact.creep_steering, "
                                                   "else Hertz + Kalker C22)", 0.0, 50.0)}),
    Effect("drive_spin_creep",
           "Longitudinal creep at drive and follower rollers proportional to the contact's spin, Gillespie's "
           "line-contact creep/spin model (Brokowski eqs 14-19): slip velocity = (a/(μN))·|Ω·n|·F.",
           {"scale": Param(1.0, "dimensionless", "multiplier on Gillespie's nominal a/(μN) "
                                                   "(a = lateral Hertz half-width)", 0.0, 200.0)}),
    Effect("normal_force_variation",
           "Creep compliances, spin creep, rolling resistance and saturation follow the normal forces of the "
           "sphere's force balance on its compliant mounts (Hertz patch: ε ∝ N^(-2/3)) instead of the preload.",
           {"exponent": Param(2.0 / 3.0, "dimensionless", "ε ∝ N^(-exponent); Hertz + Kalker gives 2/3", 0.0, 3.0)}),
    Effect("rolling_resistance",
           "Hysteresis: each contact's pressure centre sits `offset` ahead of the contact point, a resisting "
           "moment offset·N on sphere and roller (Brokowski sec. 4.4.2).",
           {"offset": Param(1e-4, "length", "pressure-centre offset [m]", 0.0, 5e-3)}),
    Effect("steering_offset",
           "The steering linkage's actual angle is the commanded one plus a constant (calibration, backlash).",
           {"offset": Param(0.00873, "angle", "steering angle offset [rad]", -0.2, 0.2)}),
    Effect("drive_radius_mismatch",
           "Shaft 2's rollers roll on an effective radius (1 + delta)·r instead of r (wear, durometer, crown); "
           "only the ratio of the two shafts' radii is observable, so shaft 1 stays nominal.",
           {"delta": Param(0.01, "dimensionless", "relative radius error of shaft 2's rollers", -0.2, 0.2)}),
    Effect("traction_saturation",
           "Creep force levels off towards μN: creepage = ε·F·atanh(u)/u with u = |F|/(μN) (inverse of "
           "F = μN·tanh(creepage/(ε μN))).",
           {"mu_scale": Param(1.0, "dimensionless", "multiplier on the materials' friction coefficient", 0.05, 5.0)}),
]}

VERDICTS_EXTRA = ("none", "unexplained")


def check_effects(names, where: str) -> tuple:
    """The names, checked against the vocabulary: an unknown one is an InputError naming `where`, with the
    near name (or the list of names when none is near)."""
    from .units import InputError, suggest

    for e in names:
        if e not in EFFECTS:
            hint = suggest(e, EFFECTS) or f" (effects: {', '.join(EFFECTS)})"
            raise InputError(f"{where}: unknown effect '{e}'{hint}")
    return tuple(names)


def parameter_vector(effects, overrides: dict | None = None):
    """Ordered (names, values) of the parameters of the effects that are on; overrides: {effect: {param: v}}."""
    names, values = [], []
    for e in effects:
        for p, spec in EFFECTS[e].params.items():
            names.append(f"{e}.{p}")
            values.append(float((overrides or {}).get(e, {}).get(p, spec.default)))
    return names, values
