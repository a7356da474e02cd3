"""The life rows of a study's NLP (`constraints.min_life_h`, docs/life.md): every roller's wear life over the
study's duty cycle at least the minimum.

`max_life`, an objective: the smallest wear life over the rollers, made largest (worst_inverse_life).

A roller's running track wears at k·P_f/(4π r b) (core.life.wear: Archard's law in its energy form, P_f the
power its creep and spin dissipate, b the patch's half-width), so its wear life over a duty cycle of
shares s_k is limit / Σ_k s_k k P_f,k/(4π r b_k). The row is L_min · Σ_k s_k k P_f,k/(4π r b_k) / limit ≤ 1
per roller, with the model's own losses and patch at the duty points, as functions of the design, at the
temperatures `cvtdesign life` finds for the study's base design (core.life.run.warm_theta: each side's creep
scale softened by its hottest roller's E^(−1/3)), held over the design space: the temperatures of the
optimum differ from the base's by what its losses differ (a kelvin or so on the shipped cobot duty). The
other limits (temperature, fatigue) are left to `cvtdesign life` on the optimum, which gives its full life.
Wear limits every shipped variant on the shipped cobot duty, with the rollers within a few kelvin of the air.
"""
from __future__ import annotations

import math
from pathlib import Path

import casadi as ca
import numpy as np

from cvtdesign.core.geometry import steering_angle_guess, steering_data
from cvtdesign.core.life.duty import WEAR_LIMIT_RATIO
from cvtdesign.core.life.run import warm_theta
from cvtdesign.core.model import compile_model
from cvtdesign.errors import InputError
from cvtdesign.io.ageing import roller_ageing
from cvtdesign.io.duty_file import duty_from_data, load_duty
from cvtdesign.io.units import to_si


def life_duty(spec, where: str):
    """The duty cycle of a study's constraints.life_duty: a duty file relative to the study, or the duty as
    data (how it travels to a study's workers: design.cases.study_content)."""
    duty = spec.constraints.life_duty
    if duty is None:
        raise InputError(f"{where}: constraints.life_duty: missing; expected the duty-cycle file that "
                         f"min_life_h holds over (e.g. ../studies/cobot_duty.yaml)")
    if isinstance(duty, dict):
        return duty_from_data(duty, f"{where}: constraints.life_duty")
    return load_duty(Path(where).parent / duty)


def inverse_lives(nlp):
    """Each roller's inverse wear life [1/s] over the study's duty cycle, as a function of the design, at the
    base design's temperatures (module docstring): Σ_k s_k k P_f,k/(4π r b_k) / limit; with the duty's name."""
    duty = life_duty(nlp.spec, nlp.where)
    ages = roller_ageing(nlp.base.file, nlp.vspec, nlp.model.roller_names)
    k = np.array([ages[n][0].values.get("wear_coefficient", math.nan) for n in nlp.model.roller_names])
    if not np.all(np.isfinite(k)):
        n = nlp.model.roller_names[int(np.flatnonzero(~np.isfinite(k))[0])]
        raise InputError(f"{nlp.base.file}: materials.{ages[n][0].material}.ageing.wear_coefficient: missing; "
                         f"expected one for a life constraint or objective (docs/life.md)")
    base = compile_model(nlp.base, effects=nlp.model.effects)        # the life chain runs on numbers
    theta, _ = warm_theta(base, duty, [ages[n] for n in base.roller_names])
    phi, _ = steering_angle_guess(*steering_data(nlp.base), duty.gamma)
    loss, b = nlp.model.point_function(["loss", "b"]).map(duty.gamma.size, "serial")(
        duty.gamma, duty.speed[None, :], duty.load, 0.0, phi, theta, nlp.P)
    radii = ca.Function("radii", [nlp.p], [ca.vertcat(*[r.radius for r in nlp.layout.rollers])])(nlp.P)
    s = ca.DM(duty.shares)
    out = []
    for i in range(len(nlp.model.roller_names)):
        rate = ca.mtimes(ca.fmax(loss[i, :], 0) / b[i, :], s) * k[i] / (4 * math.pi * radii[i])
        out.append(rate / (duty.wear_limit if duty.wear_limit is not None else WEAR_LIMIT_RATIO * radii[i]))
    return ca.vertcat(*out), duty.name


def life_rows(nlp, rows) -> None:
    """Each roller's wear life ≥ constraints.min_life_h over the duty cycle (module docstring), added to
    `rows` as rows that every solve holds (few points, so not worth a working set), family 'life'."""
    min_life_s = to_si(nlp.spec.constraints.min_life_h, "time", f"{nlp.where}: constraints.min_life_h")
    inverse, name = inverse_lives(nlp)
    rows.add(min_life_s * inverse, -np.inf, 1.0, "life",
             [f"wear life of {n} ≥ {min_life_s / 3600:g} h (over {name}, at the base design's temperatures)"
              for n in nlp.model.roller_names])


LIFE_SCALE = 1e-5 / 3600    # [1/s] the inverse life the objective is measured in units of (100 000 h)
SOFT_MAX = 32               # the p of the p-norm that stands for the largest inverse life


def worst_inverse_life(nlp):
    """The max_life objective [1/h]: the rollers' largest inverse wear life, as the p-norm (p = SOFT_MAX) of
    their inverse lives, which is smooth and lies between the largest and n^(1/p) (< 1.07 for 8 rollers)
    times it; scaled by LIFE_SCALE so that its powers stay within floating point."""
    inverse, _ = inverse_lives(nlp)
    q = inverse / LIFE_SCALE
    return ca.sum1(q ** SOFT_MAX) ** (1.0 / SOFT_MAX) * LIFE_SCALE * 3600
