"""The steering linkage's rule: which steering rollers on forks can all roll about the commanded axis, which
roller breaks it, and what would fix that roller (docs/linkages.md derives the rule).

A steering roller with rolling direction t = n × a rolls without lateral slip about the sphere's axis ω̂
iff t·ω̂ = 0: its axle, its contact normal and ω̂ are coplanar (Kim et al., "Causes of microslip in a
continuously variable transmission", for its two forks). Every commanded axis u(γ) lies in the axis plane
of the shafts (kinematics.ShaftFrame, pole p = u1 × u2), so a roller allows exactly one of them, the one
perpendicular in that plane to t's projection, its *own axis* γ_i = atan2(−t·u1, t·u2) (mod 180°), unless
t ∥ p (it then allows every axis and steers nothing). A fork turns its rollers by ρ·φ about an axis f
through the sphere centre (ρ its gear ratio, φ the linkage's one steering angle), and so turns each
roller's own axis at the rate

    dγ_i/dφ = ρ (f·p − (t·p)/(t·m) f·m),   m = p × u(γ_i).

The rule: the linkage reaches a commanded γ at some φ where every steering roller's own axis is u(γ), and
it must do so for every γ of the envelope. A roller that breaks it is found by grouping the rollers whose
own axes agree over the envelope (`linkage_groups`); the largest group sets the linkage's law, and a fix is
searched for every other roller: a fork ratio, a fork axis, an axle direction or a combination, else a move
to an image of a roller of the group (`images`), each accepted only when the rollers then reach every γ
(`refusal`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cvtdesign.core.geometry import FRAME, LINKAGE_TOL, linkage_terms, misfit_terms, pose, steering_angle_guess
from cvtdesign.core.kinematics import ShaftFrame, shaft_frame

ROUNDED = 1e-3     # [rad] a roller that misses the linkage's axis by less than this has a rounded direction


@dataclass(frozen=True)
class Steered:
    """The steered rollers of a layout (one row each): names, contact normals, axles and rolling directions
    at φ = 0, fork axes, gear ratios, the index of each one's fork in steering.forks (None if unknown)."""
    names: list
    normals: np.ndarray
    axles: np.ndarray
    t0: np.ndarray
    axes: np.ndarray
    ratios: np.ndarray
    fork_of: list
    frame: ShaftFrame
    occupied: np.ndarray       # contact normals of every roller of the layout at φ = 0 (rows)

    @property
    def pole(self) -> np.ndarray:
        """p = u1 × u2, the normal of the axis plane."""
        return np.cross(np.asarray(self.frame.u1, float), np.asarray(self.frame.u2, float))


def steered(layout) -> Steered:
    """The Steered rollers of a numeric layout."""
    rs = [r for r in layout.rollers if r.fork_axis is not None]
    occupied = np.array([pose(r, 0.0)[0] for r in layout.rollers])
    n, a = (np.array([pose(r, 0.0)[j] for r in rs]) for j in (0, 1))
    return Steered([r.name for r in rs], n, a, np.cross(n, a),
                   np.array([np.asarray(r.fork_axis, float).ravel() for r in rs]),
                   np.array([float(r.fork_ratio) for r in rs]), [r.fork for r in rs], shaft_frame(layout),
                   occupied)


def reach(st: Steered, idx, gammas, t0=None, axes=None, ratios=None) -> tuple[np.ndarray, np.ndarray]:
    """(φ, misfit) at each γ [rad] of the steered rollers `idx` (`geometry.steering_angle_guess`), with
    their rolling directions, fork axes or ratios replaced where given (full-length arrays)."""
    idx = list(idx)
    t0, axes, ratios = (st.t0 if t0 is None else t0), (st.axes if axes is None else axes), \
        (st.ratios if ratios is None else ratios)
    return steering_angle_guess(t0[idx], (axes[idx], ratios[idx]), st.frame, gammas)


def linkage_groups(st: Steered, gammas) -> list:
    """The steered rollers (indices) grouped so that the rollers of a group roll about one axis at every γ
    of `gammas` [rad] (their own axes agree), largest group first (ties: file order). A roller that cannot
    reach every γ even on its own is in no group."""
    groups = []
    for i in range(len(st.names)):
        if np.max(reach(st, [i], gammas)[1]) > LINKAGE_TOL:
            continue
        home = next((g for g in groups if np.max(reach(st, g + [i], gammas)[1]) <= LINKAGE_TOL), None)
        if home is None:
            groups.append([i])
        else:
            home.append(i)
    return sorted(groups, key=lambda g: (-len(g), g[0]))


# a fix frees some of: the roller's axle (an angle θ in its tangent plane), its fork's axis, its fork's ratio;
# tried in this order, the simplest first
FREE_SETS = (("ratio",), ("axis",), ("axis", "ratio"), ("axle",), ("axle", "ratio"), ("axle", "axis", "ratio"))
N_AXES = 800        # fork axes screened (a Fibonacci sphere, ~7° apart) besides the special ones
REFINED = 3         # best screened candidates of each set refined by least squares


def _misfits(st: Steered, T, F, R, phis, gammas) -> np.ndarray:
    """t(ρφ_k)·u(γ_k) for candidates (rows of T, F, R: rolling direction at φ = 0, fork axis, ratio) at the
    paired steering angles phis and commanded γ [rad] (K,), shape (C, K): geometry.misfit_terms."""
    terms = linkage_terms(T, (F, R), st.frame, gammas)
    return misfit_terms(terms, R, np.asarray(phis, float)[:, None])[:, 0, :].T


def _miss(st: Steered, i: int, phis, gammas) -> np.ndarray:
    """Angle [rad] between each commanded axis u(γ) and roller i's rolling plane at the paired steering
    angles phis (K,): arcsin |t_i(ρ_iφ)·u|."""
    row = slice(i, i + 1)
    return np.arcsin(np.clip(np.abs(_misfits(st, st.t0[row], st.axes[row], st.ratios[row], phis, gammas)[0]), 0, 1))


def _sphere(n: int) -> np.ndarray:
    """n unit vectors spread evenly over the sphere (Fibonacci lattice)."""
    k = np.arange(n) + 0.5
    z, az = 1 - 2 * k / n, np.pi * (1 + 5 ** 0.5) * k
    r = np.sqrt(1 - z ** 2)
    return np.stack([r * np.cos(az), r * np.sin(az), z], axis=1)


def _screen(st: Steered, i: int, ref: list, law: tuple, free) -> np.ndarray:
    """Candidate parameter vectors x = [θ, axis (3), ρ] (the free ones) to fit from: the roller's own values,
    the pole, its contact normal, the reference forks' axes and their mirror images in the axis plane, their
    ratios and a linear law's rate, the axle that puts t ⊥ the law's axis at φ = 0; then a grid of axes,
    ratios and axle angles. Each entry a row."""
    p = st.pole
    mirror = np.eye(3) - 2 * np.outer(p, p)
    u0 = st.frame.axis(law[0])
    th0 = float(np.arctan2(-(st.t0[i] @ u0), -(st.axles[i] @ u0)))          # t(θ)·u0 = 0
    axes = [st.axes[i], p, -p, st.normals[i]] + [s * m @ st.axes[j] for j in ref for s in (1, -1) for m in (np.eye(3), mirror)]
    ratios = [st.ratios[i]] + [s * st.ratios[j] for j in ref for s in (1, -1)] + ([law[1]] if law[1] else [])
    grid = {"axle": [0.0, th0] + (list(np.linspace(0, np.pi, 36 if "ratio" in free else 180, endpoint=False))
                                  if "axis" not in free else []),
            "axis": list(axes) + list(_sphere(N_AXES)),
            "ratio": ratios + list(np.concatenate([np.logspace(-2, 2, 41), -np.logspace(-2, 2, 41)]))}
    parts = [np.atleast_2d(np.array(grid[k], float)).reshape(len(grid[k]), -1)
             for k in ("axle", "axis", "ratio") if k in free]
    index = np.stack(np.meshgrid(*[np.arange(len(q)) for q in parts], indexing="ij"), -1).reshape(-1, len(parts))
    return np.hstack([q[index[:, k]] for k, q in enumerate(parts)])


def _candidates(st: Steered, i: int, free, X) -> tuple:
    """(T, F, R) of roller i for parameter rows X (see `_screen`), the others at the roller's own values."""
    X, n = np.atleast_2d(X), len(np.atleast_2d(X))
    col = 0
    T, F, R = np.tile(st.t0[i], (n, 1)), np.tile(st.axes[i], (n, 1)), np.full(n, st.ratios[i])
    if "axle" in free:
        th, col = X[:, :1], 1
        T = np.cos(th) * st.t0[i] - np.sin(th) * st.axles[i]            # n × (cos θ a + sin θ t)
    if "axis" in free:
        F, col = X[:, col:col + 3] / np.linalg.norm(X[:, col:col + 3], axis=1, keepdims=True), col + 3
    if "ratio" in free:
        R = X[:, col]
    return T, F, R


def _law(st: Steered, ref: list) -> tuple:
    """(γ [rad] of the reference rollers' axis at φ = 0, its rate dγ/dφ if their law is linear else None):
    the own axis of the first reference roller that steers at φ = 0; a law is linear when every reference
    fork turns about the pole (f = ±p), at the rate ρ (f·p)."""
    p = st.pole
    j = next((j for j in ref if np.linalg.norm(np.cross(st.t0[j], p)) > 1e-9), ref[0])
    u1, u2 = (np.asarray(v, float) for v in (st.frame.u1, st.frame.u2))
    g0 = float(np.arctan2(-(st.t0[j] @ u1), st.t0[j] @ u2))
    linear = all(abs(abs(st.axes[k] @ p) - 1) < 1e-12 for k in ref)
    return g0, (float(st.ratios[ref[0]] * (st.axes[ref[0]] @ p)) if linear else None)


def _fits(st: Steered, ref: list, i: int, cand: tuple, gammas) -> bool:
    """Do the reference rollers, roller i with (t, f, ρ) = cand and its fork mates (same fork: the same f
    and ρ) reach every γ? A fork that carries reference rollers keeps its axis and ratio."""
    t, f, rho = cand
    k = st.fork_of[i]
    mates = [j for j in range(len(st.names)) if j == i or (k is not None and st.fork_of[j] == k)]
    fork_changed = not (np.allclose(f, st.axes[i], atol=1e-12) and rho == st.ratios[i])
    if not 1e-2 <= abs(rho) <= 1e2 or (fork_changed and any(j in ref for j in mates)):
        return False
    t0, axes, ratios = st.t0.copy(), st.axes.copy(), st.ratios.copy()
    t0[i], axes[mates], ratios[mates] = t, f, rho
    return bool(np.max(reach(st, ref + [j for j in mates if j not in ref], gammas, t0, axes, ratios)[1]) <= LINKAGE_TOL)


def _snapped(cand: tuple) -> tuple:
    """The candidate with its fork axis on a frame vector and its ratio on a round number when within 1e-6
    of one (so that the fix reads as a variant file would write it)."""
    t, f, rho = cand
    named = [s * w for w in FRAME.values() for s in (1, -1) if np.allclose(f, s * w, atol=1e-6)]
    return t, (named[0] if named else f), (round(rho, 6) if abs(round(rho, 6) - rho) < 1e-6 else rho)


@dataclass(frozen=True)
class Fix:
    """A change of one steering roller that puts it on the linkage's axis: what changes (some of 'contact',
    'axle', 'axis', 'ratio'; 'contact' moves the roller and sets its axle), its rolling direction t at φ = 0,
    its fork's axis and ratio, and for a move its new contact normal and axle."""
    free: tuple
    t: np.ndarray
    axis: np.ndarray
    ratio: float
    normal: np.ndarray | None = None
    axle: np.ndarray | None = None


def _fitted(st: Steered, ref: list, i: int, gammas) -> Fix | None:
    """The simplest change of roller i's axle, its fork's axis and ratio (FREE_SETS) with which it rolls
    about the reference rollers' axis at every γ [rad]; None if none is found. The candidates of `_screen`
    are ranked by t_i(ρφ)·u(γ) at the reference's φ, the best refined by least squares, and a fit accepted
    only when the linkage then reaches every γ (`_fits`). scipy.optimize is imported here, on the way to a
    refusal: loading a linkage that holds never needs it, and its import costs more than reading a variant."""
    from scipy.optimize import least_squares
    phis = reach(st, ref, gammas)[0]
    law = _law(st, ref)
    for free in FREE_SETS:
        X = _screen(st, i, ref, law, free)
        worst = np.max(np.abs(_misfits(st, *_candidates(st, i, free, X), phis, gammas)), axis=1)

        def residual(x, free=free):
            return _misfits(st, *_candidates(st, i, free, x), phis, gammas)[0]
        for x0 in X[np.argsort(worst, kind="stable")[:REFINED]]:
            x = least_squares(residual, x0, method="trf", xtol=1e-14, ftol=1e-14, gtol=1e-14).x
            T, F, R = _candidates(st, i, free, x)
            cand = (T[0], F[0], float(R[0]))
            for c in (_snapped(cand), cand):
                if _fits(st, ref, i, c, gammas):
                    return Fix(free, *c)
    return None


def images(st: Steered, j: int) -> list:
    """(contact normal, axle, fork axis, ratio) of the places where a roller follows roller j's law
    exactly: j's images in the symmetries of the rule. With M the mirror in the axis plane (M u = u for
    every commanded axis u) and P = −M the half turn about the pole (P u = −u, the same line), t·u = 0 is
    kept by the antipode (−n, a; same fork), by M (Mn, Ma; fork Mf turning the other way, ratio −ρ, as M
    reverses every rotation) and by P (Pn, Pa; fork Pf, ratio ρ). Kim's S2 is S1's mirror image."""
    p = st.pole
    M = np.eye(3) - 2 * np.outer(p, p)
    n, a, f, rho = st.normals[j], st.axles[j], st.axes[j], st.ratios[j]
    return [(-n, a, f, rho), (M @ n, M @ a, M @ f, -rho), (-M @ n, -M @ a, -M @ f, rho)]


def _moved(st: Steered, ref: list, i: int, gammas, taken: list) -> Fix | None:
    """Roller i moved to the free image of a reference roller (`images`) nearest to its contact, with the
    image's axle and fork, when the linkage then reaches every γ [rad]; `taken`: contact normals already
    in use (a moved roller's new one is added)."""
    options = []
    for j in ref:
        for n, a, f, rho in images(st, j):
            if not any(np.allclose(n, m, atol=1e-6) for m in taken):
                options.append((-float(n @ st.normals[i]), n, a, f, rho))
    for _, n, a, f, rho in sorted(options, key=lambda o: o[0]):
        cand = _snapped((np.cross(n, a), f, rho))
        if _fits(st, ref, i, cand, gammas):
            taken.append(n)
            return Fix(("contact",), *cand, normal=n, axle=a)
    return None


def find_fix(st: Steered, ref: list, i: int, gammas, taken: list) -> Fix | None:
    """The simplest change that puts roller i on the reference rollers' axis at every γ [rad]: its fork's
    ratio, axis, its axle (`_fitted`), else a move to an image of a reference roller (`_moved`)."""
    return _fitted(st, ref, i, gammas) or _moved(st, ref, i, gammas, taken)


def direction_text(v) -> str:
    """A unit vector as a variant file may write it: a frame name ('z', '-c2') or three numbers to 10
    digits (within 1e-10, well inside the linkage's tolerance)."""
    v = np.asarray(v, float)
    for name, w in FRAME.items():
        for sign in ("", "-"):
            if name != "d3" and np.allclose(v, w if not sign else -w, atol=1e-9):
                return sign + name
    return "[" + ", ".join(f"{x + 0.0:.10g}" for x in np.where(np.abs(v) < 1e-12, 0.0, v)) + "]"


def _number(x: float) -> str:
    """A fitted ratio, as the simple number it is when it is one ('-1', '0.5'), else to 10 digits."""
    simple = round(x, 6)
    return f"{simple:g}" if abs(simple - x) < 1e-9 else f"{x:.10g}"


def fix_text(st: Steered, i: int, fix: Fix | None) -> str:
    """'steering.forks[1].ratio: -1': the fields that change, as a variant file writes them."""
    if fix is None:
        return f"no contact, axle, fork axis or ratio of {st.names[i]} alone puts it on that axis"
    where = f"rollers.{st.names[i]}."
    parts = [f"{where}contact: {direction_text(fix.normal)}, axle: {direction_text(fix.axle)}"] \
        if "contact" in fix.free else []
    if "axle" in fix.free:
        parts.append(f"{where}axle: {direction_text(np.cross(fix.t, st.normals[i]))}")
    values = {"axis": direction_text(fix.axis), "ratio": _number(fix.ratio)}
    changed = [k for k in ("axis", "ratio") if k in fix.free or ("contact" in fix.free and (
        not np.allclose(fix.axis, st.axes[i], atol=1e-9) if k == "axis" else fix.ratio != st.ratios[i]))]
    if changed:
        fork = "its fork's " if st.fork_of[i] is None else f"steering.forks[{st.fork_of[i]}]."
        parts.append(fork + ", ".join(f"{k}: {values[k]}" for k in changed))
    return " and ".join(parts)


def _offences(st: Steered, ref: list, gammas) -> list:
    """(roller, largest miss [rad], γ of it [rad]) of every roller outside the reference group, at the
    reference rollers' steering angles."""
    phis = reach(st, ref, gammas)[0]
    out = []
    for i in (i for i in range(len(st.names)) if i not in ref):
        miss = _miss(st, i, phis, gammas)
        out.append((i, float(np.max(miss)), float(gammas[int(np.argmax(miss))])))
    return out


def _and(names: list) -> str:
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


def _fix_clauses(st: Steered, ref: list, offenders: list, gammas, taken: list) -> tuple[list, bool]:
    """('fix S1 and S2 with steering.forks[1].ratio: 1', ...), one clause per distinct change (fork mates
    fixed by one change of their fork share a clause); and whether every offender has a fix."""
    clauses, complete = {}, True
    for i in offenders:
        fix = find_fix(st, ref, i, gammas, taken)
        complete &= fix is not None
        clauses.setdefault(fix_text(st, i, fix), []).append(st.names[i])
    return [text if text.startswith("no ") else f"fix {_and(names)} with {text}"
            for text, names in clauses.items()], complete


def refusal(layout, gammas) -> str:
    """The one-line refusal of a linkage that does not reach every γ of `gammas` [rad] (the layout checks
    call it when the misfit exceeds LINKAGE_TOL): the rollers that break the rule, by how much and where,
    and for each the simplest change that would make it fit, or the rule's remedy (forks about the pole)."""
    st = steered(layout)
    groups = linkage_groups(st, gammas)
    rule = (f"or put every fork about the pole {direction_text(st.pole)} with one ratio, each axle through the "
            "commanded axis at φ = 0 (the rule: docs/linkages.md)")
    if not groups:
        return (f"{layout.file}: steering.forks: no steering roller can roll about the commanded axis at every γ of "
                f"the envelope, whatever the steering angle ({', '.join(st.names)}); {rule.removeprefix('or ')}")
    ref = groups[0]
    offences = _offences(st, ref, gammas)
    names = [st.names[i] for i, _, _ in offences]
    head = (f"{layout.file}: steering.forks: {_and([n + chr(39) + 's' for n in names])} "
            f"axle{'s do' if len(names) > 1 else ' does'} not pass through the commanded axis that "
            f"{_and([st.names[i] for i in ref])} steer{'s' if len(ref) == 1 else ''} the sphere to (")
    head += ", ".join(f"{st.names[i]} misses it by up to {np.degrees(m):.3g}° at γ = {np.degrees(g):.0f}°"
                      for i, m, g in offences) + ")"
    if max(m for _, m, _ in offences) < ROUNDED:
        return (head + "; directions look rounded: write them as frame names, '= expressions' or in full "
                "precision (docs/linkages.md)")
    taken = list(st.occupied)
    clauses, complete = _fix_clauses(st, ref, [i for i, _, _ in offences], gammas, taken)
    moved = len(taken) > len(st.occupied)
    tail = " (the rule: docs/linkages.md)" if complete and not moved else "; " + rule
    return head + "; " + "; ".join(clauses) + tail
