"""Each effect of the vocabulary against its own closed form or invariant, on Kim's existing CVT.

The laws are the ones the effects state (cvtdesign/core/effects.py), written here from their definitions:
 * steering_offset: the linkage turns φ_cmd + offset, so at zero load the axis is Kim's eq 5 of that angle
   (Kim et al., "Causes of microslip in a continuously variable transmission");
 * drive_radius_mismatch: shaft 2's rollers roll on (1 + δ) r, so at zero load ω2/ω1 = tan γ/(1 + δ)
   (Kim eq 8 with the radius ratio);
 * traction_saturation: F = μN tanh(creepage/(ε μN)) at each creeping contact;
 * normal_force_variation: the creep compliance follows the force-balanced N as ε(N) = ε_ref (N_ref/N)^(2/3);
 * rolling_resistance: a moment offset·N resists rolling on sphere and roller (Brokowski et al., "Toward
   improved CVTs: theoretical and experimental results", sec. 4.4.2), so an idler carries
   |F_t| = offset·N/r and every contact dissipates offset·N·V·(1/R + 1/r);
 * no creep constants in the variant: ε from Hertz + Kalker, ε_S = 1/(G a b C22), here with a, b from
   Johnson's Hertz equations (scipy) and C22 from Kalker's table rows typed in test_contact_anchors.
Each tolerance is the measured accuracy times a stated margin; measured numbers are printed (pytest -s).
"""
from __future__ import annotations

import kim_closed_forms as kim  # tests/validation is on sys.path (tests/conftest.py)
import numpy as np
import pytest
from conftest import shipped_layout, shipped_model
from hertz_reference import hertz_axes
from test_contact_anchors import KALKER_ROWS

from cvtdesign.core.model import compile_model
from cvtdesign.io.variant import load_variant

GAMMAS = np.radians(np.arange(-80.0, 81.0, 10.0))
R_SPHERE, R_DRIVE, R_STEER = 0.0635, 0.040, 0.038        # existing_kim.yaml [m]
EPS_D, EPS_S, N_REF = 0.0038, 0.0049, 100.0              # Kim's ε_D, ε_S [1/N] at N_REF [N] (existing_kim.yaml)
STEERING, DRIVE = [2, 3], [0, 1]                         # contact indices of existing_kim.yaml: D1, D2, S1, S2
RADII = np.array([R_DRIVE, R_DRIVE, R_STEER, R_STEER])
PRELOAD = 100.0                                          # [N] every roller of existing_kim.yaml
# the model's documented compliance floor of every direction (EPS_RIGID = 1e-9 1/N times the reference speed
# V_ref = ω1 r_D1, here 10 rad/s × 40 mm): creepage/F = ε + FLOOR·V_REF/V, written here by hand
FLOOR, V_REF = 1e-9, 10.0 * R_DRIVE


def report(msg):
    print(f"[measured] {msg}")


def evaluate(effects, gammas, loads, **params):
    """The existing CVT with `effects`, parameters {"effect.param": value} overriding the defaults; every
    point must be physical (ok)."""
    m = shipped_model("existing_kim", tuple(effects))
    theta = np.array(m.param_values)
    for k, v in params.items():
        theta[m.param_names.index(k)] = v
    r = m.evaluate(gammas, loads, theta=theta)
    assert r["ok"].all(), r["status"]
    return r


def steering_axles(phi):
    """Kim's S1 and S2 axles at steering angle φ: cos φ c2 + sin φ c3 and cos φ c1 + sin φ c3."""
    c, s = np.cos(phi)[..., None], np.sin(phi)[..., None]
    return c * kim.C2 + s * kim.C3, c * kim.C1 + s * kim.C3


def rolling_speeds(r):
    """V_i = R|Ω·a_i| [m/s] of D1, D2, S1, S2 (Kim's axles), shape (4,) + the points' shape."""
    Om = np.stack([r["Omega_x"], r["Omega_y"], r["Omega_z"]], axis=-1)
    a1, a2 = steering_axles(r["phi"])
    return np.stack([R_SPHERE * np.abs(np.sum(Om * a, axis=-1)) for a in (-kim.D1, -kim.D2, a1, a2)])


def test_existing_layout_is_the_one_typed_here():
    lay = shipped_layout("existing_kim")
    assert [r.name for r in lay.rollers] == ["D1", "D2", "S1", "S2"]
    assert [float(r.radius) for r in lay.rollers] == pytest.approx([R_DRIVE, R_DRIVE, R_STEER, R_STEER])
    assert (lay.sphere_radius, lay.creep_drive, lay.creep_steering, lay.creep_reference_force) == pytest.approx(
        (R_SPHERE, EPS_D, EPS_S, N_REF))


@pytest.mark.parametrize("offset_deg", [0.5, -2.0])
def test_steering_offset_shifts_the_axis_by_the_linkage(offset_deg):
    """Zero load, only steering_offset: the axis is Kim's eq 5 of φ(γ_cmd) + offset, so
    α = α_steering = eq5(eq5⁻¹(γ) + offset) − γ (mod 180°), and no drive slip. Measured 1e-13 rad;
    tolerance 1e-10 rad (the steering solve's own 1e-14 tolerance, well above round-off)."""
    off = np.radians(offset_deg)
    r = evaluate(["steering_offset"], GAMMAS, 0.0, **{"steering_offset.offset": off})
    expected = kim.wrap_half_pi(kim.kim_gamma_from_phi(kim.kim_phi_from_gamma(GAMMAS) + off) - GAMMAS)
    err = max(np.max(np.abs(kim.wrap_half_pi(r["alpha"] - expected))),
              np.max(np.abs(kim.wrap_half_pi(r["alpha_steering"] - expected))))
    report(f"offset {offset_deg}°: |α − eq 5 shift| max {err:.2e} rad; α {np.degrees(expected.min()):.3f}.."
           f"{np.degrees(expected.max()):.3f}°")
    assert err < 1e-10
    assert np.max(np.abs(r["alpha_drive"])) < 1e-10
    # not a constant shift: Kim's linkage amplifies φ most at γ = ±45°·… (dγ/dφ varies along the envelope)
    assert np.ptp(expected) > 0.1 * abs(off)


@pytest.mark.parametrize("delta", [0.01, -0.03])
def test_drive_radius_mismatch_ratio_at_zero_load(delta):
    """Zero load, only drive_radius_mismatch: ω2/ω1 = tan γ/(1 + δ) (rolling without slip on (1 + δ) r2).
    Measured 2e-15 relative; tolerance 1e-12."""
    r = evaluate(["drive_radius_mismatch"], GAMMAS, 0.0, **{"drive_radius_mismatch.delta": delta})
    ratio = r["omega_2"] / r["omega_1"]
    expected = np.tan(GAMMAS) / (1 + delta)
    nz = np.abs(expected) > 0
    err = np.max(np.abs(ratio[nz] / expected[nz] - 1))
    report(f"delta {delta}: ω2/ω1 vs tan γ/(1+δ) max rel err {err:.2e}")
    assert err < 1e-12 and np.max(np.abs(ratio[~nz])) < 1e-12
    # the slip angle it shows: α = atan(tan γ/(1+δ)) − γ, the steering part 0 (the axis is the commanded one)
    np.testing.assert_allclose(r["alpha"], np.arctan(expected) - GAMMAS, atol=1e-12)
    np.testing.assert_allclose(r["alpha_steering"], 0.0, atol=1e-12)


def test_traction_saturation_follows_tanh():
    """Kim's two creeps with traction_saturation at μ × 0.3 (μP = 24 N), τ⊥ = ±1 N·m: at every creeping
    contact the force follows the law in the form the effect states, creepage = −ε F atanh(u)/u with u = |F|/(μP) (F, creepage along the creeping direction; P the preload, which the creep
    law follows without normal_force_variation), plus the model's rigid floor. Measured 2.4e-14 relative;
    tolerance 1e-11 (round-off of the Newton solve's 1e-12 residual, with margin). The linear law would miss by up to atanh(u)/u − 1 (> 10 % here)."""
    scale = 0.3
    mu = 0.8 * scale
    G, T = np.meshgrid(GAMMAS, [-0.6, 0.6], indexing="ij")
    r = evaluate(["drive_longitudinal_creep", "steering_lateral_creep", "traction_saturation"], G, T,
                 **{"traction_saturation.mu_scale": scale})
    u = np.hypot(r["F_t"], r["F_a"]) / (mu * PRELOAD)
    amp = np.arctanh(u) / u
    floor = FLOOR * V_REF / rolling_speeds(r)
    # drive rollers creep along t (ξ = s_t/V), steering rollers across, along a (η = s_a/V)
    creep = np.concatenate([r["xi"][DRIVE], r["eta"][STEERING]])
    force = np.concatenate([r["F_t"][DRIVE], r["F_a"][STEERING]])
    eps = np.concatenate([np.full((2,) + force.shape[1:], EPS_D), np.full((2,) + force.shape[1:], EPS_S)])
    law = -force * (eps * np.concatenate([amp[DRIVE], amp[STEERING]]) + np.concatenate([floor[DRIVE], floor[STEERING]]))
    big = np.abs(force) > 1.0
    err = np.max(np.abs(creep[big] / law[big] - 1))
    report(f"saturation: creepage vs ε F atanh(u)/u max rel err {err:.2e}; max u {u.max():.3f}, "
           f"max amplification {amp.max():.3f}")
    assert err < 1e-11
    assert amp.max() > 1.1                             # the nonlinearity is exercised
    # the same law, written forwards: F = −μP tanh(creepage/(ε μP)) along the creeping direction, where the
    # other component is negligible (|F_other| < 1e-3 |F|)
    other = np.concatenate([r["F_a"][DRIVE], r["F_t"][STEERING]])
    one_d = big & (np.abs(other) < 1e-3 * np.abs(force))
    forward = -mu * PRELOAD * np.tanh(creep / (eps * mu * PRELOAD))
    assert one_d.sum() > 20
    np.testing.assert_allclose(force[one_d], forward[one_d], rtol=1e-5)     # measured 5e-7 (the floor)


def test_normal_force_variation_scales_compliance_as_n_to_minus_two_thirds():
    """Kim's two creeps with normal_force_variation at ±1 N·m: at each contact the creep compliance is
    creepage/F = ε_ref (N_ref/N)^(2/3) with the contact's force-balanced N (ε_ref at N_ref = 100 N), where N
    ranges over 61..136 N (plus the model's rigid floor). Measured 4.7e-12 relative; tolerance 1e-10."""
    loads = np.array([-1.0, 1.0])
    G, T = np.meshgrid(GAMMAS, loads, indexing="ij")
    r = evaluate(["drive_longitudinal_creep", "steering_lateral_creep", "normal_force_variation"], G, T)
    N = r["N"]
    floor = FLOOR * V_REF / rolling_speeds(r)
    drive_c = -r["xi"][DRIVE] / r["F_t"][DRIVE] - floor[DRIVE]
    steer_c = -r["eta"][STEERING] / r["F_a"][STEERING] - floor[STEERING]
    ok_d, ok_s = np.abs(r["F_t"][DRIVE]) > 1.0, np.abs(r["F_a"][STEERING]) > 1.0
    err_d = np.max(np.abs(drive_c[ok_d] / (EPS_D * (N_REF / N[DRIVE][ok_d]) ** (2 / 3)) - 1))
    err_s = np.max(np.abs(steer_c[ok_s] / (EPS_S * (N_REF / N[STEERING][ok_s]) ** (2 / 3)) - 1))
    report(f"normal force variation: N {N.min():.1f}..{N.max():.1f} N; compliance vs ε(N) max rel err "
           f"drive {err_d:.2e}, steering {err_s:.2e}")
    assert err_d < 1e-10 and err_s < 1e-10
    assert N.max() / N.min() > 1.3                    # the law is exercised over a real range of N


@pytest.mark.parametrize("follow_n", [False, True], ids=["at_preload", "normal_force_variation"])
@pytest.mark.parametrize("load", [0.0, 0.6])
def test_rolling_resistance_moment_and_dissipation(load, follow_n):
    """Only rolling_resistance (offset 0.2 mm; every creep rigid): the moment is offset·N_c with N_c the
    preload, or the force-balanced N with normal_force_variation. Each idler's torque balance gives
    |F_t| = offset·N_c/r_S, and the shafts' power loss τ1ω1 + τ2ω2 = Σ offset·N_c,i·V_i·(1/R + 1/r_i), V_i =
    R|Ω·a_i| (the moment turns against both bodies' rolling), plus the rigid floor's own dissipation
    FLOOR·V_REF·Σ|F_i|². Measured 7.5e-13 (idler) and 3.9e-9 (loss, at 0.6 N·m) relative; tolerances
    1e-11 and 4e-8 (10×)."""
    off = 2e-4
    effects = ["rolling_resistance"] + (["normal_force_variation"] if follow_n else [])
    r = evaluate(effects, GAMMAS, load, **{"rolling_resistance.offset": off})
    Nc = r["N"] if follow_n else np.full_like(r["N"], PRELOAD)
    err_idler = np.max(np.abs(np.abs(r["F_t"][STEERING]) / (off * Nc[STEERING] / R_STEER) - 1))
    V = rolling_speeds(r)
    loss = np.sum(off * Nc * V * (1 / R_SPHERE + 1 / RADII[:, None]), axis=0) \
        + FLOOR * V_REF * np.sum(r["F_t"] ** 2 + r["F_a"] ** 2, axis=0)
    err_loss = np.max(np.abs(r["power_loss"] / loss - 1))
    report(f"rolling resistance at {load} N·m ({'N' if follow_n else 'P'}): idler |F_t| vs offset·N_c/r max rel "
           f"err {err_idler:.2e}; power loss vs Σ offset N_c V (1/R + 1/r) {err_loss:.2e} "
           f"(loss {loss.min():.4f}..{loss.max():.4f} W, N {r['N'].min():.1f}..{r['N'].max():.1f} N)")
    assert err_idler < 1e-11 and err_loss < 4e-8


# --- Hertz + Kalker creep constants (a variant without Kim's fitted ones) --------------------------------

def kalker_c22(a_over_b, nu):
    """Kalker's C22 from the typed table rows, piecewise linear in log(a/b), then 1/C quadratic in ν through
    the ν = 0, 0.25, 0.5 columns (the interpolation the package documents, CONTACT's, written here again)."""
    keys = sorted(KALKER_ROWS)
    x = np.log(keys)
    col = [np.interp(np.log(a_over_b), x, [KALKER_ROWS[k][1][j] for k in keys]) for j in range(3)]
    weights = np.polynomial.polynomial.polyfit([0.0, 0.25, 0.5], 1.0 / np.array(col), 2)
    return float(1.0 / np.polynomial.polynomial.polyval(nu, weights))


def test_hertz_kalker_creep_when_the_variant_gives_no_constants(make_variant):
    """existing_kim.yaml without `contact` (no Kim constants), its ball's material renamed so that the materials
    library has no calibration for it (theory only): the steering rollers' ε_S is Hertz + Kalker,
    1/(G a b C22) at the preload, and the model's steering slip is Kim's eqs 19-24 with that ε_S (to the
    6e-6; measured 6.2e-7). That ε_S is 0.28× Kim's fitted one, so a model that kept Kim's would fail."""
    def edit(d):
        d["contact"] = {"law": "kim"}           # Kim's linear law, without his fitted constants
        d["materials"]["resin"] = d["materials"].pop("bowling_ball")
        d["sphere"]["material"] = "resin"
        d["pairs"] = [{**p, "materials": [p["materials"][0], "resin"]} for p in d["pairs"]]
    lay = load_variant(make_variant("existing_kim", edit, file="no_constants"))
    assert lay.creep_drive is None and lay.creep_steering is None
    assert all(r.creep.uncalibrated for r in lay.rollers)
    E1, nu1, E2, nu2 = 12.3e6, 0.48, 2e9, 0.35                 # urethane 84A on the bowling ball
    e_star = 1 / ((1 - nu1 ** 2) / E1 + (1 - nu2 ** 2) / E2)
    G1, G2 = E1 / (2 * (1 + nu1)), E2 / (2 * (1 + nu2))
    G = 2 / (1 / G1 + 1 / G2)                                   # Kalker's combined shear modulus
    nu = G / 2 * (nu1 / G1 + nu2 / G2)
    a, b = hertz_axes(0.5 * (1 / R_SPHERE + 1 / R_STEER), 0.5 * (1 / R_SPHERE + 1 / 0.015), 100.0, e_star)
    eps_s = 1 / (G * a * b * kalker_c22(a / b, nu))
    m = compile_model(lay, effects=("steering_lateral_creep",))
    for tau in (0.05, -0.05):
        r = m.evaluate(GAMMAS, tau)
        assert r["ok"].all()
        expected = kim.steering_slip_angle(tau, GAMMAS, eps_s, R_DRIVE)
        err = np.max(np.abs(r["alpha_steering"] / expected - 1))
        report(f"Hertz + Kalker: a/b = {a / b:.3f}, ν = {nu:.4f}, ε_S = {eps_s:.4g} 1/N "
               f"({eps_s / EPS_S:.2f}× Kim's); α_SR rel err {err:.2e}")
        assert err < 6e-6
    assert eps_s / EPS_S == pytest.approx(0.277, abs=0.005)
