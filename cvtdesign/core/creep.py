"""Tangential contact forces from creepage: Kalker's linear theory, saturated towards μN by Polach's method.

Conventions (Kalker, "Three-dimensional elastic bodies in rolling contact", 1990): an elliptical Hertz patch
with semi-axis a along the rolling direction x and b across it (y); creepages ξ (longitudinal), η (lateral),
dimensionless, and spin φ [1/m], each the rigid slip of body 1 over body 2 divided by the rolling speed;
(Fx, Fy) the tangential force on body 1 [N]. Kalker's linear theory, exact for small creepage:

    Fx = −G a b C11 ξ,    Fy = −G a b (C22 η + √(ab) C23 φ),

G the combined shear modulus, C11, C22, C23 Kalker's coefficients (core.contact.kalker_coefficients).

Saturation: Polach's method (O. Polach, "A fast wheel–rail forces calculation computer code", Vehicle System
Dynamics Suppl. 33, 1999, 728–739; and "Creep forces in simulations of traction vehicles running on
adhesion limit", Wear 258, 2005, 992–1000, with its reduction factors k_A = k_S = 1), chosen over FASTSIM
because it is a closed form: smooth enough for the model's Newton solves and exact derivatives for the
optimiser, at the cost of a FASTSIM grid's per-element saturation; tests/validation compares the two.

* Creepage part. ε = (π/4)|F_lin|/(μN), F_lin = G a b (C11 ξ, C22 η) the linear force, and

      |F| = (2μN/π) (ε/(1 + ε²) + arctan ε),

  Polach's gradient ε = (2/3) C π a² b s/(μN) with his C = (3/8)(G/a)|(C11 ξ, C22 η)|/s written through the
  linear force. The force keeps F_lin's direction (Polach takes the creepage's; the two agree for C11 = C22,
  and Kalker's theory has F_lin's), scaled by |F|/|F_lin| = (ε/(1 + ε²) + arctan ε)/(2ε): 1 at small
  creepage (linear theory), |F| → μN at large creepage.
* Spin part, added to Fy (Polach 1999 eqs for the lateral force from spin):

      Fy_φ = (9/16) a μN K_M k φ / s_C,      k = 1 + 6.3 (1 − exp(−a/b)),
      ε_M = (8/3) (G b √(ab))/(μN) · C23 s_C / k,      δ = (ε_M² − 1)/(ε_M² + 1),
      K_M = |ε_M| (δ³/3 − δ²/2 + 1/6) − √((1 − δ²)³)/3,

  with s_C = √(ξ² + η_C²), η_C = η + φ a where that adds to |η|, else η. At small spin K_M → −(2/3)|ε_M| and
  Fy_φ → −G (ab)^(3/2) C23 φ, Kalker's linear spin term (sign of Kalker's convention; Polach prints the force
  on the other body).

Every function takes floats or CasADi scalars (no Python branches on values), so the same expressions go
into the compiled model.
"""
from __future__ import annotations

import math

import casadi as ca

SPIN_SHAPE = 6.3          # Polach's empirical factor of the spin term's patch-shape correction k
TINY = 1e-30              # keeps square roots and ratios smooth at zero creepage


def _smooth_abs(x):
    return ca.sqrt(x * x + TINY)


def saturation_ratio(eps):
    """|F|/|F_lin| of Polach's law at gradient ε ≥ 0: (ε/(1 + ε²) + arctan ε)/(2ε), 1 at ε = 0, → π/(4ε)."""
    e = ca.sqrt(eps * eps + TINY)
    return 0.5 * (1.0 / (1.0 + e * e) + ca.atan(e) / e)


def creep_forces(xi, eta, N, mu, a, b, G, C11, C22):
    """(Fx, Fy) [N] from longitudinal and lateral creepage, Kalker's linear law saturated by Polach's method
    (module docstring). N: normal force [N]; a, b: semi-axes [m]; G [Pa]."""
    fx, fy = G * a * b * C11 * xi, G * a * b * C22 * eta
    eps = (math.pi / 4.0) * ca.sqrt(fx * fx + fy * fy + TINY) / (mu * N)
    r = saturation_ratio(eps)
    return -fx * r, -fy * r


def spin_force(xi, eta, phi, N, mu, a, b, G, C23):
    """Fy [N] from spin φ [1/m] by Polach's method (module docstring); −G (ab)^(3/2) C23 φ at small spin."""
    k = 1.0 + SPIN_SHAPE * (1.0 - ca.exp(-a / b))
    eta_c = ca.if_else(_smooth_abs(eta + phi * a) > _smooth_abs(eta), eta + phi * a, eta)
    s_c = ca.sqrt(xi * xi + eta_c * eta_c + TINY)
    eps_m = (8.0 / 3.0) * G * b * ca.sqrt(a * b) / (mu * N) * C23 * s_c / k
    e2 = eps_m * eps_m
    d = (e2 - 1.0) / (e2 + 1.0)
    K_m = _smooth_abs(eps_m) * (d ** 3 / 3.0 - d ** 2 / 2.0 + 1.0 / 6.0) - ca.sqrt((1.0 - d * d) ** 3) / 3.0
    return (9.0 / 16.0) * a * mu * N * K_m * k * phi / s_c


def polach_forces(xi, eta, phi, N, mu, a, b, G, C11, C22, C23):
    """(Fx, Fy) [N] on body 1 for creepages ξ, η [-] and spin φ [1/m]: creep_forces plus spin_force."""
    fx, fy = creep_forces(xi, eta, N, mu, a, b, G, C11, C22)
    return fx, fy + spin_force(xi, eta, phi, N, mu, a, b, G, C23)
