"""`cvtdesign compare`: variants side by side over their envelope, with the ideal CVT and Kim's existing CVT."""
from __future__ import annotations

import sys
from pathlib import Path

from rich.console import Console

from cvtdesign.cli import compare_report
from cvtdesign.cli.printing import json_text, left_out_text, report_text, show
from cvtdesign.core.metrics import envelope, ideal_model, metrics
from cvtdesign.core.model import compile_model
from cvtdesign.io import plots
from cvtdesign.io.output import make_folder, named_after, write_file
from cvtdesign.io.points import check_points_path, contact_points, write_points
from cvtdesign.io.report import Note, Table
from cvtdesign.io.variant import load_variant, shipped_variant


COLUMNS = [
    ("max_abs_alpha_deg", "max |α| [°]", "{:.3f}"),
    ("rms_alpha_deg", "RMS α [°]", "{:.3f}"),
    ("max_abs_alpha_steering_deg", "max |α| steering [°]", "{:.3f}"),
    ("max_abs_alpha_drive_deg", "max |α| drive [°]", "{:.3f}"),
    ("ratio_error_pct_at_max_load", "ratio error at max load [%]", "{:.2f}"),
    ("min_efficiency", "worst efficiency ¹", "{:.3f}"),
    ("max_loss_no_output_W", "max loss without output [W] ²", "{:.2f}"),
    ("max_traction_utilisation", "max F/(μN)", "{:.3f}"),
    ("max_hertz_pressure_MPa", "max Hertz p [MPa]", "{:.2f}"),
]


def run(args):
    """Print the comparison table and have args.painter (the plotting process that cli.parser starts before it
    imports this module) draw the figure, which is completely written when this returns."""
    painter = args.painter
    if args.points:
        check_points_path(args.points)
    files = [Path(f) for f in args.variants]
    layouts = [load_variant(f) for f in files]
    if len(files) == 1:
        existing = shipped_variant("existing")     # Kim's CVT, wherever the command runs from
        if existing.resolve() != files[0].resolve():
            layouts.insert(0, load_variant(existing))
    models = [compile_model(L) for L in layouts]
    results = [envelope(m) for m in models]
    figure = make_folder(args.out, kind="--out") / named_after(files, ".png")     # another set, another file
    replaced = figure.exists()
    # the figure is drawn while the ideal CVT is evaluated and the table printed
    painter.draw("compare_figure", [(L.name, {k: res[k] for k in plots.COMPARE_KEYS})
                                    for L, res in zip(layouts, results)], figure)
    rows = [metrics(m, res) for m, res in zip(models, results)]
    if len(files) == 1:
        ideal = ideal_model(layouts[-1])
        row = metrics(ideal, envelope(ideal))
        row["name"] = f"ideal ({layouts[-1].name})"
        rows.insert(0, row)

    if args.points:
        write_points(args.points, [contact_points(L.name, L, res) for L, res in zip(layouts, results)])
    blocks = comparison_blocks(rows)
    # the files first, then the terminal: a reader that closes stdout early (`| head`) loses no file
    if args.json:
        write_file(args.json, json_text({"variants": rows}), kind="--json")
    error = painter.wait()
    if args.report and not error:
        report = compare_report.report_blocks(rows, blocks, figure, {key: label for key, label, _ in COLUMNS})
        write_file(args.report, report_text(args, "cvtdesign compare", report), kind="--report")
    console = Console(width=max(100, 30 + 22 * len(rows)))
    show(console, blocks)
    if args.json:
        console.print(f"figures written to {args.json}")
    if error:
        print(f"cvtdesign: error: plotting failed: {error}", file=sys.stderr)
        return 1
    console.print(f"plots: {figure}" + (" (replaced the earlier figure of these variants)" if replaced else ""))
    if args.points:
        console.print(f"contact states: {args.points}")
    if args.report:
        console.print(f"report: {args.report}")
    return 0


def comparison_blocks(rows: list[dict]) -> list:
    """The comparison table (one column per variant, the figures of COLUMNS as rows) and, per variant, its
    ideal law, the operating points left out of the figures and the contacts over their allowable pressure.
    The table never looks better than the run: when a variant has fewer than half its points ok, a first
    row says so in its column; a figure over no ok point is '—'; a pressure over the allowable is marked."""
    table = Table("CVT comparison over the operating envelope (γ × τ⊥)", ["figure", *[r["name"] for r in rows]])
    under = [2 * r["ok"] < r["points"] for r in rows]
    if any(under):
        table.add("operating points ok", *[f"{r['ok']} of {r['points']}" + (" (under half)" if u else "")
                                           for r, u in zip(rows, under)], style="bad")
    for key, label, fmt in COLUMNS:
        table.add(label, *[figure_cell(r, key, fmt) for r in rows])
    blocks = [table, Note("¹ over the points with |γ| ≥ 5° and |τ⊥| ≥ 25 % of the largest load that deliver power "
                          "(it leaves at one shaft): " + "; ".join(_efficiency_points(r) for r in rows)),
              Note("² the largest power lost at a point that delivers none (zero load, γ = 0, or power entering "
                   "both shafts), where an efficiency means nothing")]
    for r in rows:
        blocks.append(Note(f"{r['name']}: {r['ideal_law']}"))
        if r["ok"] < r["points"]:
            blocks.append(Note(f"{r['name']}: {r['points'] - r['ok']} of {r['points']} operating points left out "
                               f"of the figures: {left_out_text(r)}", "bad"))
        if r.get("max_hertz_pressure_over_allowable"):
            at = ", ".join(f"{n} ×{k}" for n, k in r["hertz_over_allowable_at"].items())
            blocks.append(Note(f"{r['name']}: Hertz peak pressure over the contact's allowable pressure "
                               f"({r['hertz_allowable_pressure_MPa']:.3g} MPa) at {at} points", "bad"))
    return blocks


def figure_cell(r: dict, key: str, fmt: str) -> str:
    """A variant's figure as the table shows it: '—' where no point is ok to take it over, a Hertz pressure
    over the allowable marked with it."""
    if r[key] is None or not r["ok"]:
        return "—"
    text = fmt.format(r[key])
    if key == "max_hertz_pressure_MPa" and r.get("max_hertz_pressure_over_allowable"):
        text += f" > {r['hertz_allowable_pressure_MPa']:.3g} allowed"
    return text


def _efficiency_points(row: dict) -> str:
    text = f"{row['name']} {row['efficiency_points']}"
    return text + (f" ({row['no_output_points']} more deliver none)" if row["no_output_points"] else "")
