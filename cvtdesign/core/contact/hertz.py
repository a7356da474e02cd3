"""Hertz's elliptical contact of a roller on the sphere: curvature sums, combined elastic constants, the
ellipse's semi-axes, peak pressure and approach, and the pivoting lever of its pressure.

One function per physical model, SI units (m, N, Pa) unless a docstring says otherwise. Every function
accepts Python floats as well as CasADi ``SX``/``MX`` scalars: only CasADi operations and arithmetic
are used on the inputs (no numpy, no Python ``if`` on values), so the same expressions can be built into
a CasADi model and differentiated. Called with floats, results are floats or 1x1 ``casadi.DM``
(``float(x)`` works on both).

References
----------
.. [1] K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985, sec. 4.2.
.. [2] J. J. Kalker, *Three-dimensional elastic bodies in rolling contact*, Kluwer, 1990, table E.3.
.. [3] E. A. H. Vollebregt, CONTACT, ``src/m_hertz.f90`` (subroutine ``linrol``),
       https://github.com/eve70a/CONTACT (Apache-2.0).
.. [4] B. J. Hamrock, D. E. Brewe, "Simplified solution for stresses and deformations",
       J. Lubrication Technology 105 (1983) 171-177.
"""

import math

import casadi as ca

_AGM_ITERATIONS = 7  # AGM converges quadratically: 6 steps already reach double precision, -1e3 < m <= 0.9999
_NEWTON_ITERATIONS = 5  # from the Hamrock-Brewe start, 3 steps already give < 1e-14 for 1/25 <= a/b <= 25


def _agm_KS(m):
    """K(m) and S(m) = (K - E)/(m K), computed without 0/0 at m = 0 (S(0) = 1/2).

    AGM a_{n+1} = (a_n + b_n)/2, b_{n+1} = sqrt(a_n b_n), a_0 = 1, b_0 = sqrt(1 - m); with
    c_n^2 = a_n^2 - b_n^2 = m t_n, t_0 = 1, t_{n+1} = m t_n^2 / (16 a_{n+1}^2) and
    E = K (1 - m sum_n 2^(n-1) t_n), K = pi / (2 a_N) (Abramowitz & Stegun 17.6). Valid for all m < 1.
    """
    a, b, t, s = 1.0, ca.sqrt(1.0 - m), 1.0, 0.5
    for n in range(1, _AGM_ITERATIONS + 1):
        a, b = 0.5 * (a + b), ca.sqrt(a * b)
        t = m * t * t / (16.0 * a * a)
        s = s + 2.0 ** (n - 1) * t
    return math.pi / (2.0 * a), s


def elliptic_KE(m):
    """Complete elliptic integrals of the first and second kind.

    K(m) = int_0^{pi/2} (1 - m sin^2 t)^(-1/2) dt,  E(m) = int_0^{pi/2} (1 - m sin^2 t)^(1/2) dt,
    by the arithmetic-geometric mean with a fixed number of iterations (symbolic-safe).

    Parameters
    ----------
    m : float or casadi.SX/MX
        Parameter m = e^2 [-], m < 1 (accurate to double precision for m <= 0.9999; negative m is
        allowed and is used for the analytic continuation in :func:`hertz_ellipse`).

    Returns
    -------
    K, E : [-]
    """
    K, S = _agm_KS(m)
    return K, K * (1.0 - m * S)


def curvature_sums(R_sphere, r_roll, r_crown):
    """Curvature sums of a sphere on a crowned roller: gap h = A x^2 + B y^2 (x rolling direction).

    A = (1/R_sphere + 1/r_roll)/2,  B = (1/R_sphere + 1/r_crown)/2 (convex bodies; Johnson [1] sec. 4.2).

    Parameters
    ----------
    R_sphere : sphere radius [m]
    r_roll : roller rolling radius [m]
    r_crown : roller crown radius [m]; ``float('inf')`` gives a cylindrical roller (B = 1/(2 R_sphere))

    Returns
    -------
    A, B : curvature sums [1/m]
    """
    return 0.5 * (1.0 / R_sphere + 1.0 / r_roll), 0.5 * (1.0 / R_sphere + 1.0 / r_crown)


def contact_material(E1, nu1, E2, nu2):
    """Combined elastic constants of two bodies in contact.

    Hertz contact modulus 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2 (Johnson [1]); Kalker's combined
    shear modulus 1/G = (1/G1 + 1/G2)/2 with Gi = Ei/(2(1 + nui)) and combined Poisson ratio
    nu = G/2 (nu1/G1 + nu2/G2) (Kalker [2]). For identical materials E* = G/(1 - nu).

    Parameters
    ----------
    E1, E2 : Young's moduli [Pa]
    nu1, nu2 : Poisson ratios [-]

    Returns
    -------
    E_star : contact modulus [Pa]
    G : combined shear modulus [Pa]
    nu : combined Poisson ratio [-]
    """
    E_star = 1.0 / ((1.0 - nu1**2) / E1 + (1.0 - nu2**2) / E2)
    G1, G2 = E1 / (2.0 * (1.0 + nu1)), E2 / (2.0 * (1.0 + nu2))
    G = 2.0 / (1.0 / G1 + 1.0 / G2)
    return E_star, G, 0.5 * G * (nu1 / G1 + nu2 / G2)


def _ratio_residual_function():
    """CasADi function u -> (f, df/du), f(u) = log(B/A) implied by an ellipse with log(a/b) = u.

    Johnson [1] eq. 4.39: B/A = [(a/b)^2 E - K]/(K - E), e^2 = m = 1 - (b/a)^2. Written as
    B/A = (a/b)^2 (1 - S)/S with S from :func:`_agm_KS`, so there is no 0/0 at the circle; the
    same expression with m < 0 is the analytic continuation to a < b (Carlson's symmetric forms),
    which makes f odd and smooth through u = 0.
    """
    u = ca.SX.sym("u")
    _, S = _agm_KS(1.0 - ca.exp(-2.0 * u))
    f = 2.0 * u + ca.log(1.0 - S) - ca.log(S)
    return ca.Function("hertz_ratio_residual", [u], [f, ca.jacobian(f, u)])


_RATIO_RESIDUAL = _ratio_residual_function()


def hertz_ellipse(A, B, N, E_star):
    """Hertz elliptical contact: semi-axes, peak pressure and mutual approach.

    Solves the eccentricity equation B/A = [(a/b)^2 E(e) - K(e)]/[K(e) - E(e)] (Johnson [1] sec. 4.2)
    for u = log(a/b) by Newton's method, unrolled over a fixed number of iterations from the
    Hamrock-Brewe start a/b = (B/A)^(2/pi) [4]; then a^3 = 3 N (K - E)/(2 pi A E* e^2),
    p0 = 3 N/(2 pi a b), approach = p0 b K(e)/E*. Works for A < B, A > B and A = B (circle) with one
    smooth expression (see :func:`_ratio_residual_function`). Unit-agnostic (consistent units).

    Parameters
    ----------
    A : curvature sum along x, the rolling direction [1/m]
    B : curvature sum along y [1/m]
    N : normal force [N]
    E_star : contact modulus, see :func:`contact_material` [Pa]

    Returns
    -------
    a : semi-axis along x [m]
    b : semi-axis along y [m]
    p0 : peak pressure [Pa]
    approach : mutual normal approach of distant points of the two bodies [m]
    """
    L = ca.log(B / A)
    u = (2.0 / math.pi) * L
    for _ in range(_NEWTON_ITERATIONS):
        f, df = _RATIO_RESIDUAL(u)
        u = u - (f - L) / df
    m = 1.0 - ca.exp(-2.0 * u)
    K, S = _agm_KS(m)
    a = (3.0 * N * K * S / (2.0 * math.pi * A * E_star)) ** (1.0 / 3.0)  # K S = (K - E)/e^2
    b = a * ca.exp(-u)
    p0 = 3.0 * N / (2.0 * math.pi * a * b)
    return a, b, p0, p0 * b * K / E_star


def pivot_lever(a, b):
    """Mean lever arm of the Hertz pressure about the patch centre, l = (1/N) int p rho dA [m].

    With x = a rho cos t, y = b rho sin t the integral separates: l = (3/32) P, P = 4 a E(1 - b^2/a^2) the
    ellipse's perimeter, so l = (3/8) a E(1 - b^2/a^2); 3 pi a/16 for a circle (Johnson [1] sec. 5.9 gives
    that circular case). A patch that slides in pure spin (pivots) transmits the moment mu N l.

    Parameters
    ----------
    a, b : contact semi-axes [m]

    Returns
    -------
    l : [m]
    """
    _, E = elliptic_KE(1.0 - (b / a) ** 2)
    return 0.375 * a * E
