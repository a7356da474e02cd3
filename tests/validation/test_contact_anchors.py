"""Printed anchors for cvtdesign.core.contact (Hertz: Johnson's "Contact Mechanics" sec. 4.2 worked values;
Kalker's table E.3, every row, typed here from its source), plus symbolic (CasADi) evaluation and
derivatives."""

import casadi as ca
import pytest

from cvtdesign.core.contact import hertz, kalker

# Hertz anchors, in N and mm (the function is unit-agnostic)
G, NU, N = 82000.0, 0.28, 82000.0
E_STAR = G / (1 - NU)


def floats(values):
    return [float(v) for v in values]


def test_hertz_elliptical_anchor():
    a, b, p0, approach = floats(hertz.hertz_ellipse(0.8464e-3, 0.2406e-2, N, E_STAR))
    # to the printed digits: a = 8.000 mm, b = 4.000 mm, p0 = 1223.5 N/mm^2, approach 0.09267 mm
    assert a == pytest.approx(8.000, abs=5e-4)
    assert b == pytest.approx(4.000, abs=5e-4)
    assert p0 == pytest.approx(1223.5, abs=0.05)
    assert approach == pytest.approx(0.09267, abs=5e-6)


def test_hertz_circular_anchor():
    a, b, p0, approach = floats(hertz.hertz_ellipse(0.4219e-2, 0.4219e-2, N, E_STAR))
    assert a == pytest.approx(4.000, abs=5e-4)
    assert b == a
    assert approach == pytest.approx(0.13500, abs=5e-6)
    assert p0 == pytest.approx(3 * N / (2 * 3.141592653589793 * a * b), rel=1e-14)


# Kalker (1990) "Three-dimensional elastic bodies in rolling contact", table E.3, all 19 rows, typed here
# from the data statement of subroutine linrol in CONTACT's src/m_hertz.f90 (repository eve70a/CONTACT),
# independently of cvtdesign.core.contact.KALKER_TABLE: a/b -> (C11, C22, C23), each for ν = 0, 0.25, 0.5.
# CONTACT stores the rows as g = a/b = 0.1..1 (a < b) and g = b/a = 0.1..1 (a > b); here keyed by a/b.
_A_LT_B = [   # g = a/b = 0.1, 0.2, ..., 1.0
    ((2.51, 3.31, 4.85), (2.51, 2.52, 2.53), (.334, .473, .731)),
    ((2.59, 3.37, 4.81), (2.59, 2.63, 2.66), (.483, .603, .809)),
    ((2.68, 3.44, 4.80), (2.68, 2.75, 2.81), (.607, .715, .889)),
    ((2.78, 3.53, 4.82), (2.78, 2.88, 2.98), (.720, .823, .977)),
    ((2.88, 3.62, 4.83), (2.88, 3.01, 3.14), (.827, .929, 1.07)),
    ((2.98, 3.72, 4.91), (2.98, 3.14, 3.31), (.930, 1.03, 1.18)),
    ((3.09, 3.81, 4.97), (3.09, 3.28, 3.48), (1.03, 1.14, 1.29)),
    ((3.19, 3.91, 5.05), (3.19, 3.41, 3.65), (1.13, 1.25, 1.40)),
    ((3.29, 4.01, 5.12), (3.29, 3.54, 3.82), (1.23, 1.36, 1.51)),
    ((3.40, 4.12, 5.20), (3.40, 3.67, 3.98), (1.33, 1.47, 1.63)),
]
_A_GT_B = [   # g = b/a = 0.1, 0.2, ..., 0.9 (the row b/a = 1 is the circle, above)
    ((10.7, 11.7, 12.9), (10.7, 12.8, 16.0), (12.2, 14.6, 18.0)),
    ((6.96, 7.78, 8.82), (6.96, 8.14, 9.79), (5.72, 6.63, 7.89)),
    ((5.57, 6.34, 7.34), (5.57, 6.40, 7.51), (3.79, 4.32, 5.01)),
    ((4.84, 5.57, 6.57), (4.84, 5.48, 6.31), (2.88, 3.24, 3.70)),
    ((4.37, 5.10, 6.11), (4.37, 4.90, 5.56), (2.35, 2.62, 2.96)),
    ((4.06, 4.78, 5.80), (4.06, 4.50, 5.04), (2.01, 2.23, 2.50)),
    ((3.82, 4.54, 5.58), (3.82, 4.21, 4.67), (1.76, 1.95, 2.18)),
    ((3.65, 4.36, 5.42), (3.65, 3.99, 4.39), (1.58, 1.75, 1.94)),
    ((3.51, 4.22, 5.30), (3.51, 3.81, 4.16), (1.44, 1.59, 1.77)),
]
KALKER_ROWS = {round(k / 10, 12): row for k, row in enumerate(_A_LT_B, 1)} | \
    {10 / k: row for k, row in enumerate(_A_GT_B, 1)}


def test_kalker_rows_typed_are_the_table():
    """19 rows, a/b from 0.1 to 10; for ν = 0, C11 = C22 (Kalker)."""
    assert len(KALKER_ROWS) == 19 and min(KALKER_ROWS) == 0.1 and max(KALKER_ROWS) == 10.0
    assert all(row[0][0] == row[1][0] for row in KALKER_ROWS.values())


@pytest.mark.parametrize("a_over_b", sorted(KALKER_ROWS))
@pytest.mark.parametrize("inu, nu", [(0, 0.0), (1, 0.25), (2, 0.5)])
def test_kalker_anchor_nodes(a_over_b, inu, nu):
    """At every node of the table the interpolation returns the printed coefficients (to their 3 digits,
    exactly: the nodes are the package's own table values, which must equal the printed ones)."""
    expected = [column[inu] for column in KALKER_ROWS[a_over_b]]
    assert floats(kalker.kalker_coefficients(a_over_b, nu))[:3] == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("sym", [ca.SX, ca.MX])
def test_symbolic_evaluation_equals_float(sym):
    A, B, Nf, Es, r, nu = (sym.sym(n) for n in ("A", "B", "N", "Es", "r", "nu"))
    f = ca.Function("contact", [A, B, Nf, Es, r, nu],
                    [*hertz.hertz_ellipse(A, B, Nf, Es), *kalker.kalker_coefficients(r, nu)])
    for args in [(0.8464e-3, 0.2406e-2, N, E_STAR, 2.0, 0.28),
                 (0.4219e-2, 0.4219e-2, N, E_STAR, 0.37, 0.1),
                 (0.2406e-2, 0.8464e-3, N, E_STAR, 6.5, 0.45)]:
        expected = floats(hertz.hertz_ellipse(*args[:4])) + floats(kalker.kalker_coefficients(*args[4:]))
        assert floats(f(*args)) == pytest.approx(expected, rel=1e-14)


@pytest.mark.parametrize("A, B", [(0.8464e-3, 0.2406e-2), (0.4219e-2, 0.4219e-2), (0.2406e-2, 0.8464e-3)])
def test_derivative_of_semi_axis_wrt_load(A, B):
    Nsym = ca.SX.sym("N")
    a = hertz.hertz_ellipse(A, B, Nsym, E_STAR)[0]
    f = ca.Function("a_of_N", [Nsym], [a, ca.jacobian(a, Nsym)])
    a0, dadN = floats(f(N))
    h = 1e-3 * N
    fd = (float(f(N + h)[0]) - float(f(N - h)[0])) / (2 * h)
    assert dadN == pytest.approx(fd, rel=1e-6)  # central difference error ~ (h/N)^2
    assert dadN == pytest.approx(a0 / (3 * N), rel=1e-12)  # Hertz: a proportional to N^(1/3)
    assert float(f(8 * N)[0]) == pytest.approx(2 * a0, rel=1e-13)
