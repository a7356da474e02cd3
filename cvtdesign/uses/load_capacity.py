"""The load capacity of variants, as `cvtdesign capacity` computes it (docs/capacity.md): at each γ of a
variant's envelope the largest τ⊥ of each sign before the ratio is no longer usable, runs away, or the first
contact reaches a limit (core.capacity), each with its 95 % interval and budget (core.capacity_interval); the
drive rollers that pivot. The command (cli/capacity.py) prints and writes what capacity_records returns."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from cvtdesign.uses.comparison import as_layout
from cvtdesign.uses.result import Result, table_row
from cvtdesign.core import basis
from cvtdesign.core.capacity import LIMITS, MAX_SLIP, PIVOT_SHARE, smallest_capacity
from cvtdesign.core.capacity import capacity as search_capacity
from cvtdesign.core.capacity_interval import figure, with_intervals
from cvtdesign.core.inputs import uncertain_model
from cvtdesign.core.metrics import allowable_pressures
from cvtdesign.errors import InputError
from cvtdesign.io import plots
from cvtdesign.io.limits import check_samples, load_capacity
from cvtdesign.io.output import named_after
from cvtdesign.io.units import check_range, to_si


def check_safety(value: float) -> float:
    """The safety factor S on friction (gross slip once F/(μN) reaches 1/S): finite and at least 1 (below 1
    it would let a contact pass its friction)."""
    if not (math.isfinite(value) and value >= 1):
        raise InputError(f"--safety: expected a finite safety factor of at least 1 (gross slip is counted once "
                         f"F/(μN) reaches 1/S), got {value:g}")
    return float(value)


def check_max_slip(text: str | None) -> float | None:
    """--max-slip: the usable-ratio bound on |α| [rad], an angle in (0°, 90°] ('2deg'; a plain number is in
    rad); None: the default MAX_SLIP. 90° bounds nothing (α is an angle between two axes): returns None."""
    if text is None:
        return MAX_SLIP
    value = check_range(to_si(text, "angle", "--max-slip"), text, "--max-slip", "usable slip-angle bound |α|", "angle",
                        lo=0.0, hi=math.pi / 2, lo_open=True, guess="deg")
    return None if value >= math.pi / 2 - 1e-12 else float(value)


def side_record(model, cap: dict, side: str, i: int) -> dict:
    """The JSON fields of one γ and one side ('max': τ⊥ > 0, 'min': τ⊥ < 0) of a core.capacity result; a limit
    that is no limit of the CVT (the model did not converge, …) leaves the capacity and the limit null and
    says why in unknown_<side>, with held_<side>_Nm the largest load at which the model held."""
    names, limit = model.roller_names, cap[f"limit_{side}"][i]
    k = int(cap[f"contact_{side}"][i])
    return {f"tau_perp_{side}_Nm": cap[f"tau_perp_{side}"][i],
            f"limit_{side}": limit if limit in LIMITS else None,
            f"contact_{side}": names[k] if k >= 0 else None,
            f"contacts_{side}": [n for n, s in zip(names, cap[f"sharing_{side}"][:, i]) if s],
            f"tau_1_{side}_Nm": cap[f"tau_1_{side}"][i], f"tau_2_{side}_Nm": cap[f"tau_2_{side}"][i],
            f"alpha_{side}_deg": np.degrees(cap[f"alpha_{side}"][i]),
            f"alpha_steering_{side}_deg": np.degrees(cap[f"alpha_steering_{side}"][i]),
            f"unknown_{side}": None if limit in LIMITS else limit,
            f"held_{side}_Nm": cap[f"held_{side}"][i],
            f"held_gamma_axis_{side}_deg": np.degrees(cap[f"held_axis_{side}"][i])}


def variant_record(name: str, model, cap: dict, samples: int | None = None) -> dict:
    """One variant's JSON record: its capacity at every γ of its envelope (the `capacity --json` interface),
    the envelope, the safety factor, the contacts whose pressure is not checked and the search's bound; with
    `samples` (not None), each capacity's 95 % interval and budget (core.capacity_interval), checked by that
    many samples (0: first order)."""
    L = model.layout
    rows = []
    for i, g in enumerate(cap["gamma"]):
        row = {"gamma_deg": round(float(np.degrees(g)), 9)}
        for side in ("max", "min"):
            row |= side_record(model, cap, side, i)
        rows.append(row)
    if samples is not None:
        rows = with_intervals(model, cap, rows, samples)
    unchecked = [n for n, p in zip(model.roller_names, allowable_pressures(L)) if not np.isfinite(p)]
    return {"name": name, "file": L.file, "safety": cap["safety"], "max_slip_deg": np.degrees(cap["max_slip"]),
            "capacity": rows, "pivoting": pivoting_record(model, cap),
            "envelope": {"gamma_deg": [float(np.degrees(L.gamma_grid.min())), float(np.degrees(L.gamma_grid.max()))],
                         "tau_perp_Nm": [float(L.load_grid.min()), float(L.load_grid.max())]},
            "pressure_not_checked": unchecked, "search_bound_Nm": cap["bound"],
            "smallest": smallest_record(model, cap),
            "unknown": sum(r[f"unknown_{s}"] is not None for r in rows for s in ("max", "min"))}


def pivoting_record(model, cap: dict) -> dict:
    """core.capacity.pivoting as JSON: {modelled, share (PIVOT_SHARE), points: [{gamma_deg, contacts,
    moment_share (|Mz|/(μNℓ) of each), loss_W (theirs together), power_loss_W (the whole machine's)}]} at the γ
    where some drive or follower roller pivots with no load."""
    piv, points = cap["pivoting"], []
    for i, g in enumerate(cap["gamma"]):
        k = np.flatnonzero(piv["pivots"][:, i]) if piv["modelled"] else []
        if len(k):
            points.append({"gamma_deg": round(float(np.degrees(g)), 9), "contacts": [model.roller_names[j] for j in k],
                           "moment_share": piv["share"][k, i], "loss_W": float(piv["loss"][k, i].sum()),
                           "power_loss_W": piv["power_loss"][i]})
    return {"modelled": piv["modelled"], "share": PIVOT_SHARE, "points": points}


def with_smallest_interval(record: dict) -> dict:
    """The record with its smallest capacity's interval, budget and method (those of the γ and side where it is
    taken), as 'tau_perp_Nm_interval', … in `smallest` (|τ⊥|: the interval of τ⊥ < 0 is turned over)."""
    least = record["smallest"]
    if least["tau_perp_Nm"] is None or least["tau_perp_Nm"] == 0:
        return record
    row = next(r for r in record["capacity"] if r["gamma_deg"] == least["gamma_deg"])
    f = figure(least["side"])
    if row.get(f"{f}_interval") is not None:
        lo, hi = sorted(abs(v) for v in row[f"{f}_interval"])
        least |= {"tau_perp_Nm_interval": [lo, hi], "tau_perp_Nm_budget": row[f"{f}_budget"],
                  "tau_perp_Nm_interval_method": row[f"{f}_interval_method"]}
    elif f"{f}_interval_method" in row:
        least |= {"tau_perp_Nm_interval": None, "tau_perp_Nm_interval_method": row[f"{f}_interval_method"]}
    return record


def smallest_record(model, cap: dict) -> dict:
    """core.capacity.smallest_capacity as JSON: tau_perp_Nm (null where not known), gamma_deg, side, limit,
    contact."""
    least = smallest_capacity(cap)
    known, placed = np.isfinite(least["tau_perp"]), np.isfinite(least["gamma"])
    # a capacity of 0 (the limit reached without load: nothing qualifies) is no one contact's limit under load
    named = least["contact"] >= 0 and not (known and least["tau_perp"] == 0)
    return {"tau_perp_Nm": float(least["tau_perp"]) if known else None,
            "gamma_deg": round(float(np.degrees(least["gamma"])), 9) if placed else None,
            "side": least["side"], "limit": least["limit"],
            "contact": model.roller_names[least["contact"]] if named else None}


def capacity_records(variants, safety: float = 1.0, max_slip=None, samples: int = 0, progress=None) -> list[dict]:
    """The `capacity --json` records of `variants` (files or Layouts), each named distinctly: `safety` and
    `max_slip` checked first (check_safety, check_max_slip), `samples` (check_samples) checking the intervals;
    `progress(done, total, text)` told as the searches go (cli.printing.progress_bar)."""
    safety, max_slip, samples = check_safety(safety), check_max_slip(max_slip), check_samples(samples)
    progress = progress or (lambda done, total, item: None)
    layouts = [as_layout(v) for v in variants]
    names = basis.distinct_names(layouts)
    records = []
    for i, (L, name) in enumerate(zip(layouts, names)):
        model = uncertain_model(dataclasses.replace(L, name=name))
        cap = search_capacity(model, L.gamma_grid, load_capacity(L), safety, max_slip,
                              progress=lambda d, t, item, i=i, n=name: progress(i * t + d, len(layouts) * t,
                                                                                f"{n}: {item or 'done'}"))
        progress(i + 1, len(layouts), f"{name}: intervals" + (f" ({samples} samples)" if samples else ""))
        records.append(with_smallest_interval(variant_record(name, model, cap, samples)))
    return records


@dataclasses.dataclass(eq=False)
class Capacity(Result):
    """The result of `capacity`.

    Attributes
    ----------
    rows : list of dict
        Per variant the ``capacity --json`` record (docs/capacity.md): ``capacity`` (per γ [°] of its envelope,
        each side's ``tau_perp_max_Nm`` / ``tau_perp_min_Nm`` [N·m], limit, contact, shaft torques [N·m], slip
        angles [°], and with samples its ``<figure>_interval`` [N·m] and budget), ``smallest`` (the smallest
        capacity [N·m], where, and its interval), ``pivoting``, ``envelope``, ``safety``, ``max_slip_deg``
        [°].
    """

    rows: list[dict]
    files: list = dataclasses.field(default_factory=list, repr=False)

    def content(self) -> dict:
        """The ``capacity --json`` document: {"variants": rows}."""
        return {"variants": self.rows}

    def table_rows(self) -> list[dict]:
        """One row per variant and γ: ``variant``, then the γ's fields (capacities [N·m] of each sign with their
        ``_low`` and ``_high`` ends, limits, contacts, angles [°])."""
        return [{"variant": r["name"]} | table_row(row) for r in self.rows for row in r["capacity"]]

    def plot(self, path=None) -> Path:
        """The capacity figure (`cvtdesign capacity --plots`'): capacity against γ with the envelope drawn in, a
        PNG at `path`, default out/capacity/<the files' stems joined by +>_capacity.png; returns the path."""
        path = Path(path) if path is not None else Path("out/capacity") / named_after(self.files, "_capacity.png")
        plots.capacity_figure(self.rows, path)
        return path


def capacity(*variants, safety: float = 1.0, max_slip=None, samples: int = 0) -> Capacity:
    """The load capacity τ⊥ [N·m] of each variant at each γ [°] of its envelope, as ``cvtdesign capacity`` gives it.

    Parameters
    ----------
    *variants : str, Path or Layout
        Variant files, or layouts from `load_variant`.
    safety : float
        Safety factor S ≥ 1 on friction: a contact counts as slipping grossly once F/(μN) reaches 1/S
        (``--safety``).
    max_slip : str or float, optional
        The usable-ratio bound on |α| [°]: an angle with its unit (``'2deg'``) or a number of degrees; 90° leaves
        it out; default 2° (``--max-slip``).
    samples : int
        Samples of every uncertain input that check each capacity's first-order interval: 0 (first order) or 20
        to 10,000 (``--samples``).

    Returns
    -------
    Capacity
        `.rows` (the ``--json`` records), `.table` (pandas.DataFrame, a row per variant and γ), `.to_json()`,
        `.plot(path)`.

    Raises
    ------
    cvtdesign.errors.InputError
        A file, field or option that is not valid (one line naming it).
    """
    if not variants:
        raise InputError("capacity: no variant given; expected one or more variant files")
    if isinstance(max_slip, (int, float)) and not isinstance(max_slip, bool):
        max_slip = f"{max_slip!r} deg"
    return Capacity(capacity_records(variants, safety, max_slip, samples), [getattr(v, "file", v) for v in variants])
