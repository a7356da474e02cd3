"""An independent Hertz solution for the tests: Johnson, "Contact Mechanics", sec. 4.2, solved with SciPy's
elliptic integrals (which take the parameter m = e²), written without cvtdesign.core.contact."""
import numpy as np
from scipy import optimize, special


def hertz_axes(A, B, N, E_star):
    """Semi-axes (a along x, b along y) [m] of the contact of a gap h = A x² + B y² with B > A (so a ≥ b):
    q = a/b solves B/A = [q² E(e) − K(e)]/[K(e) − E(e)], e² = 1 − q⁻², and a³ = 3 N (K − E)/(2π A E* e²)."""
    def ratio(q):
        m = 1 - q ** -2
        return (q * q * special.ellipe(m) - special.ellipk(m)) / (special.ellipk(m) - special.ellipe(m))
    q = optimize.brentq(lambda x: ratio(x) - B / A, 1 + 1e-9, 1e3, xtol=1e-15, rtol=1e-15)
    m = 1 - q ** -2
    K, E = special.ellipk(m), special.ellipe(m)
    a = (3 * N * (K - E) / (2 * np.pi * A * E_star * m)) ** (1 / 3)
    return a, a / q
