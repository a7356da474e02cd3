"""Every contact's state at every operating point, as a table (`cvtdesign compare --points FILE`): one row per
variant × operating point × contact, written as CSV or Parquet by the file's extension.

Columns (fixed: outside tools rely on them; more may follow at the end):

| column | unit | what |
| --- | --- | --- |
| variant | | the variant's name |
| gamma_cmd_deg | ° | commanded transmission angle γ |
| tau_perp_Nm | N·m | lateral load τ⊥ |
| status | | the point's status (ok, not_converged, lost_contact, gross_slip, reversed, multiple_roots) |
| roller, role | | the roller's name and role (drive, follower, steering) |
| N_N | N | normal force |
| xi, eta | - | creepages of the sphere over the roller along the rolling direction x and along the axle, y |
| phi_1_m | 1/m | spin creepage: the sphere's angular velocity about the contact normal n over the rolling speed |
| F_long_N, F_lat_N | N | tangential force on the sphere along x and along y |
| M_spin_Nm | N·m | moment of the patch's tractions on the sphere about n |
| utilisation | - | \\|F\\|/(μN) |
| a_mm, b_mm | mm | the Hertz patch's semi-axes along t and across it, at N |
| p0_MPa | MPa | Hertz peak pressure at N |
| G_MPa | MPa | combined shear modulus |
| mu | - | friction coefficient |
| C11, C22, C23 | - | creep coefficients as the law used them (calibration included): small-creepage force slopes G·a·b·C11 along t, G·a·b·C22 along a, G·(ab)^1.5·C23 per unit spin |
| loss_W | W | power lost at the contact (creep, spin and rolling resistance) |
| T_fork_Nm | N·m | torque the steering actuator applies about the roller's fork axis while the contact rolls (0 on no fork) |
| T_fork_standstill_Nm | N·m | torque to turn the fork with the sphere at rest, its patch sliding (0 on no fork) |

The frame is Kalker's patch frame, so that the rows can be checked against any rolling-contact code: n is the
sphere's outward normal at the contact, x the rolling direction (the way the contact travels over both
surfaces, so their material passes through the patch along −x), y = n × x, along the roller's axle; a creepage
is the slip velocity of the sphere over the roller divided by the rolling speed (docs/comparing.md). Points
that are not ok keep their status and carry no numbers (empty in CSV, null in Parquet).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cvtdesign.core.status import STATUS
from cvtdesign.errors import InputError
from cvtdesign.io.output import write_file

# column → (model output, factor); the model's outputs are SI
NUMBERS = {"N_N": ("N", 1.0), "xi": ("xi", 1.0), "eta": ("eta", 1.0), "phi_1_m": ("spin", 1.0),
           "F_long_N": ("F_t", 1.0), "F_lat_N": ("F_a", 1.0), "M_spin_Nm": ("M_spin", 1.0),
           "utilisation": ("utilisation", 1.0), "a_mm": ("a", 1e3), "b_mm": ("b", 1e3), "p0_MPa": ("p_max", 1e-6),
           "G_MPa": ("G", 1e-6), "mu": ("mu", 1.0), "C11": ("C11", 1.0), "C22": ("C22", 1.0), "C23": ("C23", 1.0),
           "loss_W": ("loss", 1.0), "T_fork_Nm": ("T_fork", 1.0), "T_fork_standstill_Nm": ("T_fork_standstill", 1.0)}
COLUMNS = ["variant", "gamma_cmd_deg", "tau_perp_Nm", "status", "roller", "role", *NUMBERS]
FORMATS = (".csv", ".parquet")


def check_points_path(path) -> Path:
    """The --points path, refused unless its extension names a format (before any work)."""
    path = Path(path)
    if path.suffix.lower() not in FORMATS:
        raise InputError(f"--points {path}: unknown format '{path.suffix}'; expected a file ending in "
                         f"{' or '.join(FORMATS)}")
    return path


def contact_points(name: str, layout, res: dict) -> dict[str, np.ndarray]:
    """The rows of one variant's envelope result (core.metrics.envelope), as columns (COLUMNS): points in
    γ-major order, then contacts in the layout's order."""
    status = np.asarray(res["status"]).ravel()
    n_points, rollers = status.size, layout.rollers
    frame = {"variant": np.repeat(name, n_points * len(rollers)),
             "gamma_cmd_deg": np.repeat(np.degrees(np.ravel(res["gamma_cmd"])), len(rollers)),
             "tau_perp_Nm": np.repeat(np.ravel(res["load"]), len(rollers)),
             "status": np.repeat(np.array(STATUS)[status], len(rollers)),
             "roller": np.tile([r.name for r in rollers], n_points),
             "role": np.tile([r.role for r in rollers], n_points)}
    sign = np.asarray(res["roll_sign"], float).reshape(len(rollers), n_points)
    flip = {"xi": sign, "eta": -sign, "F_long_N": sign, "F_lat_N": -sign}      # (t, a) → Kalker's (x, y)
    for column, (key, factor) in NUMBERS.items():
        values = np.asarray(res[key], float).reshape(len(rollers), n_points) * flip.get(column, 1.0)
        frame[column] = (values.T * factor).ravel()
    return {column: frame[column] for column in COLUMNS}


def data_frame(data, columns=None):
    """A pandas DataFrame of `data` (columns → arrays, or a list of rows as dicts), with `columns` in that order.
    pandas is imported here, the one place that needs it (the --points table and the Python API's tables): a
    compare without --points never loads it (its import costs what the rest of the command's imports do)."""
    import pandas as pd
    return pd.DataFrame(data, columns=columns)


def points_frame(frames: list[dict]):
    """The rows of every variant (contact_points' columns, in COLUMNS' order) as one DataFrame."""
    import pandas as pd
    return pd.concat([pd.DataFrame(f, columns=COLUMNS) for f in frames], ignore_index=True)


def write_points(path, frames: list[dict]) -> Path:
    """Write the rows of every variant (contact_points' columns) to `path`, CSV or Parquet by its extension,
    through the one writer (the table: points_frame)."""
    path = check_points_path(path)
    table = points_frame(frames)
    if path.suffix.lower() == ".parquet":
        return write_file(path, lambda tmp: table.to_parquet(tmp, index=False), kind="--points")
    return write_file(path, table.to_csv(index=False, float_format="%.9g"), kind="--points")
