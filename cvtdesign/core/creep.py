"""Tangential contact forces and the spin moment from creepage: Kalker's linear theory, saturated towards μN by
Polach's method.

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

  with s_C = √(ξ² + η_C²), η_C = η + φ a where that adds to |η|, else η. K_M simplifies exactly to
  −(2/3)|ε_M|/(1 + ε_M²)², so Fy_φ = −G (ab)^(3/2) C23 φ/(1 + ε_M²)² (spin_force): Kalker's linear spin term
  at small spin (in Kalker's sign convention; Polach prints the force on the other body), falling as the
  traction comes to circulate at large spin.

* Spin moment (spin_moment): Kalker's linear Mz = G (ab)^(3/2) (C23 η − √(ab) C33 φ), saturated by the same
  ratio towards the pivoting moment μN ℓ (1 − u²)^(1/4), ℓ the Hertz pressure's mean lever about the centre
  and u the creep force's utilisation: the moment a spinning patch transmits, which the model adds to the
  sphere's moment balance, so its loss reaches the shafts by the energy balance.

Every function takes floats or CasADi scalars (no Python branches on values), so the same expressions go
into the compiled model.
"""
from __future__ import annotations

import math

import casadi as ca

from cvtdesign.core.contact import pivot_lever

SPIN_SHAPE = 6.3          # Polach's empirical factor of the spin term's patch-shape correction k
TINY = 1e-30              # keeps square roots and ratios smooth at zero creepage
NEWTON_STEPS = 6          # of saturation_amplification (4 already reach machine precision)


def _smooth_abs(x):
    return ca.sqrt(x * x + TINY)


def saturation_ratio(eps):
    """|F|/|F_lin| of Polach's law at gradient ε ≥ 0: (ε/(1 + ε²) + arctan ε)/(2ε), 1 at ε = 0, → π/(4ε)."""
    e = ca.sqrt(eps * eps + TINY)
    return 0.5 * (1.0 / (1.0 + e * e) + ca.atan(e) / e)


def saturation_amplification(u):
    """The inverse of Polach's law for the creepage part: at utilisation u = |F|/(μN) < 1, the creepage over
    linear theory's creepage for the same force, 1/r = 2ε/(ε/(1 + ε²) + arctan ε) = 4 tan θ/(π u), where
    ε = tan θ solves θ + sin(2θ)/2 = πu/2 (the law in θ: concave, its derivative 2cos²θ). Newton's method,
    unrolled (NEWTON_STEPS), from πu/4 below u = 0.9 (an underestimate, from which Newton rises monotonically
    on a concave function, with no cancellation at small u) and from the asymptote π/2 − (3π(1 − u)/4)^(1/3)
    above: tan θ to machine precision for 0 ≤ u ≤ 1 − 1e-9 in 6 steps (5e-14 in 5). 1 at u = 0, → ∞ as
    u → 1."""
    y = 0.5 * math.pi * u
    theta = ca.if_else(u < 0.9, 0.25 * math.pi * u, 0.5 * math.pi - (0.75 * math.pi * ca.fabs(1.0 - u)) ** (1.0 / 3.0))
    for _ in range(NEWTON_STEPS):
        theta = theta - (theta + 0.5 * ca.sin(2.0 * theta) - y) / (2.0 * ca.cos(theta) ** 2)
    return 4.0 * ca.tan(theta) / (math.pi * ca.fmax(u, 1e-300))


def creep_forces(xi, eta, N, mu, a, b, G, C11, C22):
    """(Fx, Fy) [N] from longitudinal and lateral creepage, Kalker's linear law saturated by Polach's method
    (module docstring). N: normal force [N]; a, b: semi-axes [m]; G [Pa]."""
    fx, fy = G * a * b * C11 * xi, G * a * b * C22 * eta
    eps = (math.pi / 4.0) * ca.sqrt(fx * fx + fy * fy + TINY) / (mu * N)
    r = saturation_ratio(eps)
    return -fx * r, -fy * r


def spin_force(xi, eta, phi, N, mu, a, b, G, C23):
    """Fy [N] from spin φ [1/m] by Polach's method (module docstring), in the closed form
    Fy = −G (ab)^(3/2) C23 φ / (1 + ε_M²)²: Polach's K_M simplifies to −(2/3)|ε_M|/(1 + ε_M²)² (with
    δ = (ε_M² − 1)/(ε_M² + 1): δ³/3 − δ²/2 + 1/6 = (δ − 1)²(2δ + 1)/6 and 1 − δ² = 4ε_M²/(1 + ε_M²)²), and
    |ε_M|/s_C cancels against his φ/s_C. Linear theory at small spin; no division by s_C, no square root of a
    difference, so it is smooth for Newton."""
    k = 1.0 + SPIN_SHAPE * (1.0 - ca.exp(-a / b))
    eta_c = ca.if_else(_smooth_abs(eta + phi * a) > _smooth_abs(eta), eta + phi * a, eta)
    eps_m2 = ((8.0 / 3.0) * G * b * ca.sqrt(a * b) * C23 / (mu * N * k)) ** 2 * (xi * xi + eta_c * eta_c)
    return -G * (a * b) ** 1.5 * C23 * phi / (1.0 + eps_m2) ** 2


def spin_moment(eta, phi, N, mu, a, b, G, C23, C33, utilisation=0.0, lever=None):
    """Mz [N m] on body 1 about the patch normal, from lateral creepage η [-] and spin φ [1/m].

    Kalker's linear theory, Mz = G (ab)^(3/2) (C23 η − √(ab) C33 φ) (Kalker 1990, with C32 = −C23, so the
    coupling stores no energy and the loss is G (ab)² C33 φ² per unit rolling speed), saturated like the
    creep force: Mz = Mz_lin·saturation_ratio(ε), ε = (π/4)|Mz_lin|/M_max, towards the pivoting moment
    M_max = μN ℓ (1 − u²)^(1/4) (core.contact.pivot_lever), reduced as the creep force takes up the share
    u = |F|/(μN) of the traction bound. An engineering closure, not Polach's, checked against FASTSIM with the
    elliptic bound (tests/validation/test_spin_moment.py): pure spin reaches exactly μN ℓ and lies within
    0.11 μN ℓ of FASTSIM's curve; with creepage (u ≤ 0.75, a/b 0.5–2) within 0.18 μN ℓ, where the powers 0,
    1/2 and 1 of (1 − u²) are 0.25, 0.18 and 0.33 off; CONTACT's exact theory on its combined lateral + spin
    example: 13.8 % beyond its moment. `lever`: ℓ [m] where the caller has it already (the model scales the
    preload's ℓ with the patch, a ∝ N^(1/3), rather than solving the elliptic integral at every point)."""
    m_lin = G * (a * b) ** 1.5 * (C23 * eta - ca.sqrt(a * b) * C33 * phi)
    m_max = mu * N * (pivot_lever(a, b) if lever is None else lever) * (1.0 - utilisation * utilisation) ** 0.25
    return m_lin * saturation_ratio((math.pi / 4.0) * ca.sqrt(m_lin * m_lin + TINY) / m_max)


def polach_forces(xi, eta, phi, N, mu, a, b, G, C11, C22, C23):
    """(Fx, Fy) [N] on body 1 for creepages ξ, η [-] and spin φ [1/m]: creep_forces plus spin_force."""
    fx, fy = creep_forces(xi, eta, N, mu, a, b, G, C11, C22)
    return fx, fy + spin_force(xi, eta, phi, N, mu, a, b, G, C23)
