"""Closed forms from the two papers, as plain numpy functions, for the validation tests.

Kim et al., "Causes of microslip in a continuously variable transmission", ASME J. Mech. Des.:
the existing CVT's kinematics (eqs 5, 8), the steering-roller slip (eqs 19-24), the
drive-roller slip (eqs 25-31) and their sum (eq 32).
Brokowski et al., "Toward improved CVTs: theoretical and experimental results", IMECE2002-DSC-33680:
Gillespie's creep/spin
speed ratio (eqs 14-15), its sideslip angle (eq 17), k (eq 19) and the creep/spin efficiency (eq 22).

Units: angles [rad], torques [N m], radii [m], creep constants [1/N], forces [N]. Frames and signs are
Kim's (sec. 2.1; τ⊥ = −τ1 sin γ + τ2 cos γ, eq 17; α = atan2(ω2, ω1) − γ_cmd, eq 15).

Where a printed equation is inconsistent with the vectors it is derived from, the function implements
the corrected form and its docstring says what was changed and why; the tests in test_papers.py
show that the generalised model (cvtdesign.core.model) reproduces the corrected form, not the printed one.
"""
from __future__ import annotations

import numpy as np

S2 = np.sqrt(2.0)
D1 = np.array([1.0, 1.0, 0.0]) / S2
D2 = np.array([-1.0, 1.0, 0.0]) / S2
C1 = np.array([0.0, -1.0, 1.0]) / S2
C2 = np.array([0.0, -1.0, -1.0]) / S2
C3 = np.array([1.0, 0.0, 0.0])


def wrap_pi(x):
    """Wrap angles [rad] to [−π, π)."""
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def wrap_half_pi(x):
    """Wrap angles [rad] to [−π/2, π/2): the difference of two axis directions, which are defined modulo π."""
    return (np.asarray(x) + np.pi / 2) % np.pi - np.pi / 2


# --- kinematics (Kim sec. 2.1) ------------------------------------------------------------------------

def kim_gamma_from_phi(phi):
    """Kim eq 5: transmission angle γ [rad] of the existing CVT's steering angle φ [rad].

    γ = atan((√2 + tan φ)/(√2 − tan φ)), the principal value, in (−π/2, π/2): the axis angle is defined
    modulo π (γ and γ + π are the same axis), so compare it with other angles modulo π."""
    phi = np.asarray(phi, float)
    return np.arctan((S2 + np.tan(phi)) / (S2 - np.tan(phi)))


def kim_phi_from_gamma(gamma):
    """Kim eq 5 inverted: steering angle φ [rad] in (−π/2, π/2) that commands γ [rad].

    tan γ = (√2 + tan φ)/(√2 − tan φ)  ⇔  tan φ = √2 (tan γ − 1)/(tan γ + 1) = √2 tan(γ − π/4).
    For γ < −π/4 the principal value of φ corresponds to γ + π (φ wraps by π there)."""
    return np.arctan(S2 * np.tan(np.asarray(gamma, float) - np.pi / 4))


def ideal_ratio(gamma, r1=1.0, r2=1.0):
    """Kim eq 8, the ideal transmission law: ω2/ω1 = tan γ; with drive-roller radii r1, r2 [m]
    (rolling without slip, r1 ω1 = R Ω·d1, r2 ω2 = R Ω·d2) ω2/ω1 = (r1/r2) tan γ."""
    return (r1 / r2) * np.tan(np.asarray(gamma, float))


# --- steering-roller slip (Kim sec. 3.2, eqs 19-24) ----------------------------------------------------

def steering_lateral_force(tau_perp, gamma, phi, r_drive):
    """Kim eq 19-20: magnitude K [N] of the lateral force the sphere puts on each steering roller,

        K = τ⊥ cos γ / (r (√2 cos φ − sin φ)),   f⊥^S1 = K·(0, −cos φ, −sin φ) in (c1, c2, c3).

    Correction (a): the text says r is the steering-roller radius, but the lateral forces balance the
    moment of the drive rollers' tractive forces τ/r_D (Kim sec. 3.3 uses the same τ⊥ sin γ/r with
    r the drive radius), so r must be the DRIVE-roller radius (40 mm for the existing CVT). With the
    steering radius (38 mm) the slip angle comes out 40/38 − 1 = 5.3 % too large against the model
    (test_kim_eq19_radius_is_the_drive_radius).

    The printed denominator "r√2 cos φ − sin φ" is read as r(√2 cos φ − sin φ) (the dimensionally
    consistent reading); √2 cos φ − sin φ ∝ cos γ by eq 4, so K = τ⊥/(r √(2(1 + cos²φ))) up to sign.

    Parameters: tau_perp [N m], gamma [rad], phi [rad] (Kim eq 5 inverted), r_drive [m]."""
    return tau_perp * np.cos(gamma) / (r_drive * (S2 * np.cos(phi) - np.sin(phi)))


def steering_lateral_slip_angle(tau_perp, gamma, eps_s, r_drive, phi=None, omega_sign=1.0):
    """Kim eqs 21-22: lateral slip angle α⊥ [rad] of the steering rollers (α⊥^S1 = α⊥^S2).

    Printed: α⊥^S1 = ε_S K [(0, −ω_S sin φ, ω_S cos φ) × (0, −cos φ, −sin φ)]·c1 = ε_S K ω_S, which
    is not an angle (it has the units of ω_S). Correction (b): the cross product is there for the sign
    only, so the factor must be sgn(ω_S):

        α⊥ = ε_S K sgn(ω_S) = −ε_S K sgn(Ω·a_S1),

    because S1 rolls at ω_S about its axle a_S1 = cos φ c2 + sin φ c3 with r ω_S = −R Ω·a_S1 (eq 1).
    The sphere turns about u = cos γ d1 + sin γ d2 in the sense of ω1 (−π/2 < γ < π/2): Ω = sgn(ω1)|Ω| u,
    so sgn(Ω·a_S1) = sgn(ω1) sgn(u·a_S1).

    Parameters: tau_perp [N m], gamma [rad], eps_s [1/N], r_drive [m] (see steering_lateral_force),
    phi [rad] (default: Kim eq 5 inverted), omega_sign: sgn(ω1) (= sgn(ω∥) for −π/2 < γ < π/2)."""
    gamma = np.asarray(gamma, float)
    phi = kim_phi_from_gamma(gamma) if phi is None else np.asarray(phi, float)
    K = steering_lateral_force(tau_perp, gamma, phi, r_drive)
    u = np.cos(gamma)[..., None] * D1 + np.sin(gamma)[..., None] * D2
    a_s1 = np.cos(phi)[..., None] * C2 + np.sin(phi)[..., None] * C3
    return -eps_s * K * np.sign(omega_sign * np.sum(u * a_s1, axis=-1))


def kim_gamma_actual(phi, alpha_perp):
    """Kim eq 23: the sphere's actual axis γ_a = atan((√2 + tan(φ + α⊥))/(√2 − tan(φ + α⊥))) [rad],
    principal value (modulo π, like eq 5)."""
    return kim_gamma_from_phi(np.asarray(phi, float) + alpha_perp)


def steering_slip_angle(tau_perp, gamma, eps_s, r_drive, omega_sign=1.0):
    """Kim eqs 19-24: steering-roller slip angle α_SR [rad] at commanded γ [rad] and load τ⊥ [N m].

    Printed eq 24: α_SR = γ − γ_a. Correction (c): eq 15 defines α = γ_m − γ, eq 31 α_DR = γ_m − γ_a and
    eq 32 α = α_SR + α_DR, which together need α_SR = γ_a − γ (actual minus commanded axis, the
    sign of the "steering part"). Correction (d): γ_a from eq 23 and γ are axis angles, defined modulo
    π, and φ from eq 5 inverted wraps by π below γ = −45°, so the difference is taken modulo π.

    Uses eq 5 inverted (φ), eqs 19-22 as corrected in steering_lateral_slip_angle, eq 23;
    omega_sign = sgn(ω1)."""
    gamma = np.asarray(gamma, float)
    phi = kim_phi_from_gamma(gamma)
    a_perp = steering_lateral_slip_angle(tau_perp, gamma, eps_s, r_drive, phi, omega_sign)
    return wrap_half_pi(kim_gamma_actual(phi, a_perp) - gamma)


# --- drive-roller slip (Kim sec. 3.3, eqs 25-31) -------------------------------------------------------

def drive_slip_ratios(tau_perp, gamma, eps_d, r_drive, omega_par=1.0):
    """Kim eqs 27-28: longitudinal slip ratios (ψ1, ψ2) [-] of drive rollers D1 and D2,

        ψ1 = ε_D |τ⊥ sin γ / r| sgn(−ω∥ τ⊥ sin γ cos γ),   ψ2 = ε_D |τ⊥ cos γ / r| sgn(ω∥ τ⊥ sin γ cos γ),

    from the tractive forces −τ⊥ sin γ/r (D1) and τ⊥ cos γ/r (D2), r = drive-roller radius [m]."""
    s, c = np.sin(gamma), np.cos(gamma)
    psi1 = eps_d * np.abs(tau_perp * s / r_drive) * np.sign(-omega_par * tau_perp * s * c)
    psi2 = eps_d * np.abs(tau_perp * c / r_drive) * np.sign(omega_par * tau_perp * s * c)
    return psi1, psi2


def drive_slip_angle(tau_perp, gamma, eps_d, r_drive, gamma_a=None, omega_par=1.0):
    """Kim eqs 25-31: drive-roller slip angle α_DR = γ_m − γ_a [rad] (eq 31), where γ_m is the direction
    of (ω1, ω2) = (ω∥ cos γ (1 + ψ1), ω∥ sin γ (1 + ψ2)) (eqs 29-30) with ψ from eqs 27-28.

    γ is the angle used in eqs 27-30 (Kim's CVT angle); γ_a is the actual axis (default γ, i.e. rigid
    steering rollers); omega_par: ω∥ (only its sign matters). The difference is taken modulo π (for
    ω∥ < 0 the vector (ω1, ω2) points along γ_m ≈ γ + π)."""
    gamma = np.asarray(gamma, float)
    gamma_a = gamma if gamma_a is None else gamma_a
    psi1, psi2 = drive_slip_ratios(tau_perp, gamma, eps_d, r_drive, omega_par)
    gamma_m = np.arctan2(omega_par * np.sin(gamma) * (1 + psi2), omega_par * np.cos(gamma) * (1 + psi1))
    return wrap_half_pi(gamma_m - gamma_a)


def kim_slip_angle(tau_perp, gamma, eps_s, eps_d, r_drive, omega_sign=1.0):
    """Kim eq 32: modelled CVT slip angle α = α_SR + α_DR [rad] (α_SR with corrections (a)-(d));
    omega_sign = sgn(ω1) = sgn(ω∥) for −π/2 < γ < π/2."""
    return (steering_slip_angle(tau_perp, gamma, eps_s, r_drive, omega_sign)
            + drive_slip_angle(tau_perp, gamma, eps_d, r_drive, omega_par=omega_sign))


# --- Gillespie's creep/spin model (Brokowski sec. 2.2.2, eqs 14-19, 22) --------------------------------

def gillespie_k(b, R, r, mu, N):
    """Brokowski eq 19: k = (b/R)/(r μ N) [1/(N m)], b the contact half-width [m] (across the rolling
    direction), R sphere radius [m], r drive-roller radius [m], μ friction coefficient, N normal force [N]."""
    return (b / R) / (r * mu * N)


def gillespie_ratio(gamma, k, tau_perp):
    """Gillespie's speed ratio ω2/ω1 for −π/2 < γ < π/2 [rad], dissipative form:

        ω2/ω1 = (sin γ + k τ⊥ cos γ |cos γ|) / (cos γ − k τ⊥ sin γ |sin γ|),

    i.e. (sin γ + kτ⊥ cos²γ)/(cos γ − kτ⊥ sin²γ) for 0 < γ < π/2 and (sin γ + kτ⊥ cos²γ)/(cos γ + kτ⊥ sin²γ)
    for −π/2 < γ < 0. Shaft 2 is Brokowski's motor (T_m/b = ω_m/ω_b = tan γ), shaft 1 the brake, and
    Brokowski's t⊥ = t_m/cos γ = −t_b/sin γ (eqs 10-11) is Kim's τ⊥ (eq 17); ω1 > 0.

    Derivation (the model's drive_spin_creep): line contact of half-width b, slip velocity
    (b/(μN))·|Ω·n|·F_t at each drive roller, steering rollers rigid (τ∥ = 0, so F_t1 = −τ⊥ sin γ/r,
    F_t2 = τ⊥ cos γ/r). D1 touches at d2, where |Ω·n| = |Ω||sin γ|, and rolls r ω1 = R Ω·d1 + (b/(μN))|Ω·d2| F_t1;
    D2 likewise with |Ω·d1| = |Ω||cos γ|. Dividing gives the form above with k = b/(R r μ N) (eq 19).

    Which printed form it follows: the printed eq 15 (−π/2 < γ < 0) is this form. The printed eq 14
    (0 < γ < π/2), (sin γ − τ⊥k cos²γ)/(cos γ + τ⊥k sin²γ), is this form with τ⊥ → −τ⊥; as printed it would
    make the CVT a power source: τ1ω1 + τ2ω2 = τ⊥ ω1 (cos γ·ω2/ω1 − sin γ) < 0 for τ⊥ ≠ 0 (see
    gillespie_ratio_printed_eq14). The printed eq 17 (tan α, 0 < γ < π/2) follows from the dissipative
    form, not from the printed eq 14 (see gillespie_tan_alpha), which confirms a sign slip in eq 14."""
    s, c = np.sin(gamma), np.cos(gamma)
    return (s + k * tau_perp * c * np.abs(c)) / (c - k * tau_perp * s * np.abs(s))


def gillespie_ratio_printed_eq14(gamma, k, tau_perp):
    """Brokowski eq 14 exactly as printed (0 < γ < π/2): (sin γ − τ⊥ k cos²γ)/(cos γ + τ⊥ k sin²γ).
    Equals gillespie_ratio with τ⊥ → −τ⊥; non-dissipative (kept to show it is not what the model follows)."""
    s, c = np.sin(gamma), np.cos(gamma)
    return (s - tau_perp * k * c**2) / (c + tau_perp * k * s**2)


def gillespie_ratio_printed_eq15(gamma, k, tau_perp):
    """Brokowski eq 15 exactly as printed (−π/2 < γ < 0): (sin γ + τ⊥ k cos²γ)/(cos γ + τ⊥ k sin²γ)."""
    s, c = np.sin(gamma), np.cos(gamma)
    return (s + tau_perp * k * c**2) / (c + tau_perp * k * s**2)


def gillespie_tan_alpha(gamma, k, tau_perp):
    """Brokowski eq 17 (0 < γ < π/2): tan α = kτ⊥(sin³γ + cos³γ)/(1 + kτ⊥(cos²γ sin γ − sin²γ cos γ)),
    α = sideslip angle, tan(γ + α) = ω2/ω1 (eq 16). It is tan(atan(gillespie_ratio) − γ) exactly, i.e. it
    follows from the dissipative form of eqs 14-15."""
    s, c = np.sin(gamma), np.cos(gamma)
    return k * tau_perp * (s**3 + c**3) / (1 + k * tau_perp * (c**2 * s - s**2 * c))


def creep_spin_efficiency(gamma, alpha):
    """Brokowski eq 22: efficiency with only drive-roller creep/spin losses, power entering at the motor
    (shaft 2): η = tan γ / tan(γ + α) [-]."""
    return np.tan(gamma) / np.tan(gamma + alpha)
