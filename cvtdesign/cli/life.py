"""`cvtdesign life`: heat, wear and life of every contact of each variant over a duty cycle (core.life,
docs/life.md): a table per variant, the machine's life with its limit and contact, figures and a report."""
from __future__ import annotations

import dataclasses
import math
import tempfile
from pathlib import Path

import numpy as np
from rich.console import Console

from cvtdesign.cli.printing import json_text, progress_bar, report_text, show
from cvtdesign.core import basis
from cvtdesign.core.life.run import DutyOutsideModel, life_interval, machine_life, worn_ratio_error
from cvtdesign.core.inputs import uncertain_model
from cvtdesign.errors import InputError
from cvtdesign.io import plots
from cvtdesign.io.ageing import roller_ageing
from cvtdesign.io.duty_file import load_duty
from cvtdesign.io.output import make_folder, named_after, write_files
from cvtdesign.io.report import Note, Table, png_figure
from cvtdesign.io.units import number
from cvtdesign.io.variant import load_spec, load_variant

C0 = 273.15                 # [K] 0 °C
NEEDED = ("loss_fraction", "density", "specific_heat", "conductivity", "max_temperature", "wear_coefficient")


def _hours(seconds) -> float | None:
    return None if seconds is None or not math.isfinite(seconds) else seconds / 3600.0


def ageing_of(file: Path, model) -> list:
    """Per roller, (its material's Ageing, the sphere's); a constant the chain needs and no material gives is
    one InputError line naming the material."""
    ages = roller_ageing(str(file), load_spec(file), model.roller_names)
    for n in model.roller_names:
        for a in ages[n]:
            missing = [k for k in NEEDED if k not in a.values]
            if missing:
                raise InputError(f"{file}: materials.{a.material}.ageing: missing {', '.join(missing)}; expected "
                                 f"every constant `cvtdesign life` needs (docs/life.md), in the variant or the "
                                 f"materials library")
    return [ages[n] for n in model.roller_names]


def life_fields(model, duty) -> dict:
    """compare --duty's fields of one variant: its life [h] on the duty cycle (no interval: `cvtdesign life`
    gives it), its limit and contact."""
    try:
        life = machine_life(model, duty, ageing_of(Path(model.layout.file), model))
    except DutyOutsideModel as e:
        raise InputError(f"{duty.file}: {e} of {model.layout.file}; expected duty points where the variant "
                         f"holds (cvtdesign capacity shows its limits)") from None
    return {"life_h": _hours(life.life), "life_limit": life.limit, "life_contact": life.contact,
            "life_duty": duty.name}


def life_cell(row: dict) -> str:
    """The compare table's life cell: '75800 (wear at N1)', '—' without one (the ideal CVT wears nothing)."""
    if row.get("life_h") is None:
        return "—"
    return f"{number(row['life_h'], 3)} ({row['life_limit']} at {row['life_contact']})"


def variant_record(name: str, life, intervals: dict, shares) -> dict:
    """One variant's JSON record (the `life --json` interface: docs/life.md); `shares`: the duty points'."""
    contacts = [{"contact": c.name, "loss_mean_W": float(np.sum(shares * c.loss)), "loss_peak_W": float(np.max(c.loss)),
                 "T_steady_C": c.T_mean - C0, "T_peak_C": c.T_peak - C0, "wear_um_per_h": c.wear_rate * 3.6e9,
                 "life_h": _hours(c.life), "limit": c.limit} for c in life.contacts]
    lo, hi = intervals["machine"]
    return {"name": name, "life_h": _hours(life.life), "life_h_interval": [_hours(lo), _hours(hi)],
            "limit": life.limit, "contact": life.contact, "contacts": contacts}


def life_blocks(record: dict, life, duty, worn: tuple) -> list:
    """A variant's printed table and its notes (`worn`: core.life.run.worn_ratio_error)."""
    t = Table(f"{record['name']}: heat, wear and life over the duty cycle {duty.name}",
              ["contact", "loss mean [W]", "loss peak [W]", "T steady [°C]", "T peak [°C]", "wear [µm/h]",
               "life [h]", "limit"])
    for k in record["contacts"]:
        t.add(k["contact"], number(k["loss_mean_W"], 3), number(k["loss_peak_W"], 3), f"{k['T_steady_C']:.1f}",
              f"{k['T_peak_C']:.1f}", number(k["wear_um_per_h"], 3), number(k["life_h"], 3), k["limit"],
              style="bad" if k["limit"] in ("runaway", "temperature") and k["life_h"] == 0 else
              ("bold" if k["contact"] == record["contact"] and k["life_h"] == record["life_h"] else ""))
    lo, hi = record["life_h_interval"]
    blocks = [t, Note(f"{record['name']}: life {number(record['life_h'], 3)} h [{number(lo, 3)}, {number(hi, 3)}] "
                      f"(95 % from the materials' σ, the creep calibration's and the other model inputs'), limited by "
                      f"{record['limit']} at {record['contact']}", "bold")]
    why = [c for c in life.contacts if c.why]
    if why:
        blocks.append(Note(f"{record['name']}: runaway at {why[0].name}: {why[0].why}", "bad"))
    err, k = worn
    if k is not None:
        blocks.append(Note(f"{record['name']}: by then wear alone has changed the speed ratio ω2/ω1 by up to "
                           f"{100 * err:+.3g} % (duty point {k + 1}, γ {math.degrees(duty.gamma[k]):g}°: the model "
                           f"with every roller's worn radius, against the unworn)"))
    hyst, loss = (sum(float(duty.shares @ getattr(c, k)) for c in life.contacts) for k in ("hysteresis", "loss"))
    blocks.append(Note(f"{record['name']}: the temperatures settled in {life.iterations} evaluation(s) of the "
                       f"model; {number(loss, 3)} W lost on average over the cycle, {number(hyst, 3)} W of it "
                       "hysteresis (rolling resistance)"))
    return blocks


def _duty_note(duty) -> Note:
    limit = "1 % of each roller's radius" if duty.wear_limit is None else f"{duty.wear_limit * 1e3:.3g} mm"
    return Note(f"duty {duty.name} ({duty.file}): {len(duty.gamma)} points over a {number(duty.period, 4)} s "
                f"cycle; ambient {duty.ambient - C0:.1f} °C, hub at {duty.hub_ratio:g} of the roller's radius, "
                f"wear limit {limit}")


def _figures(records, lives, ages, intervals, files, folder: Path) -> list[Path]:
    curves = [{"name": r["name"], "rollers": {c.name: ((c.curve[0], c.curve[1] - C0), (c.warm_up[0], c.warm_up[1] - C0))
                                           for c in life.contacts},
               "max_C": {c.name: a[0]["max_temperature"] - C0 for c, a in zip(life.contacts, age)}}
              for r, life, age in zip(records, lives, ages)]
    paths = [folder / named_after(files, "_temperature.png"), folder / named_after(files, "_life.png")]
    plots.temperature_figure(curves, paths[0])
    plots.life_figure(records, intervals, paths[1])
    return paths


def _evaluate(files, duty, console) -> tuple[list, list, list, list, list]:
    layouts = [load_variant(f) for f in files]
    names = basis.distinct_names(layouts)
    # the uncertain model (core.inputs): its design vector moves the preloads, moduli, friction and spin moment
    models = [uncertain_model(dataclasses.replace(L, name=n)) for L, n in zip(layouts, names)]
    ages = [ageing_of(f, m) for f, m in zip(files, models)]
    records, lives, intervals, worn = [], [], [], []
    with progress_bar(console, "life", lambda item: item, transient=True) as progress:
        for i, (f, m, a) in enumerate(zip(files, models, ages)):
            try:
                life = machine_life(m, duty, a)
            except DutyOutsideModel as e:
                raise InputError(f"{duty.file}: {e} of {f}; expected duty points where the variant holds "
                                 f"(cvtdesign capacity shows its limits)") from None
            iv = life_interval(m, duty, a, life, progress=lambda d, t, i=i, n=names[i]: progress(
                i * t + d, len(files) * t, f"{n}: intervals"))
            records.append(variant_record(names[i], life, iv, duty.shares))
            lives.append(life)
            worn.append(worn_ratio_error(m, duty, life))
            intervals.append({k: tuple(_hours(x) for x in v) for k, v in iv.items()})
    return records, lives, ages, intervals, worn


def run(args):
    files = [Path(f) for f in args.variants]
    duty = load_duty(args.duty)
    console = Console(width=140)
    records, lives, ages, intervals, worn = _evaluate(files, duty, console)
    # the files first, then the terminal (a reader closing stdout early loses no file)
    written, out, kinds = [], {}, {}
    if args.plots:
        for p in _figures(records, lives, ages, intervals, files, make_folder(args.plots, kind="--plots")):
            written.append(f"plot: {p}")
    blocks = [_duty_note(duty)] + [b for r, life, w in zip(records, lives, worn) for b in life_blocks(r, life, duty, w)]
    if args.report:
        with tempfile.TemporaryDirectory() as tmp:
            figs = [png_figure(p) for p in _figures(records, lives, ages, intervals, files, Path(tmp))]
        out[Path(args.report)], kinds[Path(args.report)] = report_text(
            args, f"cvtdesign life: duty {duty.name}", blocks + figs), "--report"
        written.append(f"report written to {args.report}")
    if args.json:
        out[Path(args.json)], kinds[Path(args.json)] = json_text({"variants": records}), "--json"
        written.append(f"lives written to {args.json}")
    write_files(out, kind=kinds)
    show(console, blocks)
    for line in written:
        console.print(line)
    return 0
