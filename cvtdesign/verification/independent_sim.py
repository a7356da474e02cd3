"""An independently written steady-state simulator of Kim's existing spherical CVT, for testing the diagnosis on
rig-like data whose functional forms are not the package's own.

Physics from two papers, re-derived here without the package's model (this module imports numpy, scipy and
pandas only, nothing from cvtdesign):

* Kim et al., "Causes of microslip in a continuously variable transmission" (ASME J. Mech. Des.): the
  existing CVT's frames d1, d2, d3 and c1, c2, c3, its rollers and forks (sec. 2.1, eqs 1-5), the ideal
  law ω2/ω1 = tan γ (eq 8), the lateral and parallel torques τ⊥ = −τ1 sin γ + τ2 cos γ,
  τ∥ = τ1 cos γ + τ2 sin γ (eq 17), the steering rollers' lateral slip angle α⊥ = ε_S·F (eqs 19-24), the
  drive rollers' longitudinal slip ratio ψ = ε_D·F (eqs 25-31), fitted ε_S = 0.0049 1/N and
  ε_D = 0.0038 1/N at 100 N.
* Brokowski, Kim, Colgate, Gillespie, Peshkin, "Toward improved CVTs: theoretical and experimental
  results" (IMECE2002-DSC-33680): Gillespie's creep/spin model (slip growing with the contact's spin),
  rolling losses, normal-force variation and the unmodelled effects of its sec. 6.1.

The machine (Kim's existing CVT): sphere R = 63.5 mm; drive roller D1 (shaft 1, the motor, held at ω1) touches
at R·d2 with axle −d1, D2 (shaft 2, loaded) at R·d1 with axle −d2, both r = 40 mm; steering idlers S1 at R·c1
and S2 at R·c2, r_S = 38 mm, on forks turning about c1 (by +φ) and c2 (by −φ) coupled by a bevel gear: S1's
axle cos φ c2 + sin φ c3, S2's cos φ c1 + sin φ c3 (Kim eqs 1-2). Preload P = 100 N per contact, μ = 0.8. The
steering angle of a commanded γ is Kim eq 5 inverted, on the linkage's continuous branch
φ = atan2(√2 sin(γ − 45°), cos(γ − 45°)) (φ from −116° at γ = −80° to +45° at γ = 80°; the idlers never
reverse, so a fork's deflection has one physical sense over the whole range).

Formulation (this module's own; not the package's). A roller of radius r turning at w about its axle a,
touching at R·n, has rolling direction t = n × a; its surface moves at v_r = r·w along t, the sphere's at
v_s = −R Ω·a along t and R Ω·t along a. Slips (sphere minus roller): s_t = v_s − v_r, s_a = R Ω·t. F_t, F_a
are the tangential forces on the sphere along t and a. Unknowns per operating point (14): Ω (3), ω2, the
idler speeds w_S1, w_S2 and (F_t, F_a) at the four contacts. Equations (14), solved by a damped Newton
iteration (finite-difference Jacobian, all operating points at once); a point that fails it is retried by
continuation in the load, then with scipy.optimize.root:

* sphere moment balance Σ R n × F = 0 (3); the normal forces pass through the centre, and resisting torques
  act on the rollers' axles and are reacted by the frame, so nothing else acts on the sphere;
* drive rollers, along t: s_t + slip(F_t) = 0, the creep law of the effects that are on (rigid s_t = 0 when
  none) (2);
* drive rollers, along a: rigid (as in Kim). The two constraints are the same one (both say Ω·d3 = 0), so the
  lateral forces are closed by the drive mounts' symmetry, F_a,D1 + F_a,D2 = 0 (the limit of equal lateral
  compliances) (2);
* steering idlers, along t: free rolling, s_t = 0 (gives w_S) (2), and the idler's torque balance
  −r_S F_t + M = 0 with M its resisting torque (2);
* steering idlers, along a: creep laws s_a + slip(F_a) = 0, written as their difference and as their sum
  divided by the mean lateral compliance (the sum is identically F_a,S1 + F_a,S2 when the forks agree, which
  closes the rigid case exactly) (2);
* the load: −τ1 sin γ + τ2 cos γ = τ⊥ with τ_s = r_s F_t,s − M_s (the external shaft torque, positive in the
  sense of positive ω, power in τ·ω) (1).

Normal forces: the sphere's force balance on equally stiff preloaded mounts, Σ(−N_i n_i + F_i) = 0 with
N_i = P + k n_i·δ, gives in closed form N_i = P + n_i·M⁻¹ΣF, M = Σ n_i n_iᵀ = diag(1, 2, 1) (Σ n_i = 0 for
this layout), independent of the stiffness k. The physics checks always use these N. The contact laws
(creep compliance, spin sliding, saturation, rolling resistance) follow the preload P, or these N when
normal_force_variation is on.

The rig that measures it (Kim's protocol, noise, sequences) and the self-check's cases built on it are
independent_rig.py.

Outputs per operating point: ω2, τ1, τ2, the axis angle γ_axis = atan2(Ω·d2, Ω·d1), and a status:
`ok`; `not_converged` (Newton, then continuation in the load, then scipy.optimize.root all failed; with
strong steering compliance this happens at |γ| = 80°, |τ⊥| ≈ 1 N·m, where the axis reaches the motor
roller's pole, γ_axis → ±90°, and holding ω1 would need Ω → ∞); `lost_contact` (some N ≤ 0);
`gross_slip` (some |F| > μN, or a law that levels off at μN needs |F| → μN). Only `ok` points carry
numbers; `simulate` (independent_rig.py) leaves the others out of the data and counts them.

Effects (name: strength [unit], then the form used here). Every creep law is dissipative (F·s ≤ 0).

In the diagnosis's vocabulary:

* drive_longitudinal_creep: multiplier k on Kim's ε_D [-]. Kim's slip ratio ψ = Δω/ω = k ε_D F against
  the free-rolling (sphere's) surface speed: s_t = −k ε_D |v_s| F_t. This is Kim's own definition
  (eqs 18, 25-30); defining it against the roller's speed instead is a second-order difference the
  diagnosis can see (≈ 2σ per point at Kim's loads, ψ up to 0.1), so it is offered separately, as
  the out-of-vocabulary `creep_reference`, and the base stays Kim's.
* steering_lateral_creep: multiplier k on Kim's ε_S [-]. A true slip ANGLE k ε_S F_a against the idler's
  surface speed: s_a = −|v_r| tan(k ε_S F_a) (Kim eqs 21-23 read literally; the package's law is linear
  in the slip velocity).
* drive_spin_creep: line-contact half-width a [m]. Gillespie's line contact with every point sliding and the
  slip varying across the line as s0 + (Ω·n)·y, but with an elliptical (Hertzian) pressure across the
  line instead of his uniform one (the refinement Brokowski sec. 6.1.2 asks for): F/(μN) =
  (2/π)(asin η + η√(1 − η²)), η = s0/(a|Ω·n|), i.e. a sliding velocity s0 = a|Ω·n|·η(F/(μN)) in series
  with the elastic creep (≈ (π/4)(a/(μN))|Ω·n|F at small load, levelling off at μN); a ∝ N^(1/3).
* normal_force_variation: exponent m [-] (Hertz + Kalker: 2/3). The contact laws follow the
  force-balanced N: elastic creep compliances × (N/P)^(−m), and spin, saturation and rolling resistance
  use N instead of P.
* rolling_resistance: coefficient C_rr [-]. A resisting torque C_rr·r·N on each roller's axle (urethane
  hysteresis and bearing drag, reacted by the frame, not the sphere: an idler then needs a tangential
  force C_rr·N from the sphere), in the sense of the roller's rotation smoothed over 0.01 rad/s.
* steering_offset: offset [rad] added to the common steering angle φ (both forks, through the bevel gear).
* drive_radius_mismatch: δ [-]; shaft 2's roller rolls (and transmits torque) on (1 + δ)·r.
* traction_saturation: multiplier on μ [-] (0.8). The creep force levels off towards μN as
  F = μN·(2/π)·atan((π/2)·creepage/(c μN)), i.e. the elastic compliances are multiplied by
  tan(πu/2)/(πu/2) with u = |F|/(μN) (|F| over both tangential directions); a point that needs u → 1 is
  gross slip.

Outside the vocabulary (the diagnosis has no such effect; right answer `unexplained`):

* fork_compliance: c_f [rad/N]. Each fork yaws under its idler's lateral force (the force's trail loads the
  fork about its axis): φ_S1 = φ + c_f sgn(w_S1) F_a,S1, φ_S2 = φ − c_f sgn(w_S2) F_a,S2, the sense in which
  each fork relieves its load. In the axis angle and α this is nearly the same as more lateral creep (Kim eq 23
  adds α⊥ to φ exactly as a yaw does, both ∝ the same force); but the yaw turns the idlers' force
  directions with it while creep does not, so the torques differ: τ∥ changes (creep is a flow loss and
  leaves τ∥ = 0). A base refit of ε_S absorbs most of the α part; the τ∥ part is what is left (see the
  table at CASES).
* speed_dependent_creep: κ [s/m]. Every elastic creep compliance grows with the roller's surface speed,
  × (1 + κ|v_r|) (viscoelastic urethane), so at ω1 fixed the creep of D2 and of the idlers grows with |γ|.
* viscous_loss (the model-form difference of this module's choosing): b [N·m·s/rad]. A hysteresis loss
  ∝ speed²: a resisting torque b·w on every roller's axle, proportional to its speed (rolling resistance
  in the vocabulary is ∝ N and does not depend on speed).
* creep_reference: λ [-] in [0, 1]. Creepage taken against (1 − λ)|v_s| + λ|v_r| instead of the sphere's
  speed (λ = 1: the roller's; λ = 0.5: Kalker's mean rolling speed).

Limits: the steering idlers' lateral creep closes the indeterminate lateral forces; without
steering_lateral_creep the forks must agree (no fork_compliance).

Units: SI inside (m, N, N·m, rad, rad/s); the data columns use degrees for angles.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import root

from cvtdesign.verification.newton import newton

# --------------------------------------------------------------------------------------------- the machine

R_SPHERE = 0.0635        # [m]
R_DRIVE = 0.040          # [m]
R_STEER = 0.038          # [m]
PRELOAD = 100.0          # [N] per contact
MU = 0.8                 # [-]
EPS_D = 0.0038           # [1/N] Kim's longitudinal slip constant (drive rollers)
EPS_S = 0.0049           # [1/N] Kim's lateral slip constant (steering rollers)
W_SIGN = 0.01            # [rad/s] smoothing of the sense of rotation in resisting torques

_S2 = np.sqrt(2.0)
D1 = np.array([1.0, 1.0, 0.0]) / _S2
D2 = np.array([-1.0, 1.0, 0.0]) / _S2
D3 = np.array([0.0, 0.0, 1.0])
C1 = np.array([0.0, -1.0, 1.0]) / _S2
C2 = np.array([0.0, -1.0, -1.0]) / _S2
C3 = np.array([1.0, 0.0, 0.0])
NORMALS = np.array([D2, D1, C1, C2])                    # contacts D1, D2, S1, S2
M_INV = np.linalg.inv(np.einsum("ki,kj->ij", NORMALS, NORMALS))   # (Σ n nᵀ)⁻¹ = diag(1, 1/2, 1)

# effect name -> (parameter, value that means "off", unit, in the diagnosis's vocabulary)
EFFECTS = {
    "drive_longitudinal_creep": ("scale", 0.0, "-", True),
    "steering_lateral_creep": ("scale", 0.0, "-", True),
    "drive_spin_creep": ("half_width", 0.0, "m", True),
    "normal_force_variation": ("exponent", 0.0, "-", True),
    "rolling_resistance": ("c_rr", 0.0, "-", True),
    "steering_offset": ("offset", 0.0, "rad", True),
    "drive_radius_mismatch": ("delta", 0.0, "-", True),
    "traction_saturation": ("mu_scale", None, "-", True),
    "fork_compliance": ("c_f", 0.0, "rad/N", False),
    "speed_dependent_creep": ("kappa", 0.0, "s/m", False),
    "viscous_loss": ("b", 0.0, "N*m*s/rad", False),
    "creep_reference": ("lam", 0.0, "-", False),
}
BASE = {"drive_longitudinal_creep": 1.0, "steering_lateral_creep": 1.0}   # Kim's model at his constants

STATUS = ("ok", "not_converged", "lost_contact", "gross_slip")


def _check(effects: dict) -> dict:
    unknown = [e for e in effects if e not in EFFECTS]
    if unknown:
        raise ValueError(f"unknown effect(s) {unknown}; known: {', '.join(EFFECTS)}")
    p = {e: (spec[1] if spec[1] is not None else 0.0) for e, spec in EFFECTS.items()}
    p.update({e: float(v) for e, v in effects.items()})
    p["saturation"] = "traction_saturation" in effects
    if p["saturation"] and p["traction_saturation"] <= 0:
        raise ValueError("traction_saturation: the μ multiplier must be > 0")
    return p


def steering_angle(gamma):
    """Kim eq 5 inverted, tan φ = √2 tan(γ − 45°), on the linkage's continuous branch [rad]."""
    g = np.asarray(gamma, float) - np.pi / 4
    return np.arctan2(_S2 * np.sin(g), np.cos(g))


def _sabs(x, floor):
    return np.sqrt(x * x + floor * floor)


def _ellipse_inverse(x):
    """η in (−1, 1) with (2/π)(asin η + η√(1 − η²)) = x, for |x| < 1 (Newton from the small-x value)."""
    x = np.asarray(x, float)
    eta = np.clip(np.pi / 4 * x, -0.999, 0.999)
    for _ in range(60):
        q = np.sqrt(np.maximum(1 - eta * eta, 1e-300))
        d = (2 / np.pi * (np.arcsin(eta) + eta * q) - x) / (4 / np.pi * q)
        eta = np.clip(eta - d, -1 + 1e-15, 1 - 1e-15)
        if np.all(np.abs(d) < 1e-15):
            break
    return eta


# ----------------------------------------------------------------------------------------- the equations

class _Problem:
    """The 14 equations at P operating points (arrays over the last axis)."""

    F_REF = 10.0    # [N] force scale of the unknowns and residuals

    def __init__(self, gamma, tau_perp, omega_1, p):
        self.g = np.asarray(gamma, float)
        self.tau = np.asarray(tau_perp, float)
        self.w1 = np.asarray(omega_1, float)
        self.p = p
        self.phi = steering_angle(self.g) + p["steering_offset"]
        self.r = np.array([R_DRIVE, R_DRIVE * (1 + p["drive_radius_mismatch"]), R_STEER, R_STEER])
        self.mu = MU * (p["traction_saturation"] if p["saturation"] else 1.0)
        self.w_ref = np.abs(self.w1)                          # [rad/s]
        self.om_ref = R_DRIVE * self.w_ref / R_SPHERE         # [rad/s] sphere speed scale
        self.v_ref = R_DRIVE * self.w_ref                     # [m/s]

    # unknowns: x[0:3] Ω/om_ref, x[3] ω2/w_ref, x[4:6] w_S/w_ref, x[6:14] (F_t, F_a) of D1, D2, S1, S2 / F_REF
    def unpack(self, x):
        Om = x[0:3] * self.om_ref
        w = np.stack([self.w1, x[3] * self.w_ref, x[4] * self.w_ref, x[5] * self.w_ref])
        F = x[6:14].reshape(4, 2, -1) * self.F_REF            # [contact, (t, a), point]
        return Om, w, F

    def guess(self):
        c, s = np.cos(self.g), np.sin(self.g)
        Om = (R_DRIVE * self.w1 / (R_SPHERE * c)) * (c * D1[:, None] + s * D2[:, None])
        x = np.zeros((14, self.g.size))
        x[0:3] = Om / self.om_ref
        x[3] = self.w1 * np.tan(self.g) / self.w_ref
        a = self.axles(self.phi, self.phi)
        for k in (2, 3):
            x[2 + k] = -R_SPHERE * np.einsum("ip,ip->p", Om, a[k]) / (R_STEER * self.w_ref)
        x[6] = -self.tau * s / R_DRIVE / self.F_REF
        x[8] = self.tau * c / R_DRIVE / self.F_REF
        return x

    @staticmethod
    def axles(phi1, phi2):
        n = np.broadcast(phi1, phi2).shape
        a_s1 = np.cos(phi1) * C2[:, None] + np.sin(phi1) * C3[:, None]
        a_s2 = np.cos(phi2) * C1[:, None] + np.sin(phi2) * C3[:, None]
        return [np.broadcast_to(-D1[:, None], (3,) + n), np.broadcast_to(-D2[:, None], (3,) + n), a_s1, a_s2]

    def state(self, x):
        """Everything the equations and the outputs need, at unknowns x (14, P)."""
        p = self.p
        Om, w, F = self.unpack(x)
        sgn_w = w / _sabs(w, W_SIGN)
        phi1 = self.phi + p["fork_compliance"] * sgn_w[2] * F[2, 1]
        phi2 = self.phi - p["fork_compliance"] * sgn_w[3] * F[3, 1]
        a = self.axles(phi1, phi2)
        n = [np.broadcast_to(v[:, None], Om.shape) for v in NORMALS]
        t = [np.cross(n[k], a[k], axis=0) for k in range(4)]
        v_r = self.r[:, None] * w                                               # roller surface speed along t
        v_s = np.stack([-R_SPHERE * np.einsum("ip,ip->p", Om, a[k]) for k in range(4)])
        s_t = v_s - v_r
        s_a = np.stack([R_SPHERE * np.einsum("ip,ip->p", Om, t[k]) for k in range(4)])
        Fv = [F[k, 0] * t[k] + F[k, 1] * a[k] for k in range(4)]                # force vectors on the sphere
        N = PRELOAD + np.stack([np.einsum("ip,ip->p", n[k], M_INV @ sum(Fv)) for k in range(4)])
        Fmag = np.sqrt(F[:, 0] ** 2 + F[:, 1] ** 2)
        # the normal force the contact laws follow: the preload, or the force balance's N with
        # normal_force_variation (kept positive while Newton iterates; N <= 0 is reported as lost contact)
        N_law = np.maximum(N, 1e-3 * PRELOAD) if self.p["normal_force_variation"] else np.full_like(N, PRELOAD)
        spin = np.stack([np.einsum("ip,ip->p", Om, n[k]) for k in range(4)])
        return dict(Om=Om, w=w, F=F, sgn_w=sgn_w, a=a, n=n, t=t, v_r=v_r, s_t=s_t, s_a=s_a, Fv=Fv, N=N,
                    N_law=N_law, Fmag=Fmag, spin=spin)

    def compliance_factors(self, st):
        """Per contact: the multiplier on the elastic creep compliances (normal force, speed, saturation)."""
        p = self.p
        N = st["N_law"]
        f = np.ones_like(N)
        if p["normal_force_variation"]:
            f = f * (N / PRELOAD) ** (-p["normal_force_variation"])
        if p["speed_dependent_creep"]:
            f = f * (1 + p["speed_dependent_creep"] * _sabs(st["v_r"], 1e-9 * self.v_ref))
        if p["saturation"]:
            u = np.minimum(st["Fmag"] / (self.mu * N), 1 - 1e-9)
            h = np.pi * u / 2
            f = f * np.where(h < 1e-6, 1 + h * h / 3, np.tan(h) / np.maximum(h, 1e-6))
        return f

    def spin_slip(self, st, k):
        """Drive contact k's sliding velocity from spin [m/s] (0 unless drive_spin_creep): Gillespie's line
        contact of half-width a across the rolling direction, every point of it sliding, the slip varying
        linearly across the line (s0 + Ω·n y); with an elliptical (Hertzian) pressure across the line
        instead of Gillespie's uniform one, F/(μN) = f(η) = (2/π)(asin η + η√(1 − η²)), η = s0/(a|Ω·n|),
        so s0 = a|Ω·n| f⁻¹(F/(μN)) (≈ (π/4)(a/(μN))|Ω·n| F at small F); a ∝ N^(1/3) when the contact law
        follows the force-balanced N."""
        a0 = self.p["drive_spin_creep"]
        if not a0:
            return 0.0
        N = st["N_law"][k]
        a = a0 * (N / PRELOAD) ** (1 / 3)
        x = np.clip(st["F"][k, 0] / (self.mu * N), -1 + 1e-9, 1 - 1e-9)
        return a * _sabs(st["spin"][k], 1e-9 * self.om_ref) * _ellipse_inverse(x)

    def creep_speed(self, st):
        """Per contact, the rolling speed creepage is taken against [m/s]: the sphere's surface speed along t
        (Kim's free-rolling speed, eqs 18, 25), or with creep_reference λ the blend (1 − λ)|v_s| + λ|v_r|."""
        lam = self.p["creep_reference"]
        floor = 1e-9 * self.v_ref
        v_s = st["s_t"] + st["v_r"]
        return (1 - lam) * _sabs(v_s, floor) + lam * _sabs(st["v_r"], floor)

    def resisting(self, st):
        """Resisting torque on each roller's axle [N m] (signed about the axle: opposes the rotation)."""
        p = self.p
        M = np.zeros_like(st["N"])
        if p["rolling_resistance"]:
            M = M - p["rolling_resistance"] * self.r[:, None] * st["N_law"] * st["sgn_w"]
        if p["viscous_loss"]:
            M = M - p["viscous_loss"] * st["w"]
        return M

    def torques(self, st, M=None):
        M = self.resisting(st) if M is None else M
        return self.r[0] * st["F"][0, 0] - M[0], self.r[1] * st["F"][1, 0] - M[1]

    def residual(self, x):
        p = self.p
        st = self.state(x)
        F = st["F"]
        f = self.compliance_factors(st)
        M = self.resisting(st)
        Fr, Vr = self.F_REF, self.v_ref
        res = []
        # sphere moment balance
        mom = sum(R_SPHERE * np.cross(st["n"][k], st["Fv"][k], axis=0) for k in range(4))
        res += list(mom / (R_SPHERE * Fr))
        V = self.creep_speed(st)
        # drive rollers along t
        for k in (0, 1):
            c = EPS_D * p["drive_longitudinal_creep"] * V[k] * f[k]
            res.append((st["s_t"][k] + c * F[k, 0] + self.spin_slip(st, k)) / Vr)
        # drive rollers along a: rigid, closed by symmetry
        res.append(R_SPHERE * np.einsum("ip,ip->p", st["Om"], np.broadcast_to(D3[:, None], st["Om"].shape)) / Vr)
        res.append((F[0, 1] + F[1, 1]) / Fr)
        # steering idlers along t: free rolling, and their torque balance
        for k in (2, 3):
            res.append(st["s_t"][k] / Vr)
            res.append((-self.r[k] * F[k, 0] + M[k]) / (self.r[k] * Fr))
        # steering idlers along a: creep laws as difference and compliance-scaled sum
        e = [EPS_S * p["steering_lateral_creep"] * f[k] for k in (2, 3)]
        vs = [V[k] for k in (2, 3)]
        G = [vs[i] * np.tan(e[i] * F[2 + i, 1]) for i in (0, 1)]
        res.append((st["s_a"][2] - st["s_a"][3] + G[0] - G[1]) / Vr)
        cbar = 0.5 * (e[0] * vs[0] + e[1] * vs[1])
        if p["steering_lateral_creep"]:
            res.append((st["s_a"][2] + st["s_a"][3] + G[0] + G[1]) / (cbar * Fr))
        else:
            res.append((F[2, 1] + F[3, 1]) / Fr)
        # the load
        t1, t2 = self.torques(st, M)
        res.append((-t1 * np.sin(self.g) + t2 * np.cos(self.g) - self.tau) / (R_DRIVE * Fr))
        return np.array(res)


def _rescue(prob: _Problem, x, idx, tol=1e-11):
    """For the points Newton left: continuation in the load (τ⊥ raised from 0 in eight steps, Newton at each,
    all such points at once); a point whose branch reached the last step but did not converge there gets
    scipy.optimize.root (hybr) from its last state. Returns (x, converged)."""
    sub = _Problem(prob.g[idx], prob.tau[idx] * 0, prob.w1[idx], prob.p)
    z, alive = newton(sub, sub.guess(), tol)
    for lam in np.linspace(0.125, 0.875, 7):
        sub.tau = prob.tau[idx] * lam
        z_new, ok = newton(sub, z.copy(), tol)
        alive &= ok
        z[:, alive] = z_new[:, alive]
    sub.tau = prob.tau[idx]
    z_new, ok = newton(sub, z.copy(), tol)
    conv = alive & ok
    z[:, conv] = z_new[:, conv]
    for m in np.flatnonzero(alive & ~conv):       # the branch reached 7/8 of the load, Newton stalled after
        one = _Problem(prob.g[idx[m]:idx[m] + 1], prob.tau[idx[m]:idx[m] + 1], prob.w1[idx[m]:idx[m] + 1], prob.p)
        sol = root(lambda v: one.residual(v[:, None])[:, 0], z[:, m], method="hybr", options={"xtol": 1e-13})
        if np.all(np.isfinite(sol.x)) and np.max(np.abs(one.residual(sol.x[:, None]))) < tol * 10:
            z[:, m] = sol.x
            conv[m] = True
    x[:, idx[conv]] = z[:, conv]
    return x, conv


def solve(gammas, loads, effects: dict, omega_1=10.0) -> dict:
    """Steady state at commanded γ [rad] and lateral loads τ⊥ [N m] (broadcast together), motor speed ω1
    [rad/s], with `effects` {name: strength}. Returns flat arrays: gamma_cmd, tau_perp, omega_1, omega_2,
    tau_1, tau_2, gamma_axis [rad], alpha (= atan2(ω2, ω1) − γ_cmd), alpha_steering (γ_axis − γ_cmd),
    N (4, P), F (4, 2, P), phi, status (index into STATUS); numbers are NaN where the status is not ok."""
    p = _check(effects)
    g, tau, w1 = (np.ravel(v).astype(float) for v in np.broadcast_arrays(np.asarray(gammas, float),
                                                                          np.asarray(loads, float),
                                                                          np.asarray(omega_1, float)))
    prob = _Problem(g, tau, w1, p)
    x, conv = newton(prob, prob.guess())
    if not conv.all():
        idx = np.flatnonzero(~conv)
        x, c2 = _rescue(prob, x, idx)
        conv[idx] = c2
    st = prob.state(x)
    t1, t2 = prob.torques(st)
    N, Fmag = st["N"], st["Fmag"]
    # utilisation of the laws that level off at μN (saturation: |F|; spin sliding: the drive rollers' F_t),
    # against the normal force those laws follow; a point that needs it to reach 1 is gross slip
    with np.errstate(invalid="ignore", divide="ignore"):
        u_law = np.zeros(g.size)
        if p["saturation"]:
            u_law = np.max(Fmag / (prob.mu * st["N_law"]), axis=0)
        if p["drive_spin_creep"]:
            u_law = np.maximum(u_law, np.max(np.abs(st["F"][:2, 0]) / (prob.mu * st["N_law"][:2]), axis=0))
    status = np.zeros(g.size, int)
    status[~conv] = 1
    status[~conv & (u_law > 0.99)] = 3       # no steady state: the tractive force would have to reach μN
    lost = np.any(N <= 0, axis=0) & conv
    status[lost] = 2
    slip = (np.any(Fmag > prob.mu * np.maximum(N, 0), axis=0) | (u_law > 1 - 1e-6)) & conv & ~lost
    status[slip] = 3
    ok = status == 0
    Om = st["Om"]
    gax = np.arctan2(Om.T @ D2, Om.T @ D1)
    out = {"gamma_cmd": g, "tau_perp": tau, "omega_1": w1, "omega_2": st["w"][1], "tau_1": t1, "tau_2": t2,
           "gamma_axis": gax, "alpha": _wrap(np.arctan2(st["w"][1], st["w"][0]) - g),
           "alpha_steering": _wrap(gax - g), "phi": prob.phi, "N": N, "F": st["F"], "omega_S": st["w"][2:]}
    for k, v in out.items():
        if k not in ("gamma_cmd", "tau_perp", "omega_1"):
            out[k] = np.where(ok, v, np.nan)
    out["status"] = status
    out["ok"] = ok
    return out


def _wrap(a):
    """Angles between axes, wrapped to [−π/2, π/2)."""
    return (np.asarray(a) + np.pi / 2) % np.pi - np.pi / 2
