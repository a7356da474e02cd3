"""A hand-written reference model of Kim's existing CVT, independent of cvtdesign (nothing imported from it).

Kim et al., "Causes of microslip in a continuously variable transmission", sec. 2: the layout and its vectors.

In the manner of PyBaMM's hand-written "basic" models that are cross-checked against the composed ones:
the equations of the existing CVT's four contacts are written out by hand here, with Kim's vectors, in
numpy, and solved point by point with scipy.optimize.root. Only the effects of variants/existing_kim.yaml are
included: drive_longitudinal_creep (Kim ε_D) and steering_lateral_creep (Kim ε_S). The drive rollers may
have different radii r_1, r_2 (variants/unequal_kim.yaml), which Kim's layout allows.

Contacts (outward normal n, axle a, rolling direction t = n × a):
    D1 (shaft 1, radius r_1): n = d2, a = −d1          D2 (shaft 2, radius r_2): n = d1, a = −d2
    S1 (idler, radius r_S):   n = c1, a = cos φ c2 + sin φ c3
    S2 (idler, radius r_S):   n = c2, a = cos φ c1 + sin φ c3
with φ from Kim eq 5 inverted, tan φ = √2 tan(γ_cmd − π/4).

Unknowns (14): sphere angular velocity Ω (3), shaft-2 speed ω2, the steering rollers' speeds ω_S1, ω_S2,
and the tangential force on the sphere at each contact, F = F_t t + F_a a (8).
Equations (14):
    creep law, per contact and direction:   s·t + c_t F_t = 0,   s·a + c_a F_a = 0,
        s = R Ω × n − r ω t (slip velocity of the sphere over the roller), V = |R Ω·a| (rolling speed),
        c_t = ε_D V on drive rollers, c_a = ε_S V on steering rollers, and a rigid floor eps_rigid·V_ref
        [m/(N s)] (V_ref = |ω1| r_1) added to every direction (it keeps the statically indeterminate split
        of the drive rollers' axial forces regular: a numerical regularisation, not physics; the package
        documents the same 1e-9 1/N floor, written here by hand, not imported);
    sphere moment balance:                 Σ R n × F = 0 (3);
    idler torque balance:                  F_t = 0 at S1 and S2 (2);
    load:                                  −τ1 sin γ_cmd + τ2 cos γ_cmd = τ⊥, τ_s = r_s F_t of shaft s's roller (1).
Outputs (Kim eqs 8, 15, 17 with the radius ratio): α = atan2(ω2 r_2/r_1, ω1) − γ_cmd, γ_axis = atan2(Ω·d2, Ω·d1),
α_steering = γ_axis − γ_cmd, α_drive = α − α_steering.
"""
from __future__ import annotations

import numpy as np
from scipy import optimize

from kim_closed_forms import C1, C2, C3, D1, D2, S2  # Kim's vectors, written by hand there too
EPS_RIGID = 1e-9      # [1/N] compliance floor of the rigid directions (a regularisation, see above)


def _wrap(x):
    return np.arctan2(np.sin(x), np.cos(x))


class ExistingCVT:
    """Kim's existing CVT with Kim's creep constants; all quantities SI.

    R: sphere radius [m]; r_drive: shaft 1's drive-roller radius [m]; r_drive_2: shaft 2's (default
    r_drive); r_steer: steering-roller radius [m]; eps_d, eps_s: Kim's ε_D, ε_S [1/N]; eps_rigid: compliance
    floor of the rigid directions [1/N]."""

    def __init__(self, R=0.0635, r_drive=0.040, r_steer=0.038, eps_d=0.0038, eps_s=0.0049, eps_rigid=EPS_RIGID,
                 r_drive_2=None):
        self.R, self.r_drive, self.r_steer, self.eps_d, self.eps_s = R, r_drive, r_steer, eps_d, eps_s
        self.r_drive_2 = r_drive if r_drive_2 is None else r_drive_2
        self.eps_rigid = eps_rigid

    def contacts(self, phi):
        """Contact geometry at steering angle φ [rad], rows D1, D2, S1, S2: normals n (4, 3), axles a (4, 3),
        rolling directions t = n × a (4, 3), radii r (4,), and masks of the drive and steering rows."""
        a_s1 = np.cos(phi) * C2 + np.sin(phi) * C3
        a_s2 = np.cos(phi) * C1 + np.sin(phi) * C3
        n = np.array([D2, D1, C1, C2])
        a = np.array([-D1, -D2, a_s1, a_s2])
        r = np.array([self.r_drive, self.r_drive_2, self.r_steer, self.r_steer])
        drive = np.array([True, True, False, False])
        return n, a, np.cross(n, a), r, drive

    def residual(self, x, gamma, omega1, tau_perp, geometry):
        """Scaled residual of the 14 equations; x = (Ω/Ω_ref, ω2/ω1, ω_S1/ω1, ω_S2/ω1, F_t/F_s, F_a/F_s)
        with Ω_ref = ω1 r_D/R, F_s = 10 N; geometry = self.contacts(φ)."""
        n, a, t, r, drive = geometry
        R = self.R
        v_ref = omega1 * self.r_drive
        om_ref, f_s = v_ref / R, 10.0
        Om = om_ref * x[0:3]
        speeds = omega1 * np.array([1.0, x[3], x[4], x[5]])          # roller speeds about their axles
        Ft, Fa = f_s * x[6:10], f_s * x[10:14]
        s = R * np.cross(Om, n) - (r * speeds)[:, None] * t           # slip velocity, one row per contact
        V = np.abs(R * a @ Om)                                         # rolling speed
        floor = self.eps_rigid * abs(v_ref)                            # a compliance: never negative
        c_t = np.where(drive, self.eps_d * V, 0.0) + floor            # Kim ε_D: drive, longitudinal
        c_a = np.where(drive, 0.0, self.eps_s * V) + floor            # Kim ε_S: steering, lateral
        creep_t = (np.sum(s * t, axis=1) + c_t * Ft) / v_ref
        creep_a = (np.sum(s * a, axis=1) + c_a * Fa) / v_ref
        F = Ft[:, None] * t + Fa[:, None] * a
        moment = R * np.sum(np.cross(n, F), axis=0)                   # Σ R n × F
        tau1, tau2 = self.r_drive * Ft[0], self.r_drive_2 * Ft[1]
        load = -tau1 * np.sin(gamma) + tau2 * np.cos(gamma) - tau_perp
        return np.concatenate([creep_t, creep_a, moment / (R * f_s), Ft[2:] / f_s, [load]])

    def initial_guess(self, gamma, omega1, geometry):
        """Ideal kinematics about the commanded axis u = cos γ d1 + sin γ d2, no forces."""
        _, a, _, r, _ = geometry
        u = np.cos(gamma) * D1 + np.sin(gamma) * D2
        om_ref = omega1 * self.r_drive / self.R
        Om = u * omega1 * self.r_drive / (self.R * (u @ D1))          # ω1 = (R/r) Ω·d1
        x = np.zeros(14)
        x[0:3] = Om / om_ref
        x[3:6] = -self.R * (a[1:] @ Om) / (r[1:] * omega1)              # r ω = −R Ω·a (D2, S1, S2)
        return x

    def solve(self, gamma, tau_perp, omega1=10.0):
        """One operating point: commanded γ [rad], load τ⊥ [N m], shaft-1 speed ω1 [rad/s].

        Returns a dict of alpha, alpha_steering, alpha_drive, gamma_axis, phi [rad], omega_2 [rad/s],
        tau_1, tau_2 [N m], F_t, F_a [N] (D1, D2, S1, S2), residual (max |scaled residual|)."""
        phi = np.arctan(S2 * np.tan(gamma - np.pi / 4))                # Kim eq 5 inverted
        geometry = self.contacts(phi)
        args = (gamma, omega1, tau_perp, geometry)
        sol = optimize.root(self.residual, self.initial_guess(gamma, omega1, geometry), args=args,
                            method="hybr", options={"xtol": 1e-14})
        x = sol.x
        res = np.max(np.abs(self.residual(x, *args)))
        R, v_ref = self.R, omega1 * self.r_drive
        Om = (v_ref / R) * x[0:3]
        omega2 = omega1 * x[3]
        Ft, Fa = 10.0 * x[6:10], 10.0 * x[10:14]
        gamma_axis = np.arctan2(Om @ D2, Om @ D1)
        alpha = _wrap(np.arctan2(omega2 * self.r_drive_2 / self.r_drive, omega1) - gamma)
        alpha_s = _wrap(gamma_axis - gamma)
        return dict(alpha=alpha, alpha_steering=alpha_s, alpha_drive=_wrap(alpha - alpha_s), gamma_axis=gamma_axis,
                    phi=phi, omega_2=omega2, tau_1=self.r_drive * Ft[0], tau_2=self.r_drive_2 * Ft[1],
                    F_t=Ft, F_a=Fa, residual=res)
