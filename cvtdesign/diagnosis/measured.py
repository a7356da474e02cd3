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
from cvtdesign.io.measured_csv import read_measured

GAMMA_TOL_DEG = 1e-6     # [deg] commanded angles closer than this are one operating point

FOLDS = 5                # the diagnosis's cross-validation folds (diagnose.FOLDS)


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
        return bool(self.rows.groupby("point").size().max() > 1)


def load_measured(path, layout, drop_bad: bool = False) -> Measured:
    """Read a measured-data CSV for a variant: α, τ⊥ and τ∥ with its shaft kinematics, γ checked against its
    envelope."""
    g = np.degrees(layout.gamma_grid)
    rows, dropped = read_measured(path, (float(g.min()), float(g.max())), drop_bad)
    return from_rows(rows, shaft_frame(layout), str(path), dropped)


def from_rows(rows: pd.DataFrame, frame: ShaftFrame, where: str = "data", dropped: dict | None = None) -> Measured:
    """A Measured from rows already in the measured-data columns (numbers, checked): the derived α, τ⊥, τ∥
    and efficiency with the variant's shaft kinematics, and the operating points. `line` (the CSV line of
    each row) is numbered from 2 when the rows have none."""
    rows = rows.reset_index(drop=True).copy()
    if "line" not in rows.columns:
        rows.insert(0, "line", np.arange(len(rows)) + 2)
    g = np.radians(rows["gamma_cmd_deg"].to_numpy())
    w1, w2 = rows["omega_1"].to_numpy(), rows["omega_2"].to_numpy()
    rows["alpha_deg"] = np.degrees(frame.slip_angle(w1, w2, g))
    rows["tau_perp"], rows["tau_par"] = frame.load_split(g, rows["tau_1"].to_numpy(), rows["tau_2"].to_numpy())
    rows["efficiency"] = efficiency(rows["tau_1"] * rows["omega_1"], rows["tau_2"] * rows["omega_2"])
    m = Measured(where, rows, "gamma_axis_deg" in rows.columns, dropped or {})
    _group(m)
    return m


def _levels(values, tol):
    """Cluster sorted 1-D values into levels: a gap larger than `tol` starts a new level."""
    order = np.argsort(values)
    label = np.empty(len(values), int)
    level, last, groups = 0, None, [[]]
    for k in order:
        if last is not None and values[k] - last > tol:
            level += 1
            groups.append([])
        label[k] = level
        groups[-1].append(values[k])
        last = values[k]
    return label, np.array([np.mean(g) for g in groups])


def _group(m: Measured):
    """Operating points: the same commanded γ, load level and motor-speed level. Loads and speeds are
    measured, so replicates differ by the noise: τ⊥ levels are clusters of the measured τ⊥ separated by more
    than 2.5 % of its range (a rig's load levels are steps, Kim's 0.1-0.2 N m), speed levels clusters of ω1
    separated by more than 5 % of its largest magnitude."""
    r = m.rows
    gl, glev = _levels(r["gamma_cmd_deg"].to_numpy(), GAMMA_TOL_DEG)
    tp = r["tau_perp"].to_numpy()
    span = float(np.ptp(tp)) if len(tp) > 1 else 0.0
    ll, llev = _levels(tp, max(0.025 * span, 1e-9))
    w = r["omega_1"].to_numpy()
    sl, slev = _levels(w, 0.05 * float(np.max(np.abs(w))))
    r["gamma_bin"], r["load_bin"], r["speed_bin"] = gl, ll, sl
    r["point"] = pd.factorize(pd.Series((sl * len(glev) + gl) * (len(llev) + 1) + ll))[0]
    m.gamma_levels, m.load_levels, m.speed_levels = glev, llev, slev


MEASURED_CHANNELS = {"alpha": "alpha_deg", "tau_par": "tau_par", "axis": "gamma_axis_deg"}


def merge_points(data: Measured) -> Measured:
    """The dataset with its replicates merged: one row per operating point, with the mean of every measured
    and derived column (α, τ⊥, τ∥ and the axis angle averaged as measured; efficiency from the mean powers),
    its `count` of replicates, and the point's levels. A diagnosis predicts and fits at these points, so
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
    merged = g[cols].mean()
    merged[["gamma_bin", "load_bin", "speed_bin"]] = g[["gamma_bin", "load_bin", "speed_bin"]].first()
    merged["count"] = g.size()
    merged["line"] = g["line"].first()
    merged["efficiency"] = efficiency(merged["tau_1"] * merged["omega_1"], merged["tau_2"] * merged["omega_2"])
    merged = merged.reset_index()
    return Measured(data.file, merged, data.has_axis, data.dropped, data.gamma_levels, data.load_levels,
                    data.speed_levels)
