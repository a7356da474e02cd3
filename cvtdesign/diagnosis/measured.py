"""A measured dataset as the diagnosis uses it: the rows of a measured-data CSV (io.measured_csv) with what is
derived from them, and their operating points.

Derived per row with the variant's own shaft kinematics (core.kinematics): slip angle α (for Kim's layout
atan2(ω2·r2/r1, ω1) − γ_cmd, Kim et al., "Causes of microslip in a continuously variable transmission", eqs
15 and 35), lateral load τ⊥ and parallel torque τ∥ (for Kim's layout −τ1 sin γ + τ2 cos γ and
τ1 cos γ + τ2 sin γ, Kim eq 17), and efficiency = power out / power in.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from cvtdesign.core.kinematics import ShaftFrame, shaft_frame
from cvtdesign.core.metrics import efficiency
from cvtdesign.errors import InputError
from cvtdesign.io.measured_csv import read_measured, read_measured_frame

GAMMA_TOL_DEG = 1e-6     # [deg] commanded angles closer than this are one operating point
IMPLAUSIBLE_ALPHA_DEG = 20.0   # [deg] a median |α| beyond this is no rolling contact's: the signs are checked
STILL_SHARE = 0.01             # an output shaft never faster than this share of its typical ideal speed never turns
WRONG_POWER_SHARE = 0.75       # rows breaking a passive transmission's energy balance beyond which torque signs are wrong

FOLDS = 5                # the diagnosis's cross-validation folds, grouped by operating point (diagnose.crossval)


MIN_POINTS = 2 * FOLDS   # operating points a fit needs: every fold holds out ≥ 2 and fits on ≥ 8 (merge_points)


@dataclass
class Measured:
    """A validated dataset. `rows` has the measured-data columns (docs/measured-data.md) plus alpha_deg, tau_perp, tau_par, efficiency, point
    (operating-point index: replicates share it), gamma_bin, load_bin and speed_bin (the γ, τ⊥ and ω1 levels)."""
    file: str
    rows: pd.DataFrame
    has_axis: bool
    dropped: dict = field(default_factory=dict)     # reason -> count (only with drop_bad)
    gamma_levels: np.ndarray = None                 # [deg]
    load_levels: np.ndarray = None                  # [N m]
    speed_levels: np.ndarray = None                 # [rad/s]

    @property
    def replicated(self) -> bool:
        """Whether replicates are the rule: at least half the rows repeat an operating point (as _group asks
        of them); a few repeated rows (a sweep's turning point measured twice) say too little of the noise
        at every other γ."""
        size = self.rows.groupby("point")["point"].transform("size")
        return bool(np.mean(size > 1) >= 0.5)


def load_measured(path, layout, drop_bad: bool = False) -> Measured:
    """Read a measured-data CSV for a variant: α, τ⊥ and τ∥ with its shaft kinematics, γ checked against its
    envelope."""
    g = np.degrees(layout.gamma_grid)
    rows, dropped = read_measured(path, (float(g.min()), float(g.max())), drop_bad, shaft_capacity(layout))
    return from_rows(rows, shaft_frame(layout), str(path), dropped)


def measured_frame(frame, layout, drop_bad: bool = False, where: str = "data") -> Measured:
    """load_measured of measured data given as a DataFrame in the CSV's columns (docs/measured-data.md),
    checked as a file's rows are (io.measured_csv.read_measured_frame)."""
    g = np.degrees(layout.gamma_grid)
    rows, dropped = read_measured_frame(frame, where, (float(g.min()), float(g.max())), drop_bad, shaft_capacity(layout))
    return from_rows(rows, shaft_frame(layout), where, dropped)


def shaft_capacity(layout) -> dict:
    """{tau_1, tau_2}: the torque [N m] each shaft's rollers can pass through their contacts at their preloads,
    Σ |ρ_i| r_i μ_i P_i (μ_i the friction coefficient of the roller's pair of materials): what a
    measured torque is checked against (a tenfold margin covers normal forces that grow under load)."""
    return {f"tau_{s}": sum(abs(float(r.ratio)) * float(r.radius) * float(r.friction.mu) * float(r.preload)
                            for r in layout.rollers if r.shaft == s) for s in (1, 2)}


def from_rows(rows: pd.DataFrame, frame: ShaftFrame, where: str = "data", dropped: dict | None = None) -> Measured:
    """A Measured from rows already in the measured-data columns (numbers, checked): the derived α, τ⊥, τ∥
    and efficiency with the variant's shaft kinematics, and the operating points. `line` (the CSV line of
    each row) is numbered from 2 when the rows have none."""
    rows = rows.reset_index(drop=True).copy()
    if "line" not in rows.columns:
        rows.insert(0, "line", np.arange(len(rows)) + 2)
    g = np.radians(rows["gamma_cmd_deg"].to_numpy())
    w1, w2 = rows["omega_1"].to_numpy(), rows["omega_2"].to_numpy()
    _check_output_turns(w1, w2, g, frame, where)
    rows["alpha_deg"] = np.degrees(frame.slip_angle(w1, w2, g))
    if len(rows) >= MIN_POINTS:      # a handful of rows says nothing about conventions
        _check_signs(rows["alpha_deg"].to_numpy(), frame, w1, w2, g, where)
        _check_power(w1 * rows["tau_1"].to_numpy(), w2 * rows["tau_2"].to_numpy(), where)
    rows["tau_perp"], rows["tau_par"] = frame.load_split(g, rows["tau_1"].to_numpy(), rows["tau_2"].to_numpy())
    rows["efficiency"] = efficiency(rows["tau_1"] * rows["omega_1"], rows["tau_2"] * rows["omega_2"])
    m = Measured(where, rows, "gamma_axis_deg" in rows.columns, dropped or {})
    _group(m)
    return m


def _check_output_turns(w1, w2, g, frame: ShaftFrame, where: str) -> None:
    """Refuse data whose output shaft never turns (ω2 = 0 in every row: an encoder not connected) where the
    ideal law has it turn: they say nothing of the slip or the speed ratio, and a fit to them ends on its
    parameters' bounds (a drive creep scale of 50, its bound, after 74 s)."""
    if not w2.size:
        return
    ideal = np.abs(np.asarray(frame.ideal_ratio(g), float) * w1)
    turns = ideal > 1e-9 * np.max(np.abs(w1))
    top = float(np.max(np.abs(w2)))
    if turns.any() and top <= STILL_SHARE * float(np.median(ideal[turns])):
        got = "0" if top == 0 else f"at most {top:.3g} rad/s"
        raise InputError(f"{where}: omega_2: {got} in every row, where the ideal law has the output shaft turn at "
                         f"{int(turns.sum())} of the {w2.size} rows (typically at {np.median(ideal[turns]):.3g} "
                         "rad/s); such data say nothing of the slip or the speed ratio; expected the output "
                         "shaft's measured speed (docs/measured-data.md)")


def _check_signs(alpha_deg, frame: ShaftFrame, w1, w2, g, where: str) -> None:
    """Refuse data whose slip angles are implausible (median |α| beyond IMPLAUSIBLE_ALPHA_DEG) where reversing
    the sign of ω2 or of γ_cmd, or reading γ_cmd as radians, makes them plausible: the data then count that
    quantity the other way round from the variant's conventions (docs/measured-data.md, Signs), and a
    diagnosis would fit a gap that is not there."""
    typical = float(np.median(np.abs(alpha_deg)))
    if typical <= IMPLAUSIBLE_ALPHA_DEG:
        return
    trials = {("omega_2", "omega_2's sign reversed"): (w1, -w2, g),
              ("gamma_cmd_deg", "gamma_cmd_deg's sign reversed"): (w1, w2, -g),
              ("omega_2", "the signs of omega_2 and gamma_cmd_deg reversed"): (w1, -w2, -g),
              ("gamma_cmd_deg", "gamma_cmd_deg read as radians"): (w1, w2, np.degrees(g))}
    medians = {k: float(np.median(np.abs(np.degrees(frame.slip_angle(*a))))) for k, a in trials.items()}
    best = min(medians.values())
    # where the ideal law is odd in γ (Kim's tan γ), reversing ω2 and reversing γ give the same |α|: both named
    alike = [k for k, v in medians.items() if v <= best * (1 + 1e-9) + 1e-12]
    columns = ", ".join(dict.fromkeys(k[0] for k in alike))
    expected = "gamma_cmd_deg in degrees" if "radians" in alike[0][1] else \
        "ω positive about each shaft's drive roller's declared axle and γ as the variant's shaft frame defines it"
    if best <= min(IMPLAUSIBLE_ALPHA_DEG / 2, typical / 4):
        raise InputError(f"{where}: {columns}: the rows imply slip angles of {typical:.0f}° (median |α|), beyond any "
                         f"rolling contact's; with {' or '.join(k[1] for k in alike)} they are {best:.2g}°: "
                         f"expected {expected} (docs/measured-data.md)")


def _check_power(p1, p2, where: str) -> None:
    """Refuse torques whose signs break the energy balance of a passive transmission. The powers into the CVT
    at its shafts, p_s = τ_s ω_s, have opposite signs (power passes from one shaft to the other) and sum to
    its losses, ≥ 0; where the load is near zero, the noise gives either sign. So if most rows
    (WRONG_POWER_SHARE) have both powers of one sign, one torque counts positive the other way round; if
    most give out more power than they take in, both do (torques exerted by the shafts, not applied to them)."""
    same_sign = float(np.mean(np.sign(p1) * np.sign(p2) > 0))
    net_out = float(np.mean(p1 + p2 < 0))
    expected = ("expected the torques applied to the shafts from outside, positive in the sense of positive ω "
                "(docs/measured-data.md, Signs)")
    if same_sign > WRONG_POWER_SHARE:
        raise InputError(f"{where}: tau_1, tau_2: power enters the CVT at both shafts, or leaves at both, at "
                         f"{same_sign:.0%} of the rows, where a transmission passes it from one shaft to the other: "
                         f"one of the two torques counts positive the other way round; {expected}")
    if net_out > WRONG_POWER_SHARE:
        raise InputError(f"{where}: tau_1, tau_2: the CVT gives out more power than it takes in (τ1ω1 + τ2ω2 < 0) at "
                         f"{net_out:.0%} of the rows (median {np.median(p1 + p2):+.3g} W): the torques look like those "
                         f"the shafts exert, with both signs reversed; {expected}")


def _levels(values, tol, relative: bool = False):
    """Cluster sorted 1-D values into levels: a gap larger than `tol` (with `relative`, than `tol` × the larger
    magnitude of its two ends) starts a new level."""
    order = np.argsort(values)
    label = np.empty(len(values), int)
    level, last, groups = 0, None, [[]]
    for k in order:
        if last is not None and values[k] - last > (tol * max(abs(last), abs(values[k])) if relative else tol):
            level += 1
            groups.append([])
        label[k] = level
        groups[-1].append(values[k])
        last = values[k]
    return label, np.array([np.mean(g) for g in groups])


def _compact_levels(values, tol: float, ratio: float = 2.0):
    """Levels of 1-D measured values (labels, level means). A level is a run of sorted values that is
    compact: its width within `tol` and at most 1/`ratio` of the gaps that separate it from the values either
    side. Runs that are not are split at their widest gap, from the whole range down. So replicates of one
    commanded load (spread by noise, far from the next load) form a level, and loads a fine step apart or
    swept continuously stay apart (a plain gap threshold chained 0.04 N·m steps into one level, and merged
    random loads 0.13 N·m apart as "replicates")."""
    values = np.asarray(values, float)
    order = np.argsort(values, kind="stable")
    v = values[order]
    gaps = np.diff(v)
    outer = np.r_[np.inf, gaps, np.inf]          # outer[i]: the gap before sorted value i; outer[i + 1] after it
    label, means, stack = np.empty(len(v), int), [], [(0, len(v) - 1)]
    while stack:
        a, b = stack.pop()
        width = v[b] - v[a]
        if a == b or (width <= tol and ratio * width <= min(outer[a], outer[b + 1])):
            label[order[a:b + 1]] = len(means)
            means.append(v[a:b + 1].mean())
            continue
        k = a + int(np.argmax(gaps[a:b]))
        stack += [(k + 1, b), (a, k)]
    rank = np.argsort(np.argsort(means))          # levels numbered in increasing value
    return rank[label], np.sort(means)


def _group(m: Measured):
    """Operating points: replicates of one commanded γ, load and motor-speed level. Loads and speeds are
    measured, so replicates differ by the noise. Speed levels are clusters of ω1 separated by more than 5 %
    of their magnitude. At each γ and speed level, a point is a compact level of the measured τ⊥
    (_compact_levels, no wider than 5 % of the range, or the size, of the central 96 % of τ⊥); the load
    levels shared by every γ (the grid of the residual map) chain the points' mean τ⊥ closer than half the
    median of the smallest load step at each γ. Unless at least
    half the rows have a replicate, none is taken for one: 11 random loads at each γ met by chance in pairs up
    to 0.1 N·m apart, and their scatter made a noise estimate 7× too large. No tolerance depends on the
    extremes, so one wild row is a point of its own instead of merging the others."""
    r = m.rows
    gl, glev = _levels(r["gamma_cmd_deg"].to_numpy(), GAMMA_TOL_DEG)
    sl, slev = _levels(r["omega_1"].to_numpy(), 0.05, relative=True)
    tp = r["tau_perp"].to_numpy()
    lo, hi = np.percentile(tp, [2, 98])      # a single commanded load: its range is the noise, its size is not
    tol = max(0.05 * max(hi - lo, abs(lo), abs(hi)), 1e-9)
    point, loads, steps = np.empty(len(tp), int), [], []
    for idx in pd.Series(np.arange(len(tp))).groupby([sl, gl]).indices.values():
        label, means = _compact_levels(tp[idx], tol)
        point[idx] = len(loads) + label
        loads.extend(means)
        if len(means) > 1:
            steps.append(np.min(np.diff(means)))
    if np.sum(np.bincount(point)[point] > 1) < 0.5 * len(tp):   # replicates are the rule or there are none:
        point, loads = np.arange(len(tp)), tp                   # loads drawn at random meet by chance
    # the levels every γ shares: the points' mean loads chained closer than half the typical load step;
    # with no γ measured at two loads (a random protocol) there is no step, and each point's load is its own
    # level (chaining them by a fixed tolerance made one level of 187 random loads)
    load_of_point, llev = _levels(np.array(loads), 0.5 * float(np.median(steps)) if steps else 0.0)
    r["gamma_bin"], r["load_bin"], r["speed_bin"] = gl, load_of_point[point], sl
    r["point"] = pd.factorize(pd.Series(point))[0]
    m.gamma_levels, m.load_levels, m.speed_levels = glev, llev, slev


MEASURED_CHANNELS = {"alpha": "alpha_deg", "tau_par": "tau_par", "axis": "gamma_axis_deg"}


def merge_points(data: Measured) -> Measured:
    """The dataset with its replicates merged: one row per operating point, with the mean of every measured
    and derived column (α, τ⊥, τ∥ and the axis angle averaged as measured; efficiency from the mean powers;
    the mean time), its `count` of replicates, and the point's levels (and, for data split by the direction
    of approach, its `approach` and `origin`, the point it was split from). A diagnosis predicts and fits at these points, so
    its cost grows with the operating points, not the rows; the noise of a mean is σ/√count.

    A fit and its FOLDS-fold cross-validation (grouped by operating point) need at least MIN_POINTS = 10
    operating points: fewer is one InputError line naming the file."""
    r = data.rows
    n = int(r["point"].nunique())
    if n < MIN_POINTS:
        rows = f"{len(r)} row{'s' if len(r) != 1 else ''}"
        raise InputError(f"{data.file}: {n} operating point{'s' if n != 1 else ''} ({rows}); expected at least "
                         f"{MIN_POINTS} distinct operating points (γ, load, motor speed) for the fit and its "
                         f"{FOLDS}-fold cross-validation")
    cols = [c for c in ("gamma_cmd_deg", "omega_1", "omega_2", "tau_1", "tau_2", "gamma_axis_deg", "alpha_deg",
                        "tau_perp", "tau_par") if c in r.columns]
    g = r.groupby("point", sort=True)
    merged = g[cols + [c for c in ("time_s",) if c in r.columns]].mean()
    levels = ["gamma_bin", "load_bin", "speed_bin"] + [c for c in ("approach", "origin") if c in r.columns]
    merged[levels] = g[levels].first()
    merged["count"] = g.size()
    merged["line"] = g["line"].first()
    merged["efficiency"] = efficiency(merged["tau_1"] * merged["omega_1"], merged["tau_2"] * merged["omega_2"])
    merged = merged.reset_index()
    return Measured(data.file, merged, data.has_axis, data.dropped, data.gamma_levels, data.load_levels,
                    data.speed_levels)
