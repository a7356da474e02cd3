"""core/life/run.py: the chain from the model's contacts to temperatures, wear and life, and its feedback."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from conftest import ROOT, shipped_model

from cvtdesign.core.life import wear
from cvtdesign.core.life.run import DutyOutsideModel, life_interval, machine_life
from cvtdesign.io.ageing import roller_ageing
from cvtdesign.io.duty_file import load_duty
from cvtdesign.io.variant import load_spec

DUTY = load_duty(ROOT / "studies" / "cobot_duty.yaml")


def _ageing(name, model, **changes):
    f = str(ROOT / "variants" / f"{name}.yaml")
    ages = roller_ageing(f, load_spec(f), model.roller_names)
    out = []
    for n in model.roller_names:
        pair = ages[n]
        for key, factor in changes.items():
            pair = tuple(a.scaled(key, factor) if key in a.values and a.material.startswith("urethane") else a
                         for a in pair)
        out.append(pair)
    return out


def test_wear_rate_is_archards_with_the_models_contact():
    """Each contact's mean wear rate is k·P_f/(4π r b) at the model's friction loss and patch, averaged over
    the duty's shares."""
    model = shipped_model("existing_kim")
    ages = _ageing("existing_kim", model)
    life = machine_life(model, DUTY, ages)
    res = model.evaluate(DUTY.gamma, DUTY.load, speeds=DUTY.speed)
    for i, (r, c) in enumerate(zip(model.layout.rollers, life.contacts)):
        rate = wear.wear_rate(ages[i][0]["wear_coefficient"], c.friction, r.radius, res["b"][i])
        assert c.wear_rate == pytest.approx(float(np.sum(DUTY.shares * rate)), rel=1e-3)   # b at the warm state
        assert c.lives["wear"] == pytest.approx(0.01 * r.radius / c.wear_rate, rel=1e-12)
    assert life.life == min(c.life for c in life.contacts) and life.limit == "wear"


def test_softer_when_hot_loses_more():
    """A urethane that softens more with temperature creeps more: its losses and temperatures rise, and the
    feedback takes more than one evaluation to settle."""
    model = shipped_model("existing_kim")
    base = machine_life(model, DUTY, _ageing("existing_kim", model))
    soft = machine_life(model, DUTY, _ageing("existing_kim", model, modulus_factor=0.2))
    assert soft.iterations > 1
    assert all(s.T_mean > b.T_mean for s, b in zip(soft.contacts, base.contacts))
    assert sum(DUTY.shares @ s.loss for s in soft.contacts) > sum(DUTY.shares @ b.loss for b in base.contacts)


def test_runaway_is_a_limit():
    """Rollers that barely shed heat (conductivity 1e-4 of urethane's, so no conduction to the hub) and lose
    half their modulus every few kelvin: the temperatures find no consistent state, or slip when hot, and the
    limit is `runaway`, with life 0."""
    model = shipped_model("existing_kim")
    hot = machine_life(model, DUTY, _ageing("existing_kim", model, loss_fraction=4.0, conductivity=1e-4,
                                            hot_temperature=0.82))
    assert hot.limit == "runaway" and hot.life == 0.0 and hot.contact in model.roller_names
    assert [c for c in hot.contacts if c.limit == "runaway"][0].why


def test_duty_beyond_the_model_is_refused():
    model = shipped_model("existing_kim")
    far = dataclasses.replace(DUTY, load=np.full_like(DUTY.load, 5.0))
    with pytest.raises(DutyOutsideModel, match="duty point 1"):
        machine_life(model, far, _ageing("existing_kim", model))


def test_interval_holds_the_life():
    model = shipped_model("existing_kim")
    ages = _ageing("existing_kim", model)
    life = machine_life(model, DUTY, ages)
    intervals = life_interval(model, DUTY, ages, life)
    lo, hi = intervals["machine"]
    assert lo < life.life < hi and math.isfinite(hi)
    assert all(intervals[c.name][0] < c.life < intervals[c.name][1] for c in life.contacts)
    # wear limits it: ln life moves with the wear coefficient's σ (60 %) at least
    assert math.log(hi / life.life) >= 1.96 * math.log(1.6) * 0.99


@pytest.mark.parametrize("name", ["existing_kim", "box_kim"])
def test_rolling_speeds_are_the_axles_at_each_point(name):
    """R |Ω·a| with each roller's axle at the point's steering angle, mapped, as core.geometry.pose gives it
    point by point."""
    from cvtdesign.core.geometry import pose
    from cvtdesign.core.life.run import rolling_speeds
    model = shipped_model(name)
    res = model.evaluate(DUTY.gamma, DUTY.load, speeds=DUTY.speed)
    om = np.stack([res["Omega_x"], res["Omega_y"], res["Omega_z"]])
    ref = [[model.layout.sphere_radius * abs(np.dot(om[:, k], pose(r, res["phi"][k])[1]))
            for k in range(DUTY.gamma.size)] for r in model.layout.rollers]
    np.testing.assert_allclose(rolling_speeds(model, res), ref, rtol=1e-12, atol=1e-15)


def _uncertain(name):
    from cvtdesign.core.inputs import uncertain_model
    from cvtdesign.io.variant import load_variant
    model = uncertain_model(load_variant(ROOT / "variants" / f"{name}.yaml"))
    return model, _ageing(name, model)


@pytest.mark.slow
def test_interval_carries_the_models_own_inputs():
    """The life's interval moves the creep calibration's σ (and on an uncertain model the preloads, moduli,
    friction and spin moment: core.inputs) as well as the materials' ageing constants: each a +1σ move whose
    change in log life enters the quadrature sum."""
    from cvtdesign.core.life.run import moved_life, moves
    model, ages = _uncertain("box_kim")
    todo = dict(moves(model, ages))
    assert any(k.startswith("calibration:") for k in todo)
    assert {"preload of box_kim", "modulus urethane_82A", "friction urethane_82A on bowling_ball"} <= set(todo)
    life = machine_life(model, DUTY, ages)
    var = sum(math.log(moved_life(model, DUTY, ages, m).life / life.life) ** 2 for m in todo.values())
    lo, hi = life_interval(model, DUTY, ages, life)["machine"]
    assert math.log(hi / life.life) == pytest.approx(1.96 * math.sqrt(var), rel=1e-12)
    cal = [m for k, m in todo.items() if k.startswith("calibration:")]
    assert all(moved_life(model, DUTY, ages, m).life != life.life for m in cal)   # the calibration moves it


@pytest.mark.slow
def test_interval_against_sampling():
    """The first-order interval against 300 samples of every input of the chain at once: the ageing
    constants log-normal (ln σ = ln(1 + σ_rel), as the interval's +1σ moves take them), the model's own
    inputs as core.uncertainty.draw draws them. The sampled standard deviation of ln life agrees with the
    first-order one within 3 standard errors of a 300-sample standard deviation (1/√(2·300) = 4.1 % each;
    on box_kim: 0.499 sampled, 0.520 first order, 4 % apart)."""
    from cvtdesign.core.inputs import model_inputs
    from cvtdesign.core.uncertainty import draw
    model, ages = _uncertain("box_kim")
    life = machine_life(model, DUTY, ages)
    lo, hi = life_interval(model, DUTY, ages, life)["machine"]
    sigma = math.log(hi / life.life) / 1.96
    n, rng = 300, np.random.default_rng(7)
    inputs = model_inputs(model)
    x = draw(inputs, n, seed=7)
    consts = sorted({(a.material, k, a.std[k]) for pair in ages for a in pair for k in a.values if a.std.get(k)})
    logs = []
    for s in range(n):
        factors = {(m, k): math.exp(rng.normal(0, math.log(1 + sd))) for m, k, sd in consts}
        moved = [tuple(_scaled(a, factors) for a in pair) for pair in ages]
        th = np.array(model.param_values, float)
        for j, i in enumerate(inputs):
            if i.in_theta:
                th[model.param_names.index(i.target)] += x[s, j]
        design = x[s, [j for j, i in enumerate(inputs) if not i.in_theta]]
        logs.append(math.log(machine_life(model, DUTY, moved, th, design).life / life.life))
    assert np.std(logs, ddof=1) == pytest.approx(sigma, rel=3 / math.sqrt(2 * n))


def _scaled(a, factors):
    for (m, k), f in factors.items():
        if a.material == m:
            a = a.scaled(k, f)
    return a


def test_fatigue_life_takes_each_contacts_patch_and_track():
    """Steel on steel: each contact's fatigue life is Miner's sum over the duty of Lundberg–Palmgren's L10 at
    the model's peak pressure, patch (a along rolling, b across) and the roller's track 2πr, against the
    steel's test contact (core.life.fatigue), with its rolling speed's stress cycles."""
    from cvtdesign.core.life import fatigue
    from cvtdesign.core.life.run import fatigue_reference, rolling_speeds, warm_theta
    from cvtdesign.io.ageing import material_ageing
    model = shipped_model("existing_kim")
    f = ROOT / "variants" / "existing_kim.yaml"
    steel = material_ageing(str(f), load_spec(f), "steel")
    ages = [(steel, steel)] * len(model.roller_names)
    life = machine_life(model, DUTY, ages)
    res = model.evaluate(DUTY.gamma, DUTY.load, speeds=DUTY.speed, theta=warm_theta(model, DUTY, ages)[0])
    V = rolling_speeds(model, res)
    ref = fatigue_reference(steel)
    assert ref is not None
    for i, (r, c) in enumerate(zip(model.layout.rollers, life.contacts)):
        l10 = fatigue.l10_seconds(res["p_max"][i], V[i], r.radius, steel["fatigue_pressure"], steel["fatigue_cycles"],
                                  steel["fatigue_exponent"], (res["a"][i], res["b"][i], 2 * math.pi * r.radius), ref)
        assert c.lives["fatigue"] == pytest.approx(fatigue.miner_life(l10, DUTY.shares), rel=1e-9)
        short = fatigue.miner_life(fatigue.l10_seconds(res["p_max"][i], V[i], r.radius, steel["fatigue_pressure"],
                                                       steel["fatigue_cycles"], steel["fatigue_exponent"]), DUTY.shares)
        assert c.lives["fatigue"] != pytest.approx(short, rel=0.05)     # the stressed volume matters here
