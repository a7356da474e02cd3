"""Shaft kinematics derived from a layout's own rolling constraints: shaft axes, γ, the ideal law and α.

Nothing here refers to a fixed frame. A drive roller p of shaft s that rolls without slip turns at
r_p ω_p = −R Ω·a_p (a_p its declared positive spin axis, R the sphere radius, r_p its rolling radius), and
ω_p = ρ_p ω_s, so the shaft speed is a linear function of the sphere's angular velocity Ω:

    ω_s = g_s·Ω,   g_s = −R a_p / (ρ_p r_p)        (the shaft's *gain vector*, from its first drive roller)

Its direction e_s = g_s/|g_s| is the shaft's axis on the sphere, signed by the way the axle is declared.
The axis plane is spanned by e_1 and e_2, with the orthonormal basis

    u_1 = e_1,   u_2 = (e_2 − c e_1)/s,   c = e_1·e_2 = cos θ_12,   s = sin θ_12 > 0,

and every rigid motion the drive rollers allow has its axis in that plane (a drive roller's lateral
constraint Ω·t_p = 0 has t_p ⊥ a_p, so both e_1 and e_2 satisfy both drive rollers' constraints whenever
the drive rollers agree on one axis plane, which the layout checks require). Then:

* transmission angle of an axis Ω: γ = atan2(Ω·u_2, Ω·u_1); the commanded axis is u(γ) = cos γ u_1 + sin γ u_2;
* ideal law: ω2/ω1 = (g_2·u)/(g_1·u) = k (c + s tan γ), k = |g_2|/|g_1|;
* apparent axis angle from shaft speeds (the axis in the plane that the speeds would give without slip):
  γ_ω = atan2(ω2/k − c ω1, s ω1); slip angle α = γ_ω − γ_cmd, steering part γ_axis − γ_cmd, drive part the
  rest (all wrapped to ±90°: an axis is a line);
* loads: with the shaft-torque vector T = τ1 e_1 + τ2 e_2, the lateral torque τ⊥ = T·m(γ), m = −sin γ u_1 +
  cos γ u_2, and the parallel torque τ∥ = T·u(γ).

For Kim's existing CVT (shaft 1's roller at R·d2 with axle −d1, shaft 2's at R·d1 with axle −d2) this is
e_1 = d1, e_2 = d2, c = 0, s = 1, k = r1/r2, and every formula reduces to Kim et al., "Causes of microslip
in a continuously variable transmission": γ = atan2(Ω·d2, Ω·d1), ω2/ω1 = (r1/r2) tan γ (eq 8),
α = atan2(ω2 r2/r1, ω1) − γ_cmd (eqs 15, 35) and τ⊥ = −τ1 sin γ + τ2 cos γ, τ∥ = τ1 cos γ + τ2 sin γ
(eq 17). A rotated copy of a layout, or one with an axle declared the other way, is the same machine: its
figures are the same, with (γ, τ⊥, α) → (−γ, −τ⊥, −α) when shaft 2's sense is reversed.

The functions accept floats, numpy arrays or CasADi expressions alike.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from cvtdesign.errors import InputError


def _symbolic(*xs) -> bool:
    return any(isinstance(x, (ca.SX, ca.MX, ca.DM)) for x in xs)


def _sin(x):
    return ca.sin(x) if _symbolic(x) else np.sin(x)


def _cos(x):
    return ca.cos(x) if _symbolic(x) else np.cos(x)


def _atan2(y, x):
    return ca.atan2(y, x) if _symbolic(y, x) else np.arctan2(y, x)


def wrap_axis_angle(x):
    """An angle between two axis directions, wrapped to [−π/2, π/2] [rad]: an axis is a line."""
    return _atan2(_sin(2 * x), _cos(2 * x)) / 2


@dataclass(frozen=True)
class ShaftFrame:
    """The axis plane of a layout and its ideal-law constants (floats, or CasADi expressions when the layout
    depends on design symbols). u1, u2: orthonormal basis of the axis plane (u1 along shaft 1's axis);
    k = |g_2|/|g_1|; c, s: cosine and sine of the angle from shaft 1's axis to shaft 2's."""
    u1: object
    u2: object
    k: object
    c: object
    s: object

    def axis(self, gamma):
        """Commanded axis u(γ) = cos γ u1 + sin γ u2: a CasADi column for a symbolic γ or frame, else a numpy
        array of shape γ.shape + (3,)."""
        if _symbolic(gamma, self.u1):
            return ca.cos(gamma) * vec(self.u1) + ca.sin(gamma) * vec(self.u2)
        g = np.asarray(gamma, float)[..., None]
        return np.cos(g) * self.u1 + np.sin(g) * self.u2

    def axis_angle(self, omega):
        """γ [rad] of a sphere angular velocity: numpy (..., 3) or a CasADi 3-vector."""
        if _symbolic(omega):
            return ca.atan2(ca.dot(omega, self.u2), ca.dot(omega, self.u1))
        omega = np.asarray(omega, float)
        return np.arctan2(omega @ np.asarray(self.u2, float), omega @ np.asarray(self.u1, float))

    def ideal_ratio(self, gamma):
        """Ideal speed ratio ω2/ω1 = k (c + s tan γ) at commanded γ [rad]."""
        return self.k * (self.c + self.s * _sin(gamma) / _cos(gamma))

    def command_for_ratio(self, rho):
        """γ [rad] in (−90°, 90°) at which the ideal law gives the speed ratio ω2/ω1 = ρ."""
        return _atan2(rho / self.k - self.c, self.s)

    def speed_angle(self, omega_1, omega_2):
        """Apparent axis angle γ_ω [rad] from shaft speeds: the axis that turns the shafts at these speeds
        without slip."""
        return _atan2(omega_2 / self.k - self.c * omega_1, self.s * omega_1)

    def slip_angle(self, omega_1, omega_2, gamma_cmd):
        """CVT slip angle α = γ_ω − γ_cmd [rad], wrapped to ±π/2 (Kim eq 15 for Kim's layout)."""
        return wrap_axis_angle(self.speed_angle(omega_1, omega_2) - gamma_cmd)

    def load_split(self, gamma, tau_1, tau_2):
        """(τ⊥, τ∥) [N m]: the shaft-torque vector τ1 e1 + τ2 e2 across and along the commanded axis."""
        sg, cg = _sin(gamma), _cos(gamma)
        return (-tau_1 * sg + tau_2 * (self.s * cg - self.c * sg),
                tau_1 * cg + tau_2 * (self.c * cg + self.s * sg))

    def law_text(self) -> str:
        """The ideal law in words, e.g. 'ω2/ω1 = 1 · tan γ' or 'ω2/ω1 = 0.667 · (0.5 + 0.866 tan γ)'."""
        k, c, s = (float(v) for v in (self.k, self.c, self.s))
        if abs(c) < 1e-12:
            return f"ω2/ω1 = {k:.4g} · tan γ"
        return f"ω2/ω1 = {k:.4g} · ({c:.4g} + {s:.4g} tan γ)  (shaft axes {np.degrees(np.arccos(c)):.4g}° apart)"


def vec(x):
    """A 3-vector (numpy array, list or CasADi expression) as a CasADi column."""
    return ca.vec(ca.DM(x)) if isinstance(x, np.ndarray) else ca.vec(x)


def shaft_gain(layout, shaft: int):
    """Gain vector g_s [-] with ω_s = g_s·Ω at no slip, from the shaft's first drive roller (CasADi column)."""
    p = next((r for r in layout.rollers if r.role == "drive" and r.shaft == shaft), None)
    if p is None:
        raise InputError(f"{layout.file}: rollers: no drive roller on shaft {shaft} (role: drive, shaft: {shaft})")
    return -layout.sphere_radius * vec(p.axle) / (p.ratio * p.radius)


def shaft_frame(layout) -> ShaftFrame:
    """The layout's ShaftFrame: numeric (numpy/float) for a numeric layout, CasADi for a symbolic one."""
    g1, g2 = shaft_gain(layout, 1), shaft_gain(layout, 2)
    n1, n2 = ca.norm_2(g1), ca.norm_2(g2)
    e1, e2 = g1 / n1, g2 / n2
    c = ca.dot(e1, e2)
    w = e2 - c * e1
    s = ca.norm_2(w)
    parts = [_numeric(p) for p in (e1, w / s, n2 / n1, c, s)]
    if not isinstance(parts[4], ca.SX) and not parts[4] > 1e-6:
        raise InputError(f"{layout.file}: rollers: shafts 1 and 2 turn about the same axis (their drive "
                         "rollers' axles are parallel), so the speed ratio cannot change")
    return ShaftFrame(*parts)


def _numeric(x):
    """x as a float or numpy vector when it holds no symbols (so numpy callers can use it), else as is."""
    if isinstance(x, ca.DM) or (isinstance(x, ca.SX) and x.is_constant()):
        v = np.asarray(ca.evalf(x), float).ravel()
        return float(v[0]) if v.size == 1 else v
    return x
