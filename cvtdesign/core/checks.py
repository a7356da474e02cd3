"""Geometric and kinematic checks of a resolved (numeric) layout, run before any model is compiled.

Each failure is one InputError line naming the file and the field a user would edit.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from cvtdesign.core import linkage
from cvtdesign.core.geometry import FRAME, LINKAGE_TOL, ROLLING_TOL, pose, rigid_constraints, steering_angle_guess, steering_data
from cvtdesign.errors import InputError
from cvtdesign.core.layout import Layout

N_RIM = 48


def check_kinematics(layout: Layout):
    """Across the γ envelope: the linkage reaches γ, and the rigid rolling constraints leave exactly one
    motion (the sphere turning about one axis, every roller rolling): none means the rollers fight, more
    than one means the steering rollers cannot fix an axis."""
    gammas = np.linspace(layout.gamma_grid.min(), layout.gamma_grid.max(), 9)
    phis, misfit = steering_angle_guess(*steering_data(layout), gammas)
    for g, phi, m in zip(gammas, phis, misfit):
        if m > LINKAGE_TOL:
            raise InputError(linkage.refusal(layout, gammas))
        A = rigid_constraints(layout, phi)
        sv = np.linalg.svd(A, compute_uv=False)
        null = int(np.sum(sv < ROLLING_TOL * sv[0])) + max(0, A.shape[1] - A.shape[0])
        if null >= 2:
            raise InputError(f"{layout.file}: steering: the steering rollers cannot fix the sphere's axis at γ = "
                             f"{np.degrees(g):.0f}° ({null} free motions); add or move steering rollers")
        if null == 0:
            raise InputError(f"{layout.file}: rollers: no rolling motion fits every roller at γ = {np.degrees(g):.0f}° "
                             "(rollers fight); check follower ratios, axles and fork axes, and that no direction is "
                             "rounded (write them as frame names, '= expressions' or in full precision)")


def roller_poses(layout: Layout, phis) -> tuple[np.ndarray, np.ndarray]:
    """Contact normals and axles of every roller at each steering angle φ [rad], shapes (len(phis), rollers,
    3): geometry.roller_pose for many angles at once (Rodrigues' rotation of each steered roller about its
    fork axis by its ratio · φ; fixed rollers ignore φ)."""
    phis = np.atleast_1d(np.asarray(phis, float))
    normals, axles = [], []
    for r in layout.rollers:
        n0, a0 = pose(r, 0.0)
        if r.fork_axis is None:
            normals.append(np.broadcast_to(n0, (len(phis), 3)))
            axles.append(np.broadcast_to(a0, (len(phis), 3)))
            continue
        k = np.asarray(r.fork_axis, float).ravel()
        c, s = np.cos(r.fork_ratio * phis)[:, None], np.sin(r.fork_ratio * phis)[:, None]
        for v, out in ((n0, normals), (a0, axles)):
            out.append(v * c + np.cross(k, v) * s + k * (k @ v) * (1 - c))
    return np.stack(normals, axis=1), np.stack(axles, axis=1)


def surface_points(centres, normals, axles, radii, halves) -> np.ndarray:
    """Points on each roller's cylinder [m], shape (rollers, 3 × 3 × N_RIM + 1, 3): circles of the full
    radius and of 0.66 and 0.33 of it on both faces and the mid-plane, and the centre."""
    th = np.linspace(0, 2 * np.pi, N_RIM, endpoint=False)
    t = np.cross(normals, axles)
    ring = np.cos(th)[None, :, None] * normals[:, None, :] + np.sin(th)[None, :, None] * t[:, None, :]  # (n, N_RIM, 3)
    pts = [centres[:, None, :] + (s * halves)[:, None, None] * axles[:, None, :] + f * radii[:, None, None] * ring
           for s in (-1.0, 0.0, 1.0) for f in (1.0, 0.66, 0.33)]
    return np.concatenate(pts + [centres[:, None, :]], axis=1)


def overlapping_rollers(layout: Layout) -> list[tuple[float, str, str]]:
    """(γ [rad], roller, roller) for every two rollers whose bodies (cylinders of their radius and width)
    intersect at the steering angle of γ, over 9 γ across the envelope: a point sampled on one body
    (`surface_points`) lies inside the other. Pairs whose bounding spheres are apart are not sampled (no
    point of one can then lie inside the other)."""
    R = float(layout.sphere_radius)
    gammas = np.linspace(layout.gamma_grid.min(), layout.gamma_grid.max(), 9)
    phis, _ = steering_angle_guess(*steering_data(layout), gammas)
    names = [r.name for r in layout.rollers]
    radii = np.array([float(r.radius) for r in layout.rollers])
    halves = np.array([float(r.width) / 2 for r in layout.rollers])
    bound = np.hypot(radii, halves)
    i, j = np.triu_indices(len(names), 1)
    found = []
    for g, normals, axles in zip(gammas, *roller_poses(layout, phis)):
        centres = (R + radii)[:, None] * normals
        near = np.linalg.norm(centres[i] - centres[j], axis=1) < bound[i] + bound[j]
        if not near.any():
            continue
        pts = surface_points(centres, normals, axles, radii, halves)
        a, b = np.concatenate([i[near], j[near]]), np.concatenate([j[near], i[near]])   # points of a in body b
        d = pts[a] - centres[b][:, None, :]
        along = np.einsum("pkx,px->pk", d, axles[b])
        radial = np.linalg.norm(d - along[..., None] * axles[b][:, None, :], axis=-1)
        inside = ((np.abs(along) < halves[b][:, None] * (1 - 1e-9)) & (radial < radii[b][:, None] * (1 - 1e-9))).any(axis=1)
        hit = inside[:near.sum()] | inside[near.sum():]
        found += [(float(g), names[p], names[q]) for p, q in zip(i[near][hit], j[near][hit])]
    return found


def check_overlaps(layout: Layout):
    """No two roller bodies (cylinders of their radius and width) intersect, at any steering angle."""
    found = overlapping_rollers(layout)
    if found:
        g, a, b = found[0]
        raise InputError(f"{layout.file}: rollers.{a}, rollers.{b}: the two rollers overlap at "
                         f"γ = {np.degrees(g):.0f}°; move them apart or make them smaller")


def check_mounts(layout: Layout):
    """The contact normals must hold the sphere in every direction (the mount stiffness matrix is regular)."""
    K = sum(float(r.stiffness) * np.outer(*(2 * (pose(r, 0.0)[0],))) for r in layout.rollers)
    if np.linalg.cond(K) > 1e8:
        raise InputError(f"{layout.file}: rollers: the contact normals do not hold the sphere in all directions")


def check_steering_present(layout: Layout):
    """At least one roller is steered: without steering rollers nothing fixes the sphere's axis (and the
    linkage scan has nothing to scan)."""
    if not any(r.fork_axis is not None for r in layout.rollers):
        raise InputError(f"{layout.file}: steering.forks: no steering roller on any fork; without steering rollers "
                         "nothing fixes the sphere's axis (add a fork holding at least one steering roller)")


def _numeric(x) -> bool:
    return x is None or isinstance(x, (float, int, np.ndarray, ca.DM))


def _frame_name(u, tol=1e-9) -> str:
    for name, v in FRAME.items():
        for sign in ("", "-"):
            if name != "d3" and np.allclose(u, v if sign == "" else -v, atol=tol):
                return f" = {sign}{name}"
    return ""


def check_preload_equilibrium(layout: Layout):
    """The preloads P_i (normal forces with the sphere centred) balance: Σ P_i n_i = 0 (n_i the contact
    normals at φ = 0). If not, the message gives the net force and the rest equilibrium the mounts would
    find, K δ = −Σ P_i n_i with K = Σ k_i n_i n_iᵀ, N_i = P_i + k_i n_i·δ: its smallest normal force
    (negative: that roller lifts off). Skipped when preloads, stiffnesses or normals are symbolic (an
    optimiser's overrides)."""
    rs = layout.rollers
    if not all(isinstance(r.preload, (float, int)) and isinstance(r.stiffness, (float, int))
               and _numeric(r.normal) and _numeric(r.axle) and _numeric(r.fork_axis) for r in rs):
        return
    P = np.array([float(r.preload) for r in rs])
    k = np.array([float(r.stiffness) for r in rs])
    n = np.array([pose(r, 0.0)[0] for r in rs])
    F = P @ n
    if not np.linalg.norm(F) > 1e-6 * P.sum():
        return
    K = np.einsum("i,ij,ik->jk", k, n, n)
    delta = np.linalg.lstsq(K, -F, rcond=None)[0]
    N = P + k * (n @ delta)
    N[np.abs(N) < 1e-9 * P.sum()] = 0.0
    i = int(np.argmin(N))
    u = F / np.linalg.norm(F)
    u = np.where(np.abs(u) < 1e-9, 0.0, u)   # no '5.7e-16' or '-0' in the message
    lift = " (it would lift off)" if N[i] < 0 else " (unloaded)" if N[i] == 0 else ""
    raise InputError(
        f"{layout.file}: rollers: the preloads do not balance (Σ P_i n_i = {np.linalg.norm(F):.4g} N along "
        f"({u[0]:.3g}, {u[1]:.3g}, {u[2]:.3g}){_frame_name(u)}); at rest the mounts would move the sphere "
        f"{np.linalg.norm(delta) * 1e3:.3g} mm and the smallest normal force would be {N[i]:.4g} N on rollers."
        f"{rs[i].name}{lift}; move the rollers or set their preloads so that the preload forces sum to zero")


def check_layout(layout: Layout):
    check_steering_present(layout)
    check_kinematics(layout)
    check_mounts(layout)
    check_overlaps(layout)
    check_preload_equilibrium(layout)
