"""`cvtdesign capacity`: at each γ of a variant's envelope, the largest lateral load τ⊥ of each sign before the
slip angle passes what a cobot can use, the speed ratio runs away, or the first contact slips grossly, loses
contact or exceeds its allowable pressure, and which limit and contact that is (core.capacity); and the drive
rollers that pivot on the sphere with no load."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from rich.console import Console

from cvtdesign.uses.load_capacity import capacity_records
from cvtdesign.cli.printing import progress_bar, show
from cvtdesign.io.strict_json import json_text
from cvtdesign.core.capacity_interval import figure
from cvtdesign.io import plots
from cvtdesign.io.output import make_folder, named_after, write_file
from cvtdesign.io.report import Note, Table
from cvtdesign.io.units import number

LIMIT_WORDS = {"gross_slip": "gross slip", "lost_contact": "lost contact", "pressure": "pressure",
               "usable_ratio": "usable ratio", "runaway": "runaway"}


def torque_text(value) -> str:
    """A torque [N·m] to the table's 3 decimals ('—' where there is none; round-off zeros print as 0.000)."""
    return "—" if value is None or not np.isfinite(value) else f"{round(float(value), 3) + 0.0:.3f}"


def _where(row: dict, side: str) -> str:
    """What reaches the limit: the contacts (gross slip, lost contact, pressure), the slip angle's steering (S)
    and drive (D) parts (usable ratio: what to stiffen), the speed ratio's pole (runaway)."""
    limit = row[f"limit_{side}"]
    if limit == "usable_ratio":
        a, s = row[f"alpha_{side}_deg"], row[f"alpha_steering_{side}_deg"]
        if a is None or s is None or not np.isfinite(a - s):
            return "—"
        return f"S {s:.2f}° D {a - s:.2f}°"
    if limit == "runaway":
        return "ω2/ω1 → ∞"
    return ", ".join(row[f"contacts_{side}"]) or row[f"contact_{side}"]


def _cell(row: dict, side: str) -> list[str]:
    """The table's cells of one side: capacity, limit, contact(s) (_where), τ1, τ2."""
    tau, unknown = row[f"tau_perp_{side}_Nm"], row[f"unknown_{side}"]
    if unknown is not None:
        return ["—", unknown.replace("_", " ") + " ³", "", "", ""]
    limit = LIMIT_WORDS[row[f"limit_{side}"]] + (" without load" if tau == 0 else "")
    return [torque_text(tau) + interval_text(row.get(f"{figure(side)}_interval")), limit, _where(row, side),
            torque_text(row[f"tau_1_{side}_Nm"]), torque_text(row[f"tau_2_{side}_Nm"])]


def interval_text(interval) -> str:
    """' [0.30, 0.65]': a capacity's 95 % interval [N·m] after its value; '' where it has none."""
    return "" if interval is None else f" [{interval[0]:.2f}, {interval[1]:.2f}]"


def capacity_blocks(record: dict) -> list:
    """A variant's printed table (a row per γ, each side's capacity, limit, contact and shaft torques) and its
    notes: the smallest capacity against the envelope, the usable-ratio bound, the safety factor, the
    runaways, the searches that ended on no limit, the drive rollers that pivot, the contacts whose pressure is
    not checked."""
    s, name = record["safety"], record["name"]
    t = Table(f"{name}: load capacity τ⊥ at each γ [N·m], {bound_text(record)}"
              + (f", gross slip at F/(μN) = 1/{s:g}" if s != 1 else ""),
              ["γ [°]", "τ⊥ max", "limit", "contact / α", "τ1", "τ2", "τ⊥ min", "limit", "contact / α", "τ1", "τ2"])
    for row in record["capacity"]:
        t.add(number(row["gamma_deg"], 4), *_cell(row, "max"), *_cell(row, "min"),
              style="bad" if row["unknown_max"] or row["unknown_min"] else "")
    blocks = [t, Note(summary_text(record)), Note(interval_note(record)), Note(bound_note(record))]
    if s != 1:
        blocks.append(Note(f"safety factor {s:g} on friction: a contact counts as slipping grossly once its "
                           f"utilisation F/(μN) reaches 1/{s:g} = {1 / s:.3g}; lost contact and the allowable "
                           "pressure are as without it"))
    runaways = [f"γ {number(r['gamma_deg'], 4)}°, τ⊥ {'>' if side == 'max' else '<'} 0 at "
                f"{number(abs(r[f'tau_perp_{side}_Nm']), 4)} N·m" for r in record["capacity"] for side in ("max", "min")
                if r[f"limit_{side}"] == "runaway"]
    if runaways:
        blocks.append(Note(f"{name}: runaway at {'; '.join(runaways)}: there the load has turned the apparent axis "
                           "γ + α to ±90°, the pole of the speed ratio (ω2/ω1 grows without bound), and beyond it "
                           "no steady state is left: the output shaft runs away", "warn"))
    if record["unknown"]:
        blocks.append(Note(f"³ {name}: {record['unknown']} of {2 * len(record['capacity'])} searches ended "
                           f"where the model has no steady solution, so no capacity is given there: "
                           + "; ".join(unknown_texts(record)), "bad"))
    blocks.append(Note(pivoting_text(record), "warn" if record["pivoting"]["points"] else ""))
    if record["pressure_not_checked"]:
        blocks.append(Note(f"{name}: allowable pressure not checked at "
                           f"{', '.join(record['pressure_not_checked'])} (no allowable_pressure in either material)",
                           "warn"))
    return blocks


def interval_note(record: dict) -> str:
    """How the capacities' intervals were found, and what the smallest capacity's depends on most."""
    least, name = record["smallest"], record["name"]
    methods = {r.get(f"{figure(s)}_interval_method") for r in record["capacity"] for s in ("max", "min")} - {None}
    if not methods:
        return f"{name}: no interval (no uncertain input, or no capacity under load)"
    how = "; ".join(sorted(methods))
    budget = least.get("tau_perp_Nm_budget") or {}
    first = ", ".join(f"{k} {v:.0%}" for k, v in list(budget.items())[:3] if v >= 0.005)
    return (f"{name}: [ ] 95 % intervals from every uncertain input (the calibration, the preloads, the moduli, the "
            f"pairs' friction, the law's own error; docs/capacity.md): {how}"
            + ("" if any(m.startswith("first order, checked") or m.startswith("sampled") for m in methods)
               else " (--samples N checks them by sampling)")
            + (f". The smallest capacity's spread comes from {first}: measure those first" if first else ""))


def bound_text(record: dict) -> str:
    """'usable ratio: |α| ≤ 2°', or that the ratio is not bounded (--max-slip 90deg)."""
    bound = record["max_slip_deg"]
    return "usable ratio not bounded" if bound is None or not np.isfinite(bound) else f"usable ratio: |α| ≤ {bound:.4g}°"


def bound_note(record: dict) -> str:
    """What the usable-ratio bound means and how to change it."""
    bound = record["max_slip_deg"]
    if bound is None or not np.isfinite(bound):
        return (f"{record['name']}: {bound_text(record)} (--max-slip 90deg): the capacity is the contacts' limits and "
                "the runaway alone, at slip angles a cobot could not use")
    rho = 2 * math.radians(bound) / math.sin(2 * math.atan(0.4)) * 100
    return (f"{record['name']}: {bound_text(record)}, the slip angle between the shaft speeds and the command, "
            f"the direction error of a cobot's constraint (about {rho:.3g} % speed-ratio error at ratios 0.4 and 2.5 "
            "of ω2/ω1 = tan γ; docs/capacity.md); S and D: its steering and drive parts at the capacity; "
            "--max-slip sets the bound, --max-slip 90deg leaves it out")


def pivoting_text(record: dict) -> str:
    """The drive rollers that pivot on the sphere with no load, or that the law does not model it."""
    piv, name = record["pivoting"], record["name"]
    if not piv["modelled"]:
        return (f"{name}: drive rollers pivoting on the sphere: not modelled (the contact law gives no spin moment; "
                "the FASTSIM law does)")
    if not piv["points"]:
        return f"{name}: no drive roller pivots on the sphere at the envelope's γ (spin moment below {piv['share']:g} μNℓ)"
    parts = []
    for p in piv["points"]:
        one = len(p["contacts"]) == 1
        parts.append(f"at γ {number(p['gamma_deg'], 4)}° the drive roller{'' if one else 's'} {', '.join(p['contacts'])} "
                     f"pivot{'s' if one else ''} on the sphere and slide{'s' if one else ''} (spin moment "
                     f"{min(p['moment_share']):.2f} of μNℓ), losing {number(p['loss_W'], 3)} W of the "
                     f"{number(p['power_loss_W'], 3)} W lost with no load")
    return (f"{name}: {'; '.join(parts)}. A loss with no output and wear, not a limit of the load (the roller "
            "still carries its tangential force)")


def unknown_texts(record: dict) -> list[str]:
    """Where the search ended on no limit, and how far the model held: 'γ 60°, τ⊥ > 0: multiple roots beyond
    7.117 N·m (the sphere's axis at 78.86°)'."""
    out = []
    for row in record["capacity"]:
        for side in ("max", "min"):
            if row[f"unknown_{side}"] is None:
                continue
            held, axis = row[f"held_{side}_Nm"], row[f"held_gamma_axis_{side}_deg"]
            text = f"γ {number(row['gamma_deg'], 4)}°, τ⊥ {'>' if side == 'max' else '<'} 0: " \
                   + row[f"unknown_{side}"].replace("_", " ")
            if held is not None and np.isfinite(held):
                text += f" beyond {number(abs(held), 4)} N·m (the sphere's axis at {axis:.2f}°)"
            out.append(text)
    return out


def summary_text(record: dict) -> str:
    """'box: smallest capacity 0.4809 N·m (γ 40°, τ⊥ > 0: usable ratio, steering 1.21°, drive 0.79°), 0.481× the
    envelope's largest load 1 N·m', or where the model stopped first, that the smallest capacity is not known
    and where."""
    least, env = record["smallest"], max(abs(v) for v in record["envelope"]["tau_perp_Nm"])
    if least["gamma_deg"] is None:
        return f"{record['name']}: no capacity is known at any γ"
    row = next(r for r in record["capacity"] if r["gamma_deg"] == least["gamma_deg"])
    side = least["side"]
    where = f"γ {number(least['gamma_deg'], 4)}°, τ⊥ {'>' if side == 'max' else '<'} 0"
    if least["tau_perp_Nm"] is None:
        return (f"{record['name']}: smallest capacity not known: at {where} the model stops at "
                f"{number(abs(row[f'held_{side}_Nm']), 4)} N·m before any limit (³), below every capacity found")
    tau = least["tau_perp_Nm"]
    if tau == 0:
        return no_capacity_text(record, where, least["limit"])
    return (f"{record['name']}: smallest capacity {number(tau, 4)} N·m"
            f"{interval_text(least.get('tau_perp_Nm_interval'))} ({where}: {LIMIT_WORDS[least['limit']]}, "
            f"{_where(row, side)}), {tau / env:.3g}× the envelope's largest load {number(env, 4)} N·m")


def no_capacity_text(record: dict, where: str, limit: str) -> str:
    """The summary where the limit is reached without load ('—' in the table): nothing qualifies, and how
    widely; with a safety factor on gross slip, that F/(μN) reaches 1/S already at zero load."""
    rows, s = record["capacity"], record["safety"]
    zero = sum(r[f"limit_{k}"] is not None and torque_text(r[f"tau_perp_{k}_Nm"]) in ("—", "0.000") for r in rows
               for k in ("max", "min"))
    why = (f": F/(μN) reaches 1/{s:g} = {1 / s:.3g} already at τ⊥ = 0; expected a smaller --safety"
           if limit == "gross_slip" and s != 1 else "")
    return (f"{record['name']}: no load capacity: {zero} of {2 * len(rows)} searches (first at {where}) reach "
            f"{LIMIT_WORDS[limit]} without load{why}")


def run(args):
    files = [Path(f) for f in args.variants]
    console = Console(width=140)
    with progress_bar(console, "capacity", lambda item: item, transient=True) as progress:
        records = capacity_records(files, args.safety, args.max_slip, args.samples, progress)
    written = []       # the files first, then the terminal (a reader closing stdout early loses no file)
    if args.plots:
        figure = make_folder(args.plots, kind="--plots") / named_after(files, "_capacity.png")
        plots.capacity_figure(records, figure)
        written.append(f"plot: {figure}")
    if args.json:
        write_file(args.json, json_text({"variants": records}), kind="--json")
        written.append(f"capacities written to {args.json}")
    show(console, [b for r in records for b in capacity_blocks(r)])
    for line in written:
        console.print(line)
    return 0
