"""The duty-cycle file of `cvtdesign life`: how the CVT is used, as operating points with their share of time
(or hours), or as a task log (a CSV time series) resampled at a fixed step (docs/life.md).

    name: cobot_pick_place
    cycle: 60 s                    # the points run in this order, each for share × cycle, and repeat
    points:
      - {gamma: 30 deg, tau_perp: 0.4 N*m, motor_speed: 20 rad/s, share: 25 %}
      - ...
    # or, instead of points:
    log: {file: task_log.csv, step: 0.5 s}   # columns time_s, gamma_deg, tau_perp_Nm, motor_speed_rad_s
    ambient: 25 degC               # the air and frame around the rollers
    wear_limit: 0.4 mm             # the radius a roller may lose (omitted: 1 % of each roller's radius)
    hub_ratio: 0.6                 # the hub's radius / the roller's: the urethane tread lies outside it

Every problem is one InputError line naming the file and the field or row (exit status 2).
"""
from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
from pydantic import Field, ValidationError

from cvtdesign.core.life.duty import DutyCycle
from cvtdesign.errors import InputError
from cvtdesign.io.schema import Name, Num, Strict, schema_error, spec_field
from cvtdesign.io.units import check_range, to_si
from cvtdesign.io.yaml_file import read_spec

LOG_COLUMNS = ("time_s", "gamma_deg", "tau_perp_Nm", "motor_speed_rad_s")
MAX_ROWS = 1_000_000        # rows of a task log
MAX_POINTS = 5_000          # duty points after resampling (each is one operating point of the model)
SHARE_TOL = 1e-6            # |Σ shares − 1| allowed (relative to 1; shares written as data sum to 1 within 1e-12)


class PointSpec(Strict):
    """One operating point of the duty cycle."""
    gamma: Num = spec_field("commanded ratio angle γ", kind="angle")
    tau_perp: Num = spec_field("lateral load τ⊥", kind="torque")
    motor_speed: Num = spec_field("motor (input shaft) speed ω1", kind="speed")
    share: Num | None = spec_field("share of the time at this point ('25 %'); all points give share or all "
                                   "give hours", None, kind="dimensionless")
    hours: Num | None = spec_field("hours at this point over the machine's use", None, kind="time")


class LogSpec(Strict):
    """A task log: a CSV file of the columns time_s, gamma_deg, tau_perp_Nm, motor_speed_rad_s."""
    file: str = spec_field("the CSV file, relative to the duty file")
    step: Num = spec_field("the resampling step (each sample holds the last logged row)", "1 s", kind="time")


class DutySpec(Strict):
    """A duty-cycle file."""
    name: Name = spec_field("the duty cycle's name")
    description: str = spec_field("what the task is (free text)", "")
    cycle: Num = spec_field("the period of one cycle of the points", "60 s", kind="time")
    points: list[PointSpec] = Field(default_factory=list, description="the operating points, in the cycle's order")
    log: LogSpec | None = spec_field("a task log instead of points", None)
    ambient: Num = spec_field("the temperature of the air and the frame", "25 degC", kind="temperature")
    wear_limit: Num | None = spec_field("the radius a roller may lose before its life ends (omitted: 1 % of its "
                                        "radius, a 1 % ratio error)", None, kind="length")
    hub_ratio: Num = spec_field("the hub's radius over the roller's: the tread's inner edge", 0.6,
                                kind="dimensionless")


def load_duty(path) -> DutyCycle:
    """Read a duty-cycle file into SI (core.life.duty.DutyCycle)."""
    return _resolve(read_spec(path, DutySpec, "name, points or log"), str(path))


def duty_from_data(data, where: str) -> DutyCycle:
    """A duty cycle given as data (a study's duty as it travels to the workers: `inline`) into SI."""
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected a duty cycle (a mapping of name, points)")
    try:
        spec = DutySpec.model_validate(data)
    except ValidationError as err:
        raise schema_error(err, where, DutySpec) from None
    if spec.log is not None:
        raise InputError(f"{where}: log: expected points in a duty cycle given as data (a log is a file)")
    return _resolve(spec, where)


def inline(duty: DutyCycle) -> dict:
    """A duty cycle as data that `duty_from_data` reads back to the same DutyCycle: its points in SI with
    their shares, its settings in SI (the content a study sends its workers instead of the file's path)."""
    points = [{"gamma": float(g), "tau_perp": float(t), "motor_speed": float(w), "share": float(s)}
              for g, t, w, s in zip(duty.gamma, duty.load, duty.speed, duty.shares)]
    out = {"name": duty.name, "description": duty.description, "cycle": duty.period, "points": points,
           "ambient": duty.ambient, "hub_ratio": duty.hub_ratio}
    return out | ({} if duty.wear_limit is None else {"wear_limit": duty.wear_limit})


def _resolve(spec: DutySpec, where: str) -> DutyCycle:
    if bool(spec.points) == (spec.log is not None):
        raise InputError(f"{where}: expected either points or log, got "
                         f"{'both' if spec.points else 'neither'}")
    ambient = check_range(to_si(spec.ambient, "temperature", f"{where}: ambient"), spec.ambient,
                          f"{where}: ambient", "ambient temperature", "temperature", 223.15, 373.15, guess="degC")
    limit = None if spec.wear_limit is None else check_range(
        to_si(spec.wear_limit, "length", f"{where}: wear_limit"), spec.wear_limit, f"{where}: wear_limit",
        "wear limit", "length", 0.0, 0.05, lo_open=True, guess="mm")
    hub = check_range(to_si(spec.hub_ratio, "dimensionless", f"{where}: hub_ratio"), spec.hub_ratio,
                      f"{where}: hub_ratio", "hub ratio", "dimensionless", 0.05, 0.95)
    if spec.log is not None:
        g, t, w, dt = _log(Path(where).parent / spec.log.file, spec.log, f"{where}: log")
    else:
        g, t, w, dt = _points(spec, where)
    return DutyCycle(spec.name, spec.description, g, t, w, dt, ambient, limit, hub, where)


def _points(spec: DutySpec, where: str):
    """The points in SI and their durations [s] within one cycle."""
    period = check_range(to_si(spec.cycle, "time", f"{where}: cycle"), spec.cycle, f"{where}: cycle",
                         "cycle period", "time", 0.0, 1e7, lo_open=True, guess="s")
    if len(spec.points) > MAX_POINTS:
        raise InputError(f"{where}: points: {len(spec.points)} points; expected at most {MAX_POINTS}")
    by = "share" if spec.points[0].share is not None else "hours"
    rows = []
    for i, p in enumerate(spec.points):
        at = f"{where}: points.{i}"
        if (p.share is None) == (p.hours is None) or (getattr(p, by) is None):
            raise InputError(f"{at}: expected {by} (as points.0 gives), and not both share and hours")
        part = to_si(getattr(p, by), "dimensionless" if by == "share" else "time", f"{at}.{by}")
        if not part >= 0:
            raise InputError(f"{at}.{by}: expected a {by} of at least 0, got {getattr(p, by)}")
        rows.append((_operating(p.gamma, p.tau_perp, p.motor_speed, at), part))
    parts = np.array([r[1] for r in rows])
    if by == "share" and abs(parts.sum() - 1) > SHARE_TOL:
        raise InputError(f"{where}: points: the shares add up to {100 * parts.sum():.6g} %; expected 100 %")
    if not parts.sum() > 0:
        raise InputError(f"{where}: points: the hours add up to 0; expected some time at some point")
    ops = np.array([r[0] for r in rows])
    return ops[:, 0], ops[:, 1], ops[:, 2], period * parts / parts.sum()


def _operating(gamma, load, speed, at: str) -> tuple:
    """(γ [rad], τ⊥ [N m], ω1 [rad/s]) of one point, each finite and plausible."""
    g = check_range(to_si(gamma, "angle", f"{at}: gamma"), gamma, f"{at}: gamma", "ratio angle γ",
                    "angle", -math.radians(89), math.radians(89), guess="deg")
    t = check_range(to_si(load, "torque", f"{at}: tau_perp"), load, f"{at}: tau_perp", "lateral load", "torque",
                    -1e3, 1e3)
    w = check_range(to_si(speed, "speed", f"{at}: motor_speed"), speed, f"{at}: motor_speed", "motor speed",
                    "speed", 0.0, 1e4, lo_open=True, guess="rpm")
    return g, t, w


def _log(path: Path, log: LogSpec, where: str):
    """A task log resampled at its step (zero-order hold): the samples and their durations [s]."""
    step = check_range(to_si(log.step, "time", f"{where}.step"), log.step, f"{where}.step", "resampling step",
                       "time", 0.0, 3600.0, lo_open=True, guess="s")
    if not path.is_file():
        raise InputError(f"{where}.file: no such file {path}; expected a CSV task log with columns "
                         f"{', '.join(LOG_COLUMNS)}")
    rows = _read_csv(path)
    t = rows[:, 0]
    if np.any(np.diff(t) <= 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 2
        raise InputError(f"{path}: row {k + 1}: time_s: expected times that increase row by row, got "
                         f"{t[k - 1]:g} after {t[k - 2]:g}")
    if t[-1] - t[0] < step:
        raise InputError(f"{path}: the log spans {t[-1] - t[0]:g} s; expected at least one step ({step:g} s)")
    samples = np.arange(t[0], t[-1], step)
    if samples.size > MAX_POINTS:
        raise InputError(f"{where}.step: {samples.size} samples of {step:g} s; expected at most {MAX_POINTS} "
                         f"(a longer step)")
    held = rows[np.searchsorted(t, samples, side="right") - 1]
    dt = np.diff(np.append(samples, t[-1]))
    return np.radians(held[:, 1]), held[:, 2], held[:, 3], dt


def _read_csv(path: Path) -> np.ndarray:
    """The log's rows as floats (columns LOG_COLUMNS), each value finite and plausible."""
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.reader(f)
            header = [h.strip() for h in next(reader, [])]
            if header != list(LOG_COLUMNS):
                raise InputError(f"{path}: row 1: expected the header {','.join(LOG_COLUMNS)}, got "
                                 f"{','.join(header)[:80] or 'nothing'}")
            rows = []
            for i, row in enumerate(reader, start=2):
                if i > MAX_ROWS:
                    raise InputError(f"{path}: more than {MAX_ROWS} rows; expected a shorter log")
                rows.append(_row(row, path, i))
    except UnicodeDecodeError:
        raise InputError(f"{path}: not UTF-8 text; expected a CSV task log") from None
    if len(rows) < 2:
        raise InputError(f"{path}: {len(rows)} data rows; expected at least 2")
    return np.array(rows)


def _row(row: list, path: Path, i: int) -> tuple:
    if len(row) != len(LOG_COLUMNS):
        raise InputError(f"{path}: row {i}: expected {len(LOG_COLUMNS)} values ({', '.join(LOG_COLUMNS)}), "
                         f"got {len(row)}")
    out = []
    for name, text in zip(LOG_COLUMNS, row):
        try:
            v = float(text)
        except ValueError:
            v = math.nan
        if not math.isfinite(v):
            raise InputError(f"{path}: row {i}: {name}: expected a finite number, got '{text.strip()[:40]}'")
        out.append(v)
    g, t, w = _operating(f"{out[1]} deg", out[2], out[3], f"{path}: row {i}")
    return out[0], math.degrees(g), t, w
