"""Measured data in the project's CSV format: read and validate (the dataset it becomes: diagnosis.measured).

One operating point per CSV row: `gamma_cmd_deg` [deg], `omega_1`, `omega_2` [rad/s], `tau_1`, `tau_2`
[N m] (external torques, positive in the sense of positive ω), optionally `gamma_axis_deg` [deg] (the
measured axis angle) and `time_s` [s] (when the row was measured; else the rows' order is their order in
time). Other columns are ignored. Rows that repeat an operating point are replicates.

docs/measured-data.md describes the format.
"""
from __future__ import annotations

import io

import numpy as np
import pandas as pd

from cvtdesign.errors import InputError, shorten, suggest

REQUIRED = ("gamma_cmd_deg", "omega_1", "omega_2", "tau_1", "tau_2")
OPTIONAL = ("gamma_axis_deg", "time_s")
CAPACITY_MARGIN = 10.0   # a measured shaft torque may be at most this many times what its contacts carry at preload
# the largest magnitude a measurement can have: beyond it a cell is a corrupt or mis-scaled value, not a rig's
PLAUSIBLE = {"omega_1": (1e4, "rad/s", "shaft speed"), "omega_2": (1e4, "rad/s", "shaft speed"),
             "tau_1": (1e4, "N·m", "shaft torque"), "tau_2": (1e4, "N·m", "shaft torque")}


def read_measured(path, gamma_range_deg=None, drop_bad: bool = False, capacity=None) -> tuple[pd.DataFrame, dict]:
    """Read and check a measured-data CSV.

    frame: the variant's shaft kinematics (α, τ⊥, τ∥ as kinematics.py defines them); gamma_range_deg:
    (lo, hi) the variant's operating range [deg]; capacity: {tau_1, tau_2} the torques [N m] the variant's
    contacts can carry on each shaft at their preloads (`shaft_capacity`), of which a measured torque may be at
    most CAPACITY_MARGIN times. Every problem is one InputError line naming the file, the line (the
    header is line 1) or the column, and what was expected. With `drop_bad`, rows with empty or non-numeric
    cells (non-finite ones too: 'inf' is not a measurement), speeds or torques beyond PLAUSIBLE, a motor shaft at
    rest or γ outside the range are dropped and counted instead. The file must be UTF-8 text (the line of the first other byte is named)."""
    where = str(path)
    try:
        with open(path, "rb") as f:
            data = f.read()
    except FileNotFoundError:
        raise InputError(f"{where}: no such file") from None
    except OSError as e:
        raise InputError(f"{where}: cannot read file ({e.strerror or type(e).__name__})") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data[:e.start].count(b"\n") + 1
        raise InputError(f"{where}: line {line}: not a readable CSV file (byte 0x{data[e.start]:02x} is not UTF-8 "
                         "text); expected UTF-8 text with the header " + ",".join(REQUIRED)) from None
    if "\x00" in text:
        line = text[:text.index("\x00")].count("\n") + 1
        raise InputError(f"{where}: line {line}: not a readable CSV file (a NUL byte: binary data, not text); "
                         "expected UTF-8 text with the header " + ",".join(REQUIRED))
    try:
        raw = pd.read_csv(io.StringIO(text), dtype=str, keep_default_na=False, skipinitialspace=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as e:
        raise InputError(f"{where}: not a readable CSV file ({' '.join(str(e).split()) or type(e).__name__})") from None
    return checked_rows(raw, where, gamma_range_deg, drop_bad, capacity)


def read_measured_frame(frame: pd.DataFrame, where: str = "data", gamma_range_deg=None, drop_bad: bool = False,
                        capacity=None) -> tuple[pd.DataFrame, dict]:
    """Check measured data given as a DataFrame in the CSV's columns (the Python API's diagnose) exactly as
    read_measured checks a file's: each cell is taken as the text a CSV would hold (an empty or NaN cell is
    bad), a row named by the line it would have in a CSV (the header is line 1)."""
    raw = frame.reset_index(drop=True).astype(object).where(frame.reset_index(drop=True).notna(), "").astype(str)
    return checked_rows(raw, where, gamma_range_deg, drop_bad, capacity)


def checked_rows(raw: pd.DataFrame, where: str, gamma_range_deg=None, drop_bad: bool = False,
                 capacity=None) -> tuple[pd.DataFrame, dict]:
    """The rows of a measured-data table of text cells (read_measured's arguments), checked."""
    raw.columns = [str(c).strip() for c in raw.columns]
    twice = [c for c in REQUIRED + OPTIONAL if f"{c}.1" in raw.columns]     # pandas renames a repeated name
    if twice:
        raise InputError(f"{where}: column '{twice[0]}' appears more than once in the header; expected each column once")
    for c in REQUIRED:
        if c not in raw.columns:
            other = [x for x in raw.columns if x not in REQUIRED + OPTIONAL]
            raise InputError(f"{where}: missing column '{c}'{suggest(c, other)} "
                             f"(required: {', '.join(REQUIRED)}; found: {', '.join(raw.columns) or 'none'})")
    if raw.empty:
        raise InputError(f"{where}: no data rows under the header")
    num, bad, kind = _cells(raw, list(REQUIRED) + [c for c in OPTIONAL if c in raw.columns], capacity or {})
    if gamma_range_deg is not None:
        lo, hi = gamma_range_deg
        out = ~num["gamma_cmd_deg"].between(lo - 1e-9, hi + 1e-9) & bad.eq("") & num["gamma_cmd_deg"].notna()
        for i in raw.index[out]:
            bad[i] = (f"gamma_cmd_deg = {num['gamma_cmd_deg'][i]:g} is outside the variant's range "
                      f"{lo:g}..{hi:g} deg")
            kind[i] = "gamma out of range"
    still = bad.eq("") & (num["omega_1"] == 0)
    for i in raw.index[still]:
        bad[i] = "omega_1 is 0: the motor shaft must turn for a slip angle to exist"
        kind[i] = "motor at rest"
    _duplicates(num, bad, kind)
    dropped = {}
    if bad.ne("").any():
        if not drop_bad:
            i = raw.index[bad.ne("")][0]
            n = int(bad.ne("").sum())
            more = f" ({n - 1} more bad rows; --drop-bad drops and counts them)" if n > 1 else \
                " (--drop-bad drops and counts such rows)"
            raise InputError(f"{where}: line {i + 2}: {bad[i]}{more}")
        dropped = {k: int(v) for k, v in kind[bad.ne("")].value_counts().items()}
        num = num[bad.eq("")]
        if num.empty:
            raise InputError(f"{where}: every row was dropped as bad")
    rows = num.reset_index(drop=True)
    rows.insert(0, "line", (np.asarray(num.index) + 2).astype(int))
    return rows, dropped


def _cells(raw: pd.DataFrame, cols: list, capacity: dict) -> tuple[pd.DataFrame, pd.Series, pd.Series]:
    """(the columns `cols` as numbers, each row's first problem ('' if none), its category): empty,
    non-numeric and non-finite cells, speeds or torques beyond PLAUSIBLE, and torques beyond CAPACITY_MARGIN
    times the shaft's `capacity`."""
    bad = pd.Series("", index=raw.index)      # the first problem of each row
    kind = pd.Series("", index=raw.index)     # its category, for the count of dropped rows
    num = pd.DataFrame(index=raw.index)
    for c in cols:
        text = raw[c].str.strip()
        v = pd.to_numeric(text, errors="coerce").astype(float)
        for i in raw.index[v.isna() & bad.eq("")]:
            cell = text[i]
            empty = cell in ("", "nan", "NaN", "NA")
            bad[i] = f"column '{c}' is empty" if empty else f"column '{c}': '{shorten(cell)}' is not a number"
            kind[i] = "empty cell" if empty else "non-numeric cell"
        for i in raw.index[v.notna() & ~np.isfinite(v) & bad.eq("")]:
            bad[i] = f"column '{c}': '{shorten(text[i])}' is not a finite number"
            kind[i] = "non-finite cell"
        if c in PLAUSIBLE:
            limit, unit, what = PLAUSIBLE[c]
            for i in raw.index[np.isfinite(v) & (v.abs() > limit) & bad.eq("")]:
                bad[i] = f"column '{c}': {v[i]:g} {unit} is not a plausible {what} (expected |{c}| ≤ {limit:g} {unit})"
                kind[i] = "implausible value"
        if c in capacity:
            cap = capacity[c]
            for i in raw.index[np.isfinite(v) & (v.abs() > CAPACITY_MARGIN * cap) & bad.eq("")]:
                bad[i] = (f"column '{c}': {v[i]:g} N·m is beyond what shaft {c[-1]}'s contacts can carry (Σ μ·P·r = "
                          f"{cap:.3g} N·m at the preloads; expected at most {CAPACITY_MARGIN:g}× that: N·mm written "
                          "as N·m?)")
                kind[i] = "implausible value"
        num[c] = v
    return num, bad, kind


def _duplicates(num: pd.DataFrame, bad: pd.Series, kind: pd.Series) -> None:
    """Mark rows that repeat an earlier row in every cell: a rig's replicates differ by their noise, so an
    exact copy is the same measurement twice (a file appended to itself), and it would make the noise level
    the replicates give zero."""
    first: dict = {}
    for i, key in zip(num.index, map(tuple, num.to_numpy())):
        if key in first and bad[i] == "":
            bad[i] = f"repeats line {first[key] + 2} in every cell; expected each replicate measured anew"
            kind[i] = "duplicate row"
        first.setdefault(key, i)
