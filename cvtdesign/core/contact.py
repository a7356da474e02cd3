"""Contact physics: Hertz elliptical contact and Kalker's linear creep theory.

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
import numpy as np

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


# Kalker's creep coefficients, Kalker [2] table E.3, transcribed from CONTACT's src/m_hertz.f90
# (subroutine linrol, data cij) [3], repository eve70a/CONTACT, commit 0ecc556aed75519a9ea9971d0b30badb35824f13.
# Rows: a/b = 0.1, 0.2, ..., 1.0 followed by b/a = 0.9, 0.8, ..., 0.1 (the a/b = 1 row appears once).
# Columns: C11 (nu = 0, 0.25, 0.5), C22 (nu = 0, 0.25, 0.5), C23 (nu = 0, 0.25, 0.5).
KALKER_NU = np.array([0.0, 0.25, 0.5])
KALKER_A_OVER_B = np.concatenate([np.arange(1, 11) / 10.0, 1.0 / (np.arange(9, 0, -1) / 10.0)])
KALKER_TABLE = np.array([
    [2.51, 3.31, 4.85, 2.51, 2.52, 2.53, .334, .473, .731],
    [2.59, 3.37, 4.81, 2.59, 2.63, 2.66, .483, .603, .809],
    [2.68, 3.44, 4.80, 2.68, 2.75, 2.81, .607, .715, .889],
    [2.78, 3.53, 4.82, 2.78, 2.88, 2.98, .720, .823, .977],
    [2.88, 3.62, 4.83, 2.88, 3.01, 3.14, .827, .929, 1.07],
    [2.98, 3.72, 4.91, 2.98, 3.14, 3.31, .930, 1.03, 1.18],
    [3.09, 3.81, 4.97, 3.09, 3.28, 3.48, 1.03, 1.14, 1.29],
    [3.19, 3.91, 5.05, 3.19, 3.41, 3.65, 1.13, 1.25, 1.40],
    [3.29, 4.01, 5.12, 3.29, 3.54, 3.82, 1.23, 1.36, 1.51],
    [3.40, 4.12, 5.20, 3.40, 3.67, 3.98, 1.33, 1.47, 1.63],  # a/b = 1
    [3.51, 4.22, 5.30, 3.51, 3.81, 4.16, 1.44, 1.59, 1.77],  # b/a = 0.9
    [3.65, 4.36, 5.42, 3.65, 3.99, 4.39, 1.58, 1.75, 1.94],
    [3.82, 4.54, 5.58, 3.82, 4.21, 4.67, 1.76, 1.95, 2.18],
    [4.06, 4.78, 5.80, 4.06, 4.50, 5.04, 2.01, 2.23, 2.50],
    [4.37, 5.10, 6.11, 4.37, 4.90, 5.56, 2.35, 2.62, 2.96],  # b/a = 0.5
    [4.84, 5.57, 6.57, 4.84, 5.48, 6.31, 2.88, 3.24, 3.70],
    [5.57, 6.34, 7.34, 5.57, 6.40, 7.51, 3.79, 4.32, 5.01],
    [6.96, 7.78, 8.82, 6.96, 8.14, 9.79, 5.72, 6.63, 7.89],
    [10.7, 11.7, 12.9, 10.7, 12.8, 16.0, 12.2, 14.6, 18.0],  # b/a = 0.1
])
# C33, the spin-moment coefficient (Kalker [2] defines it; CONTACT [3] ships no table of it): computed for this
# package with CONTACT's exact theory [3] (the commit above; module 3, Hertzian patch, pure spin creepage 1e-8
# 1/m, grids of 24, 48 and 96 elements along each semi-axis, Richardson-extrapolated in the element size),
# C33 = -Mz/(G (ab)^2 phi), at the nodes and Poisson ratios of KALKER_TABLE; the same runs give C23 within
# 1.5 % of KALKER_TABLE. The 96-element values lie within 5 % of the extrapolated ones for a/b <= 2, 7 % at
# 2.5, 16 % at 3.3, 40 % at 5 and up to a factor 3 at 10 (nu = 0.5): C33 is well determined up to about
# a/b = 2.5 (the CVTs' patches have a/b near 1.6) and increasingly uncertain on longer patches.
KALKER_C33 = np.array([
    [ 6.44,  8.32,  11.7],
    [ 3.47,  4.29,  5.68],
    [  2.5,  2.98,  3.73],
    [ 2.04,  2.34,   2.8],
    [ 1.76,  1.95,  2.24],
    [ 1.57,  1.69,  1.87],
    [ 1.44,  1.51,  1.62],
    [ 1.35,  1.39,  1.43],
    [ 1.29,  1.29,   1.3],
    [ 1.23,  1.21,  1.18],  # a/b = 1
    [ 1.18,  1.13,  1.08],
    [ 1.12,  1.05, 0.968],
    [ 1.07,  0.98, 0.865],
    [ 1.02, 0.907, 0.763],
    [0.976, 0.834, 0.661],  # b/a = 0.5
    [0.934, 0.764, 0.562],
    [0.883, 0.686, 0.455],
    [0.843, 0.612, 0.349],
    [0.811, 0.533, 0.226],  # b/a = 0.1
])
_LOG_NODES = np.log(KALKER_A_OVER_B)
_COLUMNS = np.hstack([KALKER_TABLE, KALKER_C33])      # C11, C22, C23, C33, each at nu = 0, 0.25, 0.5


def _ramp_weights(values):
    """Weights d of the piecewise-linear interpolant y0 + sum_i d_i max(x - x_i, 0) on _LOG_NODES."""
    slopes = np.diff(values) / np.diff(_LOG_NODES)
    return ca.DM(np.concatenate([[slopes[0]], np.diff(slopes)]))


_KALKER_RAMPS = [[(_COLUMNS[0, 3 * i + j], _ramp_weights(_COLUMNS[:, 3 * i + j])) for j in range(3)]
                 for i in range(4)]
_RAMP_NODES = ca.DM(_LOG_NODES[:-1])


def kalker_coefficients(a_over_b, nu):
    """Kalker's linear creep coefficients C11, C22, C23 and C33 of an elliptical contact.

    C11, C22, C23 from table E.3 of Kalker [2] (as in CONTACT's m_hertz.f90 [3], :data:`KALKER_TABLE`),
    C33 from CONTACT's exact theory (:data:`KALKER_C33`). Interpolated piecewise-linearly in log(a/b)
    (clamped to 0.1 <= a/b <= 10), then in nu as CONTACT does: 1/C quadratic in nu through the columns
    nu = 0, 0.25, 0.5 (nu clamped to [0, 0.5]), which follows Kalker's asymptotes, where C ~ 1/(1 - nu).
    At the table nodes the table values are returned.

    Parameters
    ----------
    a_over_b : ratio of the semi-axis in the rolling direction to the lateral one [-]
    nu : combined Poisson ratio, see :func:`contact_material` [-]

    Returns
    -------
    C11, C22, C23, C33 : [-]
    """
    x = ca.fmin(ca.fmax(ca.log(a_over_b), _LOG_NODES[0]), _LOG_NODES[-1])
    ramps = ca.fmax(x - _RAMP_NODES, 0.0)
    v = ca.fmin(ca.fmax(nu, 0.0), 0.5)
    lagrange = (8.0 * (v - 0.25) * (v - 0.5), -16.0 * v * (v - 0.5), 8.0 * v * (v - 0.25))
    return tuple(1.0 / sum(w / (y0 + ca.dot(d, ramps)) for w, (y0, d) in zip(lagrange, _KALKER_RAMPS[i]))
                 for i in range(4))


def creep_compliances(G, a, b, C11, C22):
    """Creepage per unit tangential force from Kalker's linear law.

    Fx = -G a b C11 xi, Fy = -G a b C22 eta (Kalker [2]); xi, eta = slip velocity / rolling speed.
    Hence |xi|/|Fx| = 1/(G a b C11), |eta|/|Fy| = 1/(G a b C22).

    Parameters
    ----------
    G : combined shear modulus [Pa]
    a, b : contact semi-axes along and across the rolling direction [m]
    C11, C22 : Kalker coefficients, see :func:`kalker_coefficients` [-]

    Returns
    -------
    eps_long, eps_lat : longitudinal and lateral creep compliance [1/N]
    """
    Gab = G * a * b
    return 1.0 / (Gab * C11), 1.0 / (Gab * C22)


def spin_force_coefficient(G, a, b, C23):
    """Lateral force per unit spin creepage, G (ab)^(3/2) C23: Fy = -G (ab)^(3/2) C23 phi (Kalker [2]).

    Parameters
    ----------
    G : combined shear modulus [Pa]
    a, b : contact semi-axes [m]
    C23 : Kalker spin coefficient, see :func:`kalker_coefficients` [-]

    Returns
    -------
    coefficient : [N m] (phi = spin / rolling speed [1/m])
    """
    return G * (a * b) ** 1.5 * C23


def spin_moment_coefficient(G, a, b, C33):
    """Spin moment per unit spin creepage, G (ab)^2 C33: Mz = -G (ab)^2 C33 phi (Kalker [2]).

    Parameters
    ----------
    G : combined shear modulus [Pa]
    a, b : contact semi-axes [m]
    C33 : Kalker spin-moment coefficient, see :func:`kalker_coefficients` [-]

    Returns
    -------
    coefficient : [N m^2] (phi = spin / rolling speed [1/m])
    """
    return G * (a * b) ** 2 * C33


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

