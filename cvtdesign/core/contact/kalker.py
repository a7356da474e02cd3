"""Kalker's linear theory of rolling contact: the creep coefficients C11, C22, C23 (and the spin-moment
coefficient C33) of an elliptical patch, and the linear creep constants they give.

Every function accepts Python floats as well as CasADi scalars (see core.contact.hertz).

References
----------
.. [2] J. J. Kalker, *Three-dimensional elastic bodies in rolling contact*, Kluwer, 1990, table E.3.
.. [3] E. A. H. Vollebregt, CONTACT, ``src/m_hertz.f90`` (subroutine ``linrol``),
       https://github.com/eve70a/CONTACT (Apache-2.0).
"""

import casadi as ca
import numpy as np

# Kalker's creep coefficients, Kalker [2] table E.3, transcribed from CONTACT's src/m_hertz.f90
# (subroutine linrol, data cij) [3], repository eve70a/CONTACT, commit 0ecc556aed75519a9ea9971d0b30badb35824f13.
# Rows: a/b = 0.1, 0.2, ..., 1.0 followed by b/a = 0.9, 0.8, ..., 0.1 (the a/b = 1 row appears once).
# Columns: C11 (nu = 0, 0.25, 0.5), C22 (nu = 0, 0.25, 0.5), C23 (nu = 0, 0.25, 0.5).
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
