"""DESIGN.md sec. 4 anchors for cvtdesign.core.contact, plus symbolic (CasADi) evaluation and derivatives."""

import casadi as ca
import pytest

from cvtdesign.core import contact as c

# Hertz anchors, in N and mm (the function is unit-agnostic)
G, NU, N = 82000.0, 0.28, 82000.0
E_STAR = G / (1 - NU)


def floats(values):
    return [float(v) for v in values]


def test_hertz_elliptical_anchor():
    a, b, p0, approach = floats(c.hertz_ellipse(0.8464e-3, 0.2406e-2, N, E_STAR))
    # to the printed digits: a = 8.000 mm, b = 4.000 mm, p0 = 1223.5 N/mm^2, approach 0.09267 mm
    assert a == pytest.approx(8.000, abs=5e-4)
    assert b == pytest.approx(4.000, abs=5e-4)
    assert p0 == pytest.approx(1223.5, abs=0.05)
    assert approach == pytest.approx(0.09267, abs=5e-6)


def test_hertz_circular_anchor():
    a, b, p0, approach = floats(c.hertz_ellipse(0.4219e-2, 0.4219e-2, N, E_STAR))
    assert a == pytest.approx(4.000, abs=5e-4)
    assert b == a
    assert approach == pytest.approx(0.13500, abs=5e-6)
    assert p0 == pytest.approx(3 * N / (2 * 3.141592653589793 * a * b), rel=1e-14)


# Kalker (1990) table E.3 rows from DESIGN.md: a/b -> (C11, C22, C23), each for nu = 0, 0.25, 0.5
KALKER_ANCHORS = {
    0.1: ((2.51, 3.31, 4.85), (2.51, 2.52, 2.53), (0.334, 0.473, 0.731)),
    0.5: ((2.88, 3.62, 4.83), (2.88, 3.01, 3.14), (0.827, 0.929, 1.07)),
    1.0: ((3.40, 4.12, 5.20), (3.40, 3.67, 3.98), (1.33, 1.47, 1.63)),
    2.0: ((4.37, 5.10, 6.11), (4.37, 4.90, 5.56), (2.35, 2.62, 2.96)),
    10.0: ((10.7, 11.7, 12.9), (10.7, 12.8, 16.0), (12.2, 14.6, 18.0)),
}


@pytest.mark.parametrize("a_over_b", sorted(KALKER_ANCHORS))
@pytest.mark.parametrize("inu, nu", [(0, 0.0), (1, 0.25), (2, 0.5)])
def test_kalker_anchor_nodes(a_over_b, inu, nu):
    expected = [column[inu] for column in KALKER_ANCHORS[a_over_b]]
    assert floats(c.kalker_coefficients(a_over_b, nu)) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("sym", [ca.SX, ca.MX])
def test_symbolic_evaluation_equals_float(sym):
    A, B, Nf, Es, r, nu = (sym.sym(n) for n in ("A", "B", "N", "Es", "r", "nu"))
    f = ca.Function("contact", [A, B, Nf, Es, r, nu],
                    [*c.hertz_ellipse(A, B, Nf, Es), *c.kalker_coefficients(r, nu)])
    for args in [(0.8464e-3, 0.2406e-2, N, E_STAR, 2.0, 0.28),
                 (0.4219e-2, 0.4219e-2, N, E_STAR, 0.37, 0.1),
                 (0.2406e-2, 0.8464e-3, N, E_STAR, 6.5, 0.45)]:
        expected = floats(c.hertz_ellipse(*args[:4])) + floats(c.kalker_coefficients(*args[4:]))
        assert floats(f(*args)) == pytest.approx(expected, rel=1e-14)


@pytest.mark.parametrize("A, B", [(0.8464e-3, 0.2406e-2), (0.4219e-2, 0.4219e-2), (0.2406e-2, 0.8464e-3)])
def test_derivative_of_semi_axis_wrt_load(A, B):
    Nsym = ca.SX.sym("N")
    a = c.hertz_ellipse(A, B, Nsym, E_STAR)[0]
    f = ca.Function("a_of_N", [Nsym], [a, ca.jacobian(a, Nsym)])
    a0, dadN = floats(f(N))
    h = 1e-3 * N
    fd = (float(f(N + h)[0]) - float(f(N - h)[0])) / (2 * h)
    assert dadN == pytest.approx(fd, rel=1e-6)  # central difference error ~ (h/N)^2
    assert dadN == pytest.approx(a0 / (3 * N), rel=1e-12)  # Hertz: a proportional to N^(1/3)
    assert float(f(8 * N)[0]) == pytest.approx(2 * a0, rel=1e-13)
