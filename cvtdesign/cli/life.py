"""`cvtdesign life`: heat, wear and life of every contact of each variant over a duty cycle (core.life,
docs/life.md): a table per variant, the machine's life with its limit and contact, figures and a report."""
from __future__ import annotations

import math
import tempfile
from pathlib import Path

from rich.console import Console

from cvtdesign.uses.life import C0, life_figures, life_run
from cvtdesign.cli.printing import progress_bar, report_text, show
from cvtdesign.io.strict_json import json_text
from cvtdesign.io.duty_file import load_duty
from cvtdesign.io.output import make_folder, write_files
from cvtdesign.io.report import Note, Table, png_figure
from cvtdesign.io.units import number


def life_cell(row: dict) -> str:
    """The compare table's life cell: '75800 (wear at N1)', '—' without one (the ideal CVT wears nothing)."""
    if row.get("life_h") is None:
        return "—"
    return f"{number(row['life_h'], 3)} ({row['life_limit']} at {row['life_contact']})"


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


def run(args):
    files = [Path(f) for f in args.variants]
    duty = load_duty(args.duty)
    console = Console(width=140)
    with progress_bar(console, "life", lambda item: item, transient=True) as progress:
        result = life_run(files, duty, progress)
    records, lives, ages, intervals, worn = result.rows, result.lives, result.ages, result.intervals, result.worn
    # the files first, then the terminal (a reader closing stdout early loses no file)
    written, out, kinds = [], {}, {}
    if args.plots:
        for p in life_figures(records, lives, ages, intervals, files, make_folder(args.plots, kind="--plots")):
            written.append(f"plot: {p}")
    blocks = [_duty_note(duty)] + [b for r, life, w in zip(records, lives, worn) for b in life_blocks(r, life, duty, w)]
    if args.report:
        with tempfile.TemporaryDirectory() as tmp:
            figs = [png_figure(p) for p in life_figures(records, lives, ages, intervals, files, Path(tmp))]
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
