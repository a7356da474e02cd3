"""The creep-force table's spline coefficients (core.contact.surface): made by one matrix an axis, they are the
interpolating natural spline's, the same (to round-off) as solving its conditions along each axis in turn, and
the shipped table's spline passes through the table at its nodes."""
from __future__ import annotations

import numpy as np
import pytest

from cvtdesign.core.contact import surface


def b_spline_at_nodes(c: np.ndarray) -> np.ndarray:
    """The uniform cubic B-spline with coefficients c_-1..c_n (first axis) at its n nodes."""
    return (c[:-2] + 4.0 * c[1:-1] + c[2:]) / 6.0


@pytest.mark.parametrize("n", [2, 5, 16, 41])
def test_spline_matrix_interpolates_with_natural_ends(n):
    """The matrix's coefficients give back the values at the nodes, with zero second difference at both ends."""
    y = np.random.default_rng(n).normal(size=(n, 4))
    c = surface.spline_matrix(n) @ y
    assert c.shape == (n + 2, 4)
    np.testing.assert_allclose(b_spline_at_nodes(c), y, rtol=0, atol=1e-13)
    np.testing.assert_allclose(c[0] - 2 * c[1] + c[2], 0.0, rtol=0, atol=1e-13)
    np.testing.assert_allclose(c[-1] - 2 * c[-2] + c[-3], 0.0, rtol=0, atol=1e-13)


def solve_along(values: np.ndarray, axis: int) -> np.ndarray:
    """The coefficients along one axis by solving the interpolation conditions directly (one LU solve)."""
    y = np.moveaxis(values, axis, 0)
    n = y.shape[0]
    A = np.zeros((n + 2, n + 2))
    A[0, :3] = A[-1, -3:] = (1.0, -2.0, 1.0)
    for i in range(n):
        A[i + 1, i:i + 3] = (1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0)
    pad = np.zeros((1,) + y.shape[1:])
    rhs = np.concatenate([pad, y, pad])
    return np.moveaxis(np.linalg.solve(A, rhs.reshape(n + 2, -1)).reshape(rhs.shape), 0, axis)


def test_coefficients_are_the_axis_by_axis_solve():
    """On a random table of the surface's layout (ratio, output, z0, z1, z2): the same coefficients as solving
    along the ratio, z0, z1 and z2 in turn, C-ordered [output][ratio][z2][z1][z0] as surface.c reads them."""
    values = np.random.default_rng(3).normal(size=(6, 3, 7, 8, 9))
    want = values
    for axis in (0, 2, 3, 4):
        want = solve_along(want, axis)
    got = surface.spline_coefficients(values)
    assert got.flags.c_contiguous
    np.testing.assert_allclose(got, np.transpose(want, (1, 0, 4, 3, 2)), rtol=0, atol=1e-13)


def test_shipped_spline_passes_through_the_table():
    """The spline of the shipped table at 300 of its interior nodes (any a/b node) is the table's value there."""
    with np.load(surface.DATA) as data:
        table = surface.unfold(data["values"].astype(float))              # (ratio, output, z0, z1, z2)
    rng = np.random.default_rng(5)
    k = rng.integers(1, surface.GRID_POINTS - 1, size=(3, 300))
    r = rng.integers(0, len(surface.RATIO_NODES), size=300)
    z = surface.grid()[k]
    got = surface.evaluate(z, surface.RATIO_NODES[r])
    want = table[r, :, k[0], k[1], k[2]].T
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
