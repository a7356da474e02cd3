"""Unit tests for cvtdesign.core.contact.hertz and .kalker: elliptic integrals, Hertz ellipse, Kalker table interpolation."""

import math

import casadi as ca
import numpy as np
import pytest
from scipy import optimize, special

from cvtdesign.core.contact import hertz, kalker


def floats(values):
    return [float(v) for v in values]


# --- elliptic integrals -------------------------------------------------------------------------------

M_VALUES = [0.0, 1e-14, 1e-8, 1e-3, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.999, 0.9999, -1.0, -400.0]


@pytest.mark.parametrize("m", M_VALUES)
def test_elliptic_KE_matches_scipy(m):
    K, E = floats(hertz.elliptic_KE(m))
    assert K == pytest.approx(special.ellipk(m), rel=1e-12, abs=0)
    assert E == pytest.approx(special.ellipe(m), rel=1e-12, abs=0)


def test_elliptic_KE_symbolic_equals_float():
    m = ca.SX.sym("m")
    f = ca.Function("ke", [m], list(hertz.elliptic_KE(m)))
    for mv in (0.0, 0.37, 0.9999):
        assert floats(f(mv)) == pytest.approx(floats(hertz.elliptic_KE(mv)), rel=1e-15)


# --- geometry and material ----------------------------------------------------------------------------

def test_curvature_sums_crowned_and_cylindrical():
    A, B = floats(hertz.curvature_sums(0.0635, 0.040, 0.010))
    assert A == pytest.approx(0.5 * (1 / 0.0635 + 1 / 0.040), rel=1e-15)
    assert B == pytest.approx(0.5 * (1 / 0.0635 + 1 / 0.010), rel=1e-15)
    A, B = floats(hertz.curvature_sums(0.0635, 0.040, math.inf))
    assert B == pytest.approx(1 / (2 * 0.0635), rel=1e-15)


def test_contact_material_identical_bodies():
    E, nu = 210e9, 0.3
    E_star, G, nu_c = floats(hertz.contact_material(E, nu, E, nu))
    assert E_star == pytest.approx(E / (2 * (1 - nu**2)), rel=1e-14)
    assert G == pytest.approx(E / (2 * (1 + nu)), rel=1e-14)
    assert nu_c == pytest.approx(nu, rel=1e-14)
    assert E_star == pytest.approx(G / (1 - nu_c), rel=1e-14)


def test_contact_material_steel_on_polyurethane():
    E1, nu1, E2, nu2 = 210e9, 0.3, 30e6, 0.48
    E_star, G, nu = floats(hertz.contact_material(E1, nu1, E2, nu2))
    G1, G2 = E1 / (2 * 1.3), E2 / (2 * 1.48)
    assert E_star == pytest.approx(1 / ((1 - 0.09) / E1 + (1 - 0.48**2) / E2), rel=1e-14)
    assert G == pytest.approx(2 * G1 * G2 / (G1 + G2), rel=1e-14)
    assert nu == pytest.approx(G / 2 * (nu1 / G1 + nu2 / G2), rel=1e-14)
    assert floats(hertz.contact_material(E2, nu2, E1, nu1)) == pytest.approx([E_star, G, nu], rel=1e-15)
    assert nu == pytest.approx(0.48, abs=1e-3)  # soft body dominates: G ~ 2 G2, nu ~ nu2


# --- Hertz ellipse ------------------------------------------------------------------------------------

def test_hertz_swap_symmetry():
    a, b, p0, d = floats(hertz.hertz_ellipse(1.3e-3, 7.1e-3, 250.0, 2.3e7))
    a2, b2, p02, d2 = floats(hertz.hertz_ellipse(7.1e-3, 1.3e-3, 250.0, 2.3e7))
    assert a > b
    assert (a2, b2) == pytest.approx((b, a), rel=1e-13)
    assert (p02, d2) == pytest.approx((p0, d), rel=1e-13)


@pytest.mark.parametrize("factor", [1 + 1e-9, 1 - 1e-9])
def test_hertz_circle_limit_is_continuous(factor):
    B = 0.4219e-2
    circle = floats(hertz.hertz_ellipse(B, B, 82000.0, 82000.0 / 0.72))
    near = floats(hertz.hertz_ellipse(B * factor, B, 82000.0, 82000.0 / 0.72))
    assert near == pytest.approx(circle, rel=2e-9)


def test_hertz_circle_matches_classic_formulae():
    R, N, E_star = 0.02, 100.0, 1e8  # sphere on a flat of radius-R equivalent: A = B = 1/(2R)
    a, b, p0, d = floats(hertz.hertz_ellipse(1 / (2 * R), 1 / (2 * R), N, E_star))
    assert a == b
    assert a == pytest.approx((3 * N * R / (4 * E_star)) ** (1 / 3), rel=1e-14)
    assert d == pytest.approx(a**2 / R, rel=1e-14)
    assert p0 == pytest.approx(3 * N / (2 * math.pi * a**2), rel=1e-14)


def _johnson_ratio(a_over_b):
    """B/A implied by a >= b (Johnson eq. 4.39), evaluated with scipy."""
    m = 1 - a_over_b**-2
    K, E = special.ellipk(m), special.ellipe(m)
    return (a_over_b**2 * E - K) / (K - E)


@pytest.mark.parametrize("target", [1.05, 1.5, 2.0, 5.0, 10.0, 20.0])
@pytest.mark.parametrize("major_along_x", [True, False])
def test_hertz_solves_eccentricity_equation(target, major_along_x):
    ratio = _johnson_ratio(target)  # B/A for which a/b = target
    A, B = (1.0, ratio) if major_along_x else (ratio, 1.0)
    N, E_star = 3.0, 2.0
    a, b, p0, d = floats(hertz.hertz_ellipse(A, B, N, E_star))
    major, minor = (a, b) if major_along_x else (b, a)
    assert major / minor == pytest.approx(target, rel=1e-12)
    # independent check of the size with scipy: a^3 = 3 N (K - E) / (2 pi A_min E* e^2)
    m = 1 - (minor / major) ** 2
    K, E = special.ellipk(m), special.ellipe(m)
    assert major**3 == pytest.approx(3 * N * (K - E) / (2 * math.pi * 1.0 * E_star * m), rel=1e-12)
    assert N == pytest.approx(2 / 3 * math.pi * a * b * p0, rel=1e-14)
    assert d == pytest.approx(p0 * minor * K / E_star, rel=1e-12)


def test_hertz_ratio_root_by_brentq():
    # a/b for B/A = 7 solved independently with scipy's root finder
    root = optimize.brentq(lambda q: _johnson_ratio(q) - 7.0, 1.0001, 50.0, xtol=1e-15, rtol=1e-15)
    a, b, _, _ = floats(hertz.hertz_ellipse(1.0, 7.0, 1.0, 1.0))
    assert a / b == pytest.approx(root, rel=1e-12)


def test_float_inputs_give_float_convertible_results():
    for value in (*hertz.hertz_ellipse(1.0, 2.0, 3.0, 4.0), *kalker.kalker_coefficients(1.7, 0.3),
                  *kalker.creep_compliances(1.0, 2.0, 3.0, 4.0, 5.0), kalker.spin_force_coefficient(1.0, 2.0, 3.0, 4.0)):
        assert isinstance(float(value), float)


# --- Kalker coefficients ------------------------------------------------------------------------------

def test_kalker_table_layout():
    """The table's shape and node order (its values are checked against the printed table, typed
    independently, in tests/validation/test_contact_anchors.py)."""
    assert kalker.KALKER_TABLE.shape == (19, 9) and kalker.KALKER_C33.shape == (19, 3)
    assert kalker.KALKER_A_OVER_B[0] == pytest.approx(0.1) and kalker.KALKER_A_OVER_B[-1] == pytest.approx(10.0)
    assert np.all(np.diff(kalker.KALKER_A_OVER_B) > 0)
    # Kalker: for nu = 0 longitudinal and lateral coefficients coincide
    np.testing.assert_array_equal(kalker.KALKER_TABLE[:, 0], kalker.KALKER_TABLE[:, 3])


def columns(i, j):
    """Column of coefficient i (C11, C22, C23, C33) at the j-th Poisson ratio of the tables."""
    return kalker.KALKER_TABLE[:, 3 * i + j] if i < 3 else kalker.KALKER_C33[:, j]


def test_kalker_between_nodes_lies_between_neighbours():
    nodes = kalker.KALKER_A_OVER_B
    for i in range(len(nodes) - 1):
        mid = math.sqrt(nodes[i] * nodes[i + 1])  # midpoint in log(a/b)
        for j, nu in enumerate((0.0, 0.25, 0.5)):     # the tables' columns
            got = floats(kalker.kalker_coefficients(mid, nu))
            for k in range(4):
                lo, hi = columns(k, j)[i], columns(k, j)[i + 1]
                assert got[k] == pytest.approx(0.5 * (lo + hi), rel=1e-12)


def test_kalker_monotonic_where_table_is():
    aob = np.logspace(-1, 1, 301)
    for nu in (0.0, 0.1, 0.25, 0.4, 0.5):
        values = np.array([floats(kalker.kalker_coefficients(x, nu)) for x in aob])
        assert np.all(np.diff(values[:, 1]) > 0)  # C22 grows with a/b
        assert np.all(np.diff(values[:, 2]) > 0)  # C23 grows with a/b
        assert np.all(np.diff(values[aob >= 0.3, 0]) > 0)  # C11 grows for a/b >= 0.3 (table dips below)
        # C33 falls with a/b where it is well determined (contact.KALKER_C33: a/b up to about 2.5); beyond, its
        # nu columns spread so far (0.81 to 0.23 at a/b = 10) that 1/C quadratic in nu need not fall there
        assert np.all(np.diff(values[aob <= 3.0, 3]) < 0)
    nus = np.linspace(0, 0.5, 21)
    for x in (0.15, 1.0, 3.0):
        values = np.array([floats(kalker.kalker_coefficients(x, nu)) for nu in nus])
        assert np.all(np.diff(values[:, :3], axis=0) > 0)  # C11, C22, C23 grow with nu at these ratios
    for x, sign in ((0.15, 1), (3.0, -1)):   # C33 grows with nu for a < b and falls for a > b
        values = np.array([floats(kalker.kalker_coefficients(x, nu)) for nu in nus])
        assert np.all(sign * np.diff(values[:, 3]) > 0)


def test_kalker_nu_rule_and_clamping():
    """Between the columns, 1/C is quadratic in nu (CONTACT's linrol), exact for C proportional to 1/(1 - nu):
    a row built as k/(1 - nu) comes back as k/(1 - nu) at any nu."""
    nu = 0.37
    for x in (0.3, 1.0, 4.0):
        got = floats(kalker.kalker_coefficients(x, nu))
        for k in range(4):
            row = [float(np.interp(np.log(x), np.log(kalker.KALKER_A_OVER_B), columns(k, j))) for j in range(3)]
            inverse = (8 * (nu - .25) * (nu - .5) / row[0] - 16 * nu * (nu - .5) / row[1]
                       + 8 * nu * (nu - .25) / row[2])
            assert got[k] == pytest.approx(1 / inverse, rel=1e-12)
    # the rule is exact for 1/(1 - nu): three nodes of a quadratic in nu give it back
    assert 8 * (nu - .25) * (nu - .5) * 1 - 16 * nu * (nu - .5) * .75 + 8 * nu * (nu - .25) * .5 == \
        pytest.approx(1 - nu, rel=1e-14)
    assert floats(kalker.kalker_coefficients(0.05, 0.3)) == pytest.approx(floats(kalker.kalker_coefficients(0.1, 0.3)))
    assert floats(kalker.kalker_coefficients(30.0, 0.3)) == pytest.approx(floats(kalker.kalker_coefficients(10.0, 0.3)))
    assert floats(kalker.kalker_coefficients(2.0, 0.7)) == pytest.approx(floats(kalker.kalker_coefficients(2.0, 0.5)))
    assert floats(kalker.kalker_coefficients(2.0, -0.1)) == pytest.approx(floats(kalker.kalker_coefficients(2.0, 0.0)))


@pytest.mark.slow
def test_pivot_lever():
    """Mean lever of the Hertz pressure: 3 pi a/16 for a circle, symmetric in a and b, and equal to a
    direct quadrature of (3/(2 pi a b)) int sqrt(1 - x^2/a^2 - y^2/b^2) sqrt(x^2 + y^2) dA."""
    assert float(hertz.pivot_lever(2.0, 2.0)) == pytest.approx(3 * math.pi * 2.0 / 16, rel=1e-14)
    assert float(hertz.pivot_lever(1.0, 3.0)) == pytest.approx(float(hertz.pivot_lever(3.0, 1.0)), rel=1e-13)
    a, b, n = 3.0, 1.0, 2000
    rho, t = (np.arange(n) + 0.5) / n, (np.arange(n) + 0.5) * 2 * math.pi / n
    R, T = np.meshgrid(rho, t)
    integrand = np.sqrt(1 - R**2) * np.hypot(a * R * np.cos(T), b * R * np.sin(T)) * a * b * R
    quad = 3 / (2 * math.pi * a * b) * integrand.sum() / n * 2 * math.pi / n
    assert float(hertz.pivot_lever(a, b)) == pytest.approx(quad, rel=1e-5)


def test_creep_compliances_and_spin():
    G, a, b = 8e10, 2e-3, 1e-3
    eps_long, eps_lat = floats(kalker.creep_compliances(G, a, b, 4.12, 3.67))
    assert eps_long == pytest.approx(1 / (G * a * b * 4.12), rel=1e-15)
    assert eps_lat == pytest.approx(1 / (G * a * b * 3.67), rel=1e-15)
    assert float(kalker.spin_force_coefficient(G, a, b, 1.47)) == pytest.approx(G * (a * b) ** 1.5 * 1.47, rel=1e-14)
