"""Frames, roller poses, the steering linkage and ideal kinematics.

The named frame vectors are those of Kim et al., "Causes of microslip in a continuously variable
transmission" (sec. 2.1): sphere centre at the origin of N (x, y, z); d1 = (1, 1, 0)/√2, d2 = (−1, 1, 0)/√2,
d3 = z; c1 = (0, −1, 1)/√2, c2 = (0, −1, −1)/√2, c3 = x. They are only names a variant file may use for
directions: γ, α and the ideal law come from each layout's own shaft axes (kinematics.py).

A roller is described at its contact with the sphere by the outward unit normal n (contact point R·n) and
the unit axle a (its positive spin direction, a ⊥ n). Its rolling direction is t = n × a: a roller spinning
at +ω about a moves its surface at the contact with velocity r·ω·t. A steered roller's pose (n and a) turns
about its fork axis k, which passes through the sphere centre, by ρ·φ (φ = steering angle, ρ = the fork's
gear ratio), so the roller stays in contact whatever φ is. Kim's forks turn about the contact normal itself
(n unchanged); the box CVT's forks carry a tandem pair about the sphere's pole axis (n and a both turn).
Which forks and ratios can steer together: core/linkage.py and docs/linkages.md.

Functions here take and return plain 3-vectors of floats or CasADi expressions (lists/ca.SX); numeric
helpers at the bottom work on numpy arrays.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from cvtdesign.core.kinematics import shaft_frame, vec
from cvtdesign.errors import InputError

# Tolerances of the rolling and steering geometry. The rigid rolling constraints must leave exactly one motion
# (singular values below ROLLING_TOL × the largest count as zero) and the linkage must turn every steered axle
# into the commanded axis (misfit below LINKAGE_TOL). They are tight because the model's drive rollers are
# laterally rigid (EPS_RIGID): a drive roller turned by 1e-5° (2e-7 rad) against the others already makes
# contacts fight with forces of the order of the preload. So directions must be exact: frame names,
# '= expressions' or full precision (a box follower's axle typed to six decimals is refused).
ROLLING_TOL = 1e-9
LINKAGE_TOL = 1e-6

S2 = np.sqrt(2.0)
FRAME = {
    "x": np.array([1.0, 0.0, 0.0]),
    "y": np.array([0.0, 1.0, 0.0]),
    "z": np.array([0.0, 0.0, 1.0]),
    "d1": np.array([1.0, 1.0, 0.0]) / S2,
    "d2": np.array([-1.0, 1.0, 0.0]) / S2,
    "d3": np.array([0.0, 0.0, 1.0]),
    "c1": np.array([0.0, -1.0, 1.0]) / S2,
    "c2": np.array([0.0, -1.0, -1.0]) / S2,
    "c3": np.array([1.0, 0.0, 0.0]),
}
KIM_FRAME = ("d1", "d2", "d3", "c1", "c2", "c3")   # Kim's frame vectors, as opposed to the axes x, y, z


def named_vector(name: str) -> np.ndarray | None:
    """Unit vector for a frame name such as 'd1', '-c2' or 'z'; None if the name is not a frame vector."""
    sign = -1.0 if name.startswith("-") else 1.0
    v = FRAME.get(name.lstrip("+-"))
    return None if v is None else sign * v


def spherical(polar, azimuth):
    """Unit vector from polar angle [rad] (from +z) and azimuth [rad] (from +x towards +y)."""
    return ca.vertcat(ca.sin(polar) * ca.cos(azimuth), ca.sin(polar) * ca.sin(azimuth), ca.cos(polar))


def rotate(v, k, angle):
    """Rotate 3-vector v about unit axis k by angle [rad] (Rodrigues); v, k may be CasADi expressions."""
    v, k = vec(v), vec(k)
    c, s = ca.cos(angle), ca.sin(angle)
    return v * c + ca.cross(k, v) * s + k * ca.dot(k, v) * (1 - c)


def linkage_terms(t0s, forks, frame, gammas) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C), each (len(gammas), n): the lateral-constraint misfit of steered roller i at γ and φ is
    t_i(φ)·u(γ) = A cos ρ_iφ − B sin ρ_iφ + C (1 − cos ρ_iφ) (Rodrigues: t_i(φ)·u = t0 · R(−ρ_i φ) u,
    rotations preserve dot products).

    t0s: rolling directions at φ = 0 (n, 3); forks: (axis (n, 3), gear ratio ρ_i (n,)); frame: the layout's
    kinematics.ShaftFrame, whose u(γ) is the commanded axis. A linkage reaches γ where every steered roller
    rolls without lateral slip about u."""
    axes, _ = forks
    u = frame.axis(np.asarray(gammas, float))                                # (G, 3)
    kxu = np.cross(axes[None, :, :], u[:, None, :])                          # (G, n, 3)
    return u @ t0s.T, np.einsum("gnk,nk->gn", kxu, t0s), (u @ axes.T) * np.einsum("nk,nk->n", t0s, axes)


def misfit_terms(terms, ratios, phis) -> np.ndarray:
    """t_i(φ)·u(γ) of every steered roller, shape (G, P, n), for steering angles phis [rad]: (P,) shared by
    every γ or (G, P); `terms` from `linkage_terms`, `ratios` the gear ratios ρ_i (n,)."""
    A, B, C = (t[:, None, :] for t in terms)
    psi = np.asarray(phis)[..., None] * np.asarray(ratios, float)
    c, s = np.cos(psi), np.sin(psi)
    return A * c - B * s + C * (1 - c)


def scan_range(ratios) -> float:
    """Half-width Φ [rad] of the steering angles scanned, (−Φ, Φ]: the slowest fork turns ±90°, which takes
    each of its rollers' rolling directions through every line; for gear ratios ±1 this is (−90°, 90°]."""
    return np.pi / 2 / float(np.min(np.abs(ratios)))


def steering_angle_guess(t0s, forks, frame, gammas, n_scan: int = 721) -> tuple[np.ndarray, np.ndarray]:
    """Steering angle φ ∈ (−Φ, Φ] [rad] (`scan_range`) that best realises each commanded γ [rad], by a scan
    of the misfit (`linkage_terms`); the scan has n_scan points per 180° of the fastest fork's turn.

    Returns (φ, worst residual). The compiled model refines φ with Newton; the scan only seeds it and
    tells whether the linkage can reach γ at all."""
    ratios = np.asarray(forks[1], float)
    gammas, inverse = np.unique(np.atleast_1d(gammas), return_inverse=True)
    terms = linkage_terms(t0s, forks, frame, gammas)
    half = scan_range(ratios)
    n_scan = int(min(n_scan * np.ceil(np.max(np.abs(ratios)) / np.min(np.abs(ratios)) - 1e-9), 20 * n_scan))
    phis = np.linspace(-half, half, n_scan)[1:]

    def cost(phi):
        return np.sum(misfit_terms(terms, ratios, phi) ** 2, axis=-1)

    best = phis[np.argmin(cost(phis), axis=1)]
    width = phis[1] - phis[0]
    for _ in range(6):  # zoom in around each best angle: 6 passes of 41 points refine it by 20^6
        local = best[:, None] + np.linspace(-width, width, 41)[None, :]
        best = local[np.arange(len(gammas)), np.argmin(cost(local), axis=1)]
        width /= 20
    wrapped = (best + half) % (2 * half) - half
    return wrapped[inverse], np.sqrt(cost(best[:, None])[:, 0])[inverse]


def _np(v):
    return np.asarray(v, float).ravel() if isinstance(v, np.ndarray) else np.asarray(np.array(v.full() if hasattr(v, "full") else v, float)).ravel()


def roller_pose(r, phi):
    """Contact normal and axle of roller r at steering angle φ [rad] (CasADi; fixed rollers ignore φ)."""
    n, a = vec(r.normal), vec(r.axle)
    if r.fork_axis is None:
        return n, a
    k = vec(r.fork_axis)
    return rotate(n, k, r.fork_ratio * phi), rotate(a, k, r.fork_ratio * phi)


def pose(r, phi):
    """Numeric (normal, axle) of roller r at steering angle φ [rad], numpy arrays."""
    return tuple(_np(v) for v in roller_pose(r, phi))


def steering_data(layout):
    """Rolling directions at φ = 0, (fork axes, gear ratios) of the steered rollers and the layout's
    ShaftFrame: the arguments of `steering_angle_guess` before the γ."""
    steered = [r for r in layout.rollers if r.fork_axis is not None]
    t0 = np.array([np.cross(*pose(r, 0.0)) for r in steered]).reshape(-1, 3)
    forks = (np.array([_np(r.fork_axis) for r in steered]).reshape(-1, 3), np.array([r.fork_ratio for r in steered], float))
    return t0, forks, shaft_frame(layout)


def rigid_constraints(layout, phi: float) -> np.ndarray:
    """Rolling constraints of rigid contacts, rows × unknowns [Ω (3), ω1, ω2, idler speeds].

    Lateral: R Ω·t_i = 0 (no sideways slip); longitudinal: −R Ω·a_i − r_i ρ_i ω_s = 0."""
    R = float(layout.sphere_radius)
    idlers = [r.name for r in layout.rollers if r.role == "steering"]
    rows = []
    for r in layout.rollers:
        n, a = pose(r, phi)
        t = np.cross(n, a)
        lat = np.zeros(5 + len(idlers))
        lat[:3] = R * t
        lon = np.zeros_like(lat)
        lon[:3] = -R * a
        if r.role == "steering":
            lon[5 + idlers.index(r.name)] = -float(r.radius)
        else:
            lon[2 + r.shaft] = -float(r.radius) * float(r.ratio)
        rows += [lat, lon]
    return np.array(rows)


def ideal_gamma(layout, phi: float) -> float:
    """Forward kinematics: the transmission angle γ [rad] the rigid rollers give at steering angle φ [rad],
    from the one motion the rolling constraints leave (sign chosen so that shaft 1 turns forwards)."""
    A = rigid_constraints(layout, phi)
    motion = np.linalg.svd(A)[2][-1]
    om = motion[:3] * np.sign(motion[3])
    return float(shaft_frame(layout).axis_angle(om))


def steering_angle(layout, gamma: float) -> float:
    """Steering angle φ [rad] at which every steered roller rolls without lateral slip about the commanded
    axis at γ [rad]: the linkage's inverse kinematics as the model seeds and solves it (`steering_angle_guess`
    refines a scan to ~1e-10 rad; the model's Newton solve starts there). γ must be finite and within the
    variant's envelope.gamma range (the command line's --gamma)."""
    lo, hi = float(np.min(layout.gamma_grid)), float(np.max(layout.gamma_grid))
    if not (np.isfinite(gamma) and lo - 1e-12 <= gamma <= hi + 1e-12):
        raise InputError(f"{layout.file}: --gamma: γ = {np.degrees(gamma):g}° is outside the variant's envelope.gamma "
                         f"range {np.degrees(lo):g}..{np.degrees(hi):g}°; expected a --gamma in that range")
    phi, misfit = steering_angle_guess(*steering_data(layout), np.array([gamma]))
    if misfit[0] > LINKAGE_TOL:
        raise InputError(f"{layout.file}: steering.forks: the linkage cannot reach γ = {np.degrees(gamma):g}° "
                         f"(misfit {misfit[0]:.2g}); expected a --gamma the steering rollers can realise")
    return float(phi[0])
