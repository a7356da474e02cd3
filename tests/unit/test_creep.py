"""core.creep: Kalker's linear theory at small creepage, Polach's saturation towards μN, symmetry."""
import math

import numpy as np
import pytest

from cvtdesign.core.creep import creep_forces, polach_forces, saturation_ratio, spin_force

# a patch like Kim's drive contact (core.patch on existing.yaml at 100 N)
N, MU, A, B, G = 100.0, 0.8, 5.70e-3, 3.57e-3, 7.19e6
C11, C22, C23 = 5.65, 4.90, 2.39


def forces(xi, eta, phi):
    return tuple(float(f) for f in polach_forces(xi, eta, phi, N, MU, A, B, G, C11, C22, C23))


@pytest.mark.parametrize("xi, eta, phi", [(1e-9, 0, 0), (0, 1e-9, 0), (0, 0, 1e-7), (2e-9, -1e-9, 3e-7)])
def test_small_creepage_is_kalkers_linear_theory(xi, eta, phi):
    """Fx = −G a b C11 ξ, Fy = −G a b (C22 η + √(ab) C23 φ) (Kalker 1990), to 1e-9 relative."""
    fx, fy = forces(xi, eta, phi)
    assert fx == pytest.approx(-G * A * B * C11 * xi, rel=1e-9, abs=1e-18)
    assert fy == pytest.approx(-G * A * B * (C22 * eta + math.sqrt(A * B) * C23 * phi), rel=1e-9, abs=1e-18)


def test_creepage_saturates_at_mu_n_and_never_beyond():
    """|F| grows monotonically with the creepage towards μN (Polach: (2μN/π)(ε/(1+ε²) + arctan ε)), in any
    direction of creepage, and keeps the direction of Kalker's linear force."""
    for angle in np.radians([0, 30, 90, 135, 250]):
        s = np.logspace(-5, 3, 60)
        f = np.array([forces(x * np.cos(angle), x * np.sin(angle), 0.0) for x in s])
        mag = np.hypot(f[:, 0], f[:, 1])
        assert np.all(np.diff(mag) > 0) and np.all(mag < MU * N) and mag[-1] > 0.999 * MU * N
        lin = np.array([C11 * np.cos(angle), C22 * np.sin(angle)])
        np.testing.assert_allclose(-f / mag[:, None], np.broadcast_to(lin / np.linalg.norm(lin), f.shape), atol=1e-12)


def test_saturation_ratio_is_polachs_law():
    for eps in (1e-3, 0.5, 1.0, 3.0, 40.0):
        assert float(saturation_ratio(eps)) * 2 * eps == pytest.approx(eps / (1 + eps ** 2) + math.atan(eps), rel=1e-12)


def test_forces_are_odd_in_the_creepages():
    f = forces(0.01, -0.02, 15.0)
    g = forces(-0.01, 0.02, -15.0)
    assert g == pytest.approx((-f[0], -f[1]), rel=1e-12)


def test_pure_spin_force_peaks_below_mu_n_then_falls():
    """Pure spin's lateral force rises with linear theory's slope, peaks below μN and falls as the traction
    comes to circulate (Polach's K_M), so no spin alone gives gross slip."""
    phis = np.linspace(0, 600, 301)
    f = -np.array([float(spin_force(0.0, 0.0, p, N, MU, A, B, G, C23)) for p in phis]) / (MU * N)
    k = int(np.argmax(f))
    assert 0 < k < len(phis) - 1 and 0.5 < f[k] < 1.0 and f[-1] < 0.2 * f[k]
    assert float(creep_forces(0.0, 0.0, N, MU, A, B, G, C11, C22)[0]) == 0.0
