"""Heat, wear and life (core/life) against hand calculations, each with its source written here, and the
energy balance of `cvtdesign life` at every duty point."""
from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from conftest import ROOT, shipped_model

from cvtdesign.core.life import fatigue, hysteresis, thermal, wear
from cvtdesign.core.life.run import machine_life, worn_ratio_error
from cvtdesign.io.ageing import roller_ageing
from cvtdesign.io.duty_file import load_duty
from cvtdesign.io.variant import load_spec

DUTY = ROOT / "studies" / "cobot_duty.yaml"


def test_rolling_resistance_is_johnsons():
    """Johnson, Contact Mechanics (1985), sec. 9.2: a sphere rolling on a viscoelastic body meets
    F_R = α·3Wa/(16R). By hand: α = 0.2, W = 100 N, a = 3 mm, R = 24.5 mm:
    F_R = 0.2 × 3 × 100 × 0.003 / (16 × 0.0245) = 0.18 / 0.392 = 0.459184 N."""
    assert hysteresis.rolling_resistance(0.2, 100.0, 0.003, 0.0245) == pytest.approx(0.459184, rel=1e-5)


@pytest.mark.parametrize("b_over_a", [1.0, 0.4, 2.5])
def test_leading_half_work_of_an_ellipse(b_over_a):
    """The work on the leading half per unit distance rolled is ∫_{x>0} p x dA / R, with Hertz's
    p = 3W/(2πab) √(1 − x²/a² − y²/b²): for the circle (Johnson's case) 3Wa/16, and for any ellipse the same
    (module docstring of core.life.hysteresis). Summed numerically on a fine grid, within 1 %."""
    W, a = 100.0, 0.003
    b = b_over_a * a
    n = 1201
    x = (np.arange(n) + 0.5) / n * a
    y = np.linspace(-b, b, 2 * n + 1)
    X, Y = np.meshgrid(x, y, indexing="ij")
    p = 3 * W / (2 * math.pi * a * b) * np.sqrt(np.clip(1 - X ** 2 / a ** 2 - Y ** 2 / b ** 2, 0, None))
    moment = np.sum(p * X) * (a / n) * (y[1] - y[0])
    assert moment == pytest.approx(3 * W * a / 16, rel=0.01)


def test_steady_lumped_temperature():
    """A 40 mm roller, tread 24 mm wide, hub at 0.6 r, urethane k = 0.21 W/(m K), turning at 20 rad/s in
    still air, taking 0.5 W. By hand (Incropera and DeWitt, rotating cylinder: Nu = 0.133 Re^(2/3) Pr^(1/3)):
    Re = 20 × 0.08² / 1.6e-5 = 8000; Nu = 0.133 × 400 × 0.71^(1/3) = 0.133 × 400 × 0.892112 = 47.4604;
    h = 47.4604 × 0.026 / 0.08 = 15.4246 W/(m² K); A = 2π 0.04 × 0.024 + 2π 0.04² (1 − 0.36) = 0.00603186 +
    0.00643398 = 0.0124658 m²; hA = 0.192282 W/K; G_hub = 2π 0.21 × 0.024 / ln(1/0.6) = 0.0316673 / 0.510826
    = 0.0619923 W/K; G = 0.254274 W/K; T − T_amb = 0.5 / 0.254274 = 1.96638 K."""
    r, w, hub, k = 0.04, 0.024, 0.6, 0.21
    h = thermal.convection_coefficient(20.0, r)
    G = h * thermal.surface_area(r, w, hub) + thermal.hub_conductance(k, w, hub)
    rise = thermal.steady_temperature(0.5, G, 298.15) - 298.15
    assert rise == pytest.approx(1.96638, rel=0.01)
    assert rise == pytest.approx(1.96638, rel=1e-4)
    C = thermal.heat_capacity(1100.0, 1800.0, r, w, hub)       # a steady cycle's mean is the steady temperature
    _, _, mean = thermal.cycle_temperatures([0.5, 0.5], [G, G], [3.0, 9.0], C, 298.15)
    assert mean - 298.15 == pytest.approx(rise, rel=1e-9)


def test_cycle_is_the_exact_exponential():
    """Two steps of a square wave (Q 1 W for τ, 0 for τ; G = 0.25 W/K, C = 200 J/K, so τ_th = 800 s): in the
    periodic state T_start of the heating step is ΔT_ss·e/(1 + e) with e = exp(−τ/τ_th), by hand for τ =
    800 s: ΔT_ss = 4 K, e = 0.367879, θ0 = 4 × 0.367879 / 1.367879 = 1.075766 K."""
    starts, _, _ = thermal.cycle_temperatures([1.0, 0.0], [0.25, 0.25], [800.0, 800.0], 200.0, 0.0)
    assert starts[0] == pytest.approx(1.075766, rel=1e-6)
    assert starts[1] == pytest.approx(4 - (4 - 1.075766) * 0.367879, rel=1e-6)


def test_flash_temperature_limits():
    """Jaeger's uniform circular source: at rest its centre rises q a / k (Tian and Kennedy's fit at Pe = 0:
    2qa/(k√(4.0)) = 1.0025 qa/k); for a short time t it rises 2q√(κt/π)/k (a flux on a half-space)."""
    Q, a, k, rho, c = 1.0, 0.002, 0.21, 1100.0, 1800.0
    q = Q / (math.pi * a * a)
    assert thermal.flash_temperature(Q, a, a, 0.0, k, rho, c) == pytest.approx(q * a / k, rel=0.01)
    t, kappa = 0.01, k / (rho * c)
    assert thermal.flash_temperature(Q, a, a, 0.0, k, rho, c, t) == pytest.approx(
        2 * q * math.sqrt(kappa * t / math.pi) / k, rel=1e-12)


def test_wear_depth_for_known_work():
    """Archard's law, energy form: 1 W of friction for an hour (3600 J), k = 5e-14 m³/J, over a 40 mm
    roller's track of half-width 2 mm: V = 1.8e-10 m³ spread over 2π × 0.04 × 0.004 = 1.005310e-3 m²:
    h = 1.8e-10 / (2π × 0.04 × 0.004) m, exactly."""
    assert wear.wear_depth(5e-14, 3600.0, 0.04, 0.002) == 5e-14 * 3600.0 / (4 * math.pi * 0.04 * 0.002)
    assert wear.wear_depth(5e-14, 3600.0, 0.04, 0.002) == pytest.approx(1.790493e-7, rel=1e-6)
    assert wear.wear_rate(5e-14, 1.0, 0.04, 0.002) * 3600.0 == pytest.approx(wear.wear_depth(5e-14, 3600.0, 0.04, 0.002),
                                                                     rel=1e-15)


@pytest.mark.parametrize("name", ["existing_kim", "box_kim"])
def test_ratio_error_of_worn_radii(name):
    """The worn radii fed back into the model (core.life.run.worn_ratio_error): shaft 1's rollers 0.4 mm
    smaller, the others unworn. A roller rolls at r ω = V, so by hand ω2/ω1 = (V2/V1)(r1/r2) falls by
    0.4/40 = 1 %: an error of +0.01 exactly without load (no creep); under the duty's loads the worn rollers'
    creep changes too, which the model adds (here 7–18 % more)."""
    model = shipped_model(name)
    hours = 1000.0
    contacts = [SimpleNamespace(wear_rate=0.0004 / (hours * 3600) if r.role != "steering" and r.shaft == 1 else 0.0)
                for r in model.layout.rollers]
    worn = SimpleNamespace(life=hours * 3600, contacts=contacts)
    duty = load_duty(DUTY)
    err, k = worn_ratio_error(model, dataclasses.replace(duty, load=0 * duty.load), worn)
    assert k is not None and err == pytest.approx(0.0004 / 0.040, rel=1e-6)
    err, k = worn_ratio_error(model, duty, worn)
    assert k is not None and 0.01 < err < 0.0125


def test_l10_of_a_steel_contact():
    """Lundberg–Palmgren at the reference's size and shape (no patch given): L10 ∝ p_max^−9. By hand, from
    1e7 cycles at 5.52 GPa to 1.5 GPa: (5.52/1.5)^9 = 3.68^9 = 123 774.3; L10 = 1.237743e12 cycles. A 20 mm
    roller rolling at 2 m/s is stressed 2/(2π 0.02) = 15.9155 times a second: 7.776967e10 s."""
    assert fatigue.l10_cycles(1.5e9, 5.52e9, 1e7, 9) == pytest.approx(1.237743e12, rel=1e-6)
    assert fatigue.l10_seconds(1.5e9, 2.0, 0.02, 5.52e9, 1e7, 9) == pytest.approx(7.776967e10, rel=1e-6)


def test_shear_stress_of_lundberg_palmgren():
    """The largest orthogonal shear stress and its depth (Lundberg and Palmgren; Johnson, Contact Mechanics,
    sec. 4.2 and 2.7): a circle, t = 1.280776 from (t² − 1)(2t − 1) = 1: τ0 = √1.561553/(2·1.280776·2.280776)
    p0 = 1.249621/5.842329 p0 = 0.213891 p0 at z0 = 1/(2.280776·1.249621) = 0.350864 b; a line contact
    (b/a → 0, t → 1): 0.25 p0 at 0.5 b."""
    T, Z = fatigue.shear_factors(1.0, 1.0)
    assert (T, Z) == (pytest.approx(0.213891, rel=1e-5), pytest.approx(0.350864, rel=1e-5))
    T, Z = fatigue.shear_factors(1e-4, 1.0)
    assert (T, Z) == (pytest.approx(0.25, rel=1e-3), pytest.approx(0.5, rel=1e-3))


def _race_contact(D, f, gamma, Q, steel):
    """A ball on a deep-groove ball bearing's inner raceway, contact angle 0 (Harris, Rolling Bearing
    Analysis: ball diameter D, groove radius f D, γ = D/d_m): curvature sums along rolling 1/(D(1 − γ)) and
    across (2f − 1)/(2fD); track π D (1 − γ)/γ; a point of the rotating inner ring is passed by
    Z(1 + γ)/2 balls a turn. Returns (p_max, patch = (along rolling, across, track))."""
    from cvtdesign.core.contact.hertz import contact_material, hertz_ellipse
    E, _, _ = contact_material(steel.E, steel.nu, steel.E, steel.nu)
    a, b, p0, _ = (float(v) for v in hertz_ellipse(1 / (D * (1 - gamma)), (2 * f - 1) / (2 * f * D), Q, E))
    return p0, (a, b, math.pi * D * (1 - gamma) / gamma)


def _published_capacity(D, f, gamma, Z):
    """Lundberg and Palmgren's basic dynamic capacity of a rotating inner raceway contact [N] (D in m;
    their formula in N and mm, as Harris, Rolling Bearing Analysis, writes it): 90 % of such contacts
    survive 10^6 turns at Q_c = 98.1 (2f/(2f − 1))^0.41 (1 − γ)^1.39/(1 + γ)^(1/3) γ^0.3 D^1.8 Z^(−1/3)."""
    return 98.1 * (2 * f / (2 * f - 1)) ** 0.41 * (1 - gamma) ** 1.39 / (1 + gamma) ** (1 / 3) * gamma ** 0.3 \
        * (1e3 * D) ** 1.8 * Z ** (-1 / 3)


@pytest.mark.parametrize("D", [6.35e-3, 12.7e-3, 25.4e-3])
@pytest.mark.parametrize("f", [0.515, 0.52, 0.525])
@pytest.mark.parametrize("gamma", [0.1, 0.2, 0.3, 0.4])
def test_l10_against_lundberg_palmgrens_raceway_capacity(D, f, gamma):
    """L10 of a published rolling-element contact, within 5 %: Lundberg and Palmgren's capacity of a ball on
    a rotating inner raceway gives its L10 for every load, ball and osculation, L10 = (Q_c/Q)^3 10^6 inner-ring
    turns (_published_capacity). The shipped steel's fatigue constants are that formula at one contact (a
    12.7 mm ball, f 0.52, γ 0.2, 9 balls: Q_c = 98.1 × 26^0.41 × 0.8^1.39/1.2^(1/3) × 0.2^0.3 × 12.7^1.8 ×
    9^(−1/3) = 7409 N, so 5.4e6 stress cycles at its p_max, patch and track: materials.yaml), so that contact
    is exact by construction; every other ball size, osculation and γ, at half its own capacity, checks the
    stressed volume, the shear stress's shape factors and the exponents. Lundberg and Palmgren fitted their
    formula's osculation and γ factors as powers, good to a few % over the osculations of ball bearings' inner
    races (at f 0.53 the fit is 6 % off in life, at f 0.55 13 %: the power 0.41 is a fit)."""
    from cvtdesign.io.ageing import material_ageing
    Z, box = 9, ROOT / "variants" / "box.yaml"
    m = material_ageing(str(box), load_spec(box), "steel")
    Qc = _published_capacity(D, f, gamma, Z)
    p, patch = _race_contact(D, f, gamma, Qc / 2, SimpleNamespace(E=200e9, nu=0.29))   # the library's steel
    ref = (m["fatigue_rolling"], m["fatigue_across"], m["fatigue_track"])
    cycles = fatigue.l10_cycles(p, m["fatigue_pressure"], m["fatigue_cycles"], m["fatigue_exponent"], patch, ref)
    turns = float(cycles) / (Z * (1 + gamma) / 2)
    assert turns == pytest.approx(2 ** 3 * 1e6, rel=0.05)


def test_miner_published_example():
    """Modarres, Amiri and Jackson, "Probabilistic physics of failure approach to reliability" (2017), pp.
    33-37, as the `reliability` package's palmgren_miner_linear_damage documents it: parts that fail after
    50 000, 6 500 and 1 000 h at three loads, used 40, 15 and 5 min an hour, last 7400.38 one-hour cycles."""
    life = fatigue.miner_life([50000.0, 6500.0, 1000.0], np.array([40.0, 15.0, 5.0]) / 60.0)
    assert life == pytest.approx(7400.38, abs=0.01)


@pytest.mark.parametrize("name", ["box_kim", "existing_kim", pytest.param("box", marks=pytest.mark.slow),
                                  "existing"])
def test_energy_balance_at_every_duty_point(name):
    """What is checked, at every duty point (docs/life.md): (1) independently, the model's creep and spin
    losses against its shafts: Σ = τ1 ω1 + τ2 ω2; (2) the bookkeeping of the hysteresis the motor supplies
    (added after the solve, first order): P_in is the driving shaft's power plus Σ F_R·V, so Σ contact losses
    (creep, spin and hysteresis) = P_in − P_out, with every contact's hysteresis loss positive. The hysteresis
    each contact loses is Johnson's with the model's normal force, patch and rolling speed at the consistent
    temperature."""
    model = shipped_model(name)
    f = str(ROOT / "variants" / f"{name}.yaml")
    ages = roller_ageing(f, load_spec(f), model.roller_names)
    duty = load_duty(DUTY)
    life = machine_life(model, duty, [ages[n] for n in model.roller_names])
    loss = sum(c.loss for c in life.contacts)
    assert np.all(np.isfinite(loss)) and np.all(loss > 0)
    np.testing.assert_allclose(loss, life.power_in - life.power_out, rtol=1e-9)
    friction = sum(c.friction for c in life.contacts)
    assert np.all(np.isfinite(friction)) and np.max(friction) > 0.05
    hyst = sum(c.hysteresis for c in life.contacts)
    np.testing.assert_allclose(loss - hyst, friction, rtol=1e-12)
    res = model.evaluate(duty.gamma, duty.load, speeds=duty.speed, theta=_warm(model, duty, ages))
    np.testing.assert_allclose(friction, res["tau_1"] * res["omega_1"] + res["tau_2"] * res["omega_2"], rtol=1e-9)
    assert all(np.all(c.hysteresis > 0) for c in life.contacts)
    assert life.limit in ("temperature", "wear", "fatigue", "runaway") and life.contact in model.roller_names


def _warm(model, duty, ages):
    from cvtdesign.core.life.run import warm_theta
    return warm_theta(model, duty, [ages[n] for n in model.roller_names])[0]
