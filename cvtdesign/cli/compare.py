"""`cvtdesign compare`: variants side by side over their envelope, with the ideal CVT and Kim's existing CVT."""
from __future__ import annotations

import sys
from pathlib import Path

from rich.console import Console

from cvtdesign.uses.comparison import comparison_layouts, comparison_rows, figure_inputs
from cvtdesign.cli import compare_report
from cvtdesign.uses.life import life_fields
from cvtdesign.cli.life import life_cell
from cvtdesign.cli.printing import left_out_text, report_text, show
from cvtdesign.io.strict_json import json_text
from cvtdesign.core.inputs import uncertain_model
from cvtdesign.core.metrics import ZERO_TORQUE, at_key, envelope
from cvtdesign.io import plots
from cvtdesign.io.duty_file import load_duty
from cvtdesign.io.output import make_folder, named_after, write_file
from cvtdesign.io.points import check_points_path, contact_points, write_points
from cvtdesign.io.report import Note, Table

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
    ("max_steering_torque_Nm", "max steering torque [N·m]", "{:.3f}"),
    ("max_standstill_steering_torque_Nm", "steering at standstill [N·m]", "{:.3f}"),
]


LIFE_LABEL = "life on the duty cycle [h]"      # with --duty (uses.life.life_fields)
_BASIS_LABELS = [("contact_law", "contact law"), ("calibration", "calibration")]   # the table's first rows


def run(args):
    """Print the comparison table and have args.painter (the plotting process that cli.parser starts before it
    imports this module) draw the figure meanwhile: the table is printed before the figure is waited for,
    which is completely written (and --report after it) when this returns."""
    painter = args.painter
    if args.points:
        check_points_path(args.points)
    life_duty = load_duty(args.duty) if args.duty else None
    files = [Path(f) for f in args.variants]
    layouts = comparison_layouts(files, args.envelope, args.as_written)
    models = [uncertain_model(L) for L in layouts]
    results = [envelope(m) for m in models]
    figure = make_folder(args.out, kind="--out") / named_after(files, figure_suffix(args))   # another set, another file
    replaced = figure.exists()
    # the figure is drawn while the ideal CVT is evaluated and the table printed
    painter.draw(plots.compare_figure, figure_inputs(layouts, models, results), figure)
    rows, ranked = comparison_rows(models, results, args.samples, layouts[-1] if len(files) == 1 else None,
                                   (lambda m: life_fields(m, life_duty)) if args.duty else None)

    if args.points:
        write_points(args.points, [contact_points(L.name, L, res) for L, res in zip(layouts, results)])
    blocks = comparison_blocks(rows, ranked)
    if args.json:
        write_file(args.json, json_text({"variants": rows, "orderings": ranked}), kind="--json")
    console = Console(width=max(100, 30 + 22 * len(rows)))
    # the table while the figure is still drawn; a reader that closes stdout early (`| head`: a BrokenPipeError,
    # or rich's exit) still gets every file, in full
    try:
        show(console, blocks)
    except (BrokenPipeError, SystemExit):
        finish(args, painter, rows, blocks, figure, ranked)
        raise
    error = finish(args, painter, rows, blocks, figure, ranked)
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


def figure_suffix(args) -> str:
    """The figure's name after its basis, so that a run on another basis keeps its own: '.png' on the first
    file's envelope, '_on_<stem>.png' on --envelope's, '_as_written.png' with each file's own."""
    if args.envelope:
        return f"_on_{Path(args.envelope).stem}.png"
    return "_as_written.png" if args.as_written else ".png"


def finish(args, painter, rows: list[dict], blocks: list, figure: Path, ranked: list[dict]) -> str | None:
    """Wait for the figure, then write --report (it shows the figure); the plotting error's text or None."""
    error = painter.wait()
    if args.report and not error:
        labels = {k: label for k, label in _BASIS_LABELS} | {"ok": "operating points ok"} | \
            {key: label for key, label, _ in COLUMNS} | ({"life_h": LIFE_LABEL} if args.duty else {})
        report = compare_report.report_blocks(rows, blocks, figure, labels, ranked)
        write_file(args.report, report_text(args, "cvtdesign compare", report), kind="--report")
    return error


def comparison_blocks(rows: list[dict], ranked: list[dict] | None = None) -> list:
    """The comparison table (one column per variant, the figures of COLUMNS as rows) and, per variant, its
    ideal law, the operating points left out of the figures and the contacts over their allowable pressure.
    The table never looks better than the run: when a variant has fewer than half its points ok, a first
    row says so in its column; a figure over no ok point is '—'; a pressure over the allowable is marked."""
    table = Table("CVT comparison over the operating envelope (γ × τ⊥)", ["figure", *[r["name"] for r in rows]])
    table.add("contact law", *[r["contact_law"] for r in rows])
    table.add("calibration", *[r["calibration"]["cell"] for r in rows])
    under = [2 * r["ok"] < r["points"] for r in rows]
    if any(under):
        table.add("operating points ok", *[f"{r['ok']} of {r['points']}" + (" (under half)" if u else "")
                                           for r, u in zip(rows, under)], style="bad")
    for key, label, fmt in COLUMNS:
        table.add(label, *[figure_cell(r, key, fmt) for r in rows])
    duty = next((r["life_duty"] for r in rows if "life_duty" in r), None)
    if duty:
        table.add(LIFE_LABEL, *[life_cell(r) for r in rows])
    blocks = [table, Note("¹ over the points with |γ| ≥ 5° and |τ⊥| ≥ 25 % of the largest load that deliver power "
                          "(it leaves at one shaft): " + "; ".join(_efficiency_points(r) for r in rows)),
              Note("² the largest power lost at a point that delivers none (zero load, γ = 0, or power entering "
                   "both shafts), where an efficiency means nothing")]
    if duty:
        blocks.append(Note(f"life: on the duty cycle {duty}, to the first contact's first limit (docs/life.md; "
                           "`cvtdesign life --duty` gives each contact's temperature, wear and life, with intervals)"))
    sentences = compare_report.ordering_sentences(ranked or [])
    if sentences:
        blocks.append(Note("orderings at 95 %: " + "; ".join(sentences)))
    blocks += [Note(t) for t in (interval_note(r) for r in rows) if t]
    budgets = [f"{r['name']}: " + ", ".join(f"{k} {v:.0%}" for k, v in list(r["max_abs_alpha_deg_budget"].items())[:3])
               for r in rows if r.get("max_abs_alpha_deg_budget")]
    if budgets:
        blocks.append(Note("what max |α|'s interval rests on (measure the first first): " + "; ".join(budgets)))
    envelopes = {r["envelope"] for r in rows}
    blocks.append(Note(f"envelope: {envelopes.pop()}" if len(envelopes) == 1 else
                       "envelopes differ (--as-written): " + "; ".join(f"{r['name']} {r['envelope']}" for r in rows),
                       "" if len(envelopes) <= 1 else "bad"))
    for r in rows:
        blocks.append(Note(f"{r['name']}: {r['ideal_law']}; calibration: {r['calibration']['text']}",
                           "bad" if r["calibration"]["uncalibrated"] else ""))
        if r["ok"] and not r["name"].startswith("ideal"):
            blocks.append(Note(f"{r['name']}: where: {where_text(r)}"))
        if r["ok"] < r["points"]:
            blocks.append(Note(f"{r['name']}: {r['points'] - r['ok']} of {r['points']} operating points left out "
                               f"of the figures: {left_out_text(r)}", "bad"))
        if r.get("max_hertz_pressure_over_allowable"):
            at = ", ".join(f"{n} ×{k}" for n, k in r["hertz_over_allowable_at"].items())
            blocks.append(Note(f"{r['name']}: Hertz peak pressure over the contact's allowable pressure "
                               f"({r['hertz_allowable_pressure_MPa']:.3g} MPa) at {at} points", "bad"))
    return blocks


WHERE = {"max_abs_alpha_deg": "max |α|", "ratio_error_pct_at_max_load": "ratio error", "min_efficiency":
         "worst efficiency", "max_loss_no_output_W": "max loss without output", "max_traction_utilisation":
         "max F/(μN)", "max_hertz_pressure_MPa": "max Hertz p", "max_steering_torque_Nm": "max steering torque",
         "max_standstill_steering_torque_Nm": "steering torque at standstill"}    # the extremes whose place the notes give


def where_text(r: dict) -> str:
    """Where each extreme figure of a variant is taken: 'max |α| at γ 40°, τ⊥ +1 N·m; max F/(μN) at B, …'."""
    parts = []
    for key, label in WHERE.items():
        at = r.get(at_key(key))
        if at and not (key.endswith("torque_Nm") and abs(r.get(key) or 0.0) < ZERO_TORQUE):   # no place for a 0
            contact = f"{at['contact']}, " if at.get("contact") else ""
            parts.append(f"{label} at {contact}γ {at['gamma_deg']:g}°, τ⊥ {at['tau_perp_Nm']:+g} N·m")
    return "; ".join(parts)


def interval_note(r: dict) -> str | None:
    """How a variant's intervals were made: first order, checked by sampling, sampled where the first order does
    not hold, or none where the figure left the physics in samples; None where it has no interval."""
    keys = [key for key, _, _ in COLUMNS if r.get(f"{key}_interval") is not None or f"{key}_interval_method" in r]
    if not keys:
        return None
    methods = {key: r.get(f"{key}_interval_method") for key in keys}
    if not any(methods.values()):
        return f"{r['name']}: intervals to first order, not checked by sampling (--samples N checks them)"
    labels = {key: label for key, label, _ in COLUMNS}
    sampled = [labels[k] for k, m in methods.items() if m and m.startswith("sampled")]
    left = [f"{labels[k]} ({m})" for k, m in methods.items() if m and m.startswith("left")]
    text = f"{r['name']}: intervals to first order, checked by sampling every input"
    text += f"; sampled where the first order does not hold: {', '.join(sampled)}" if sampled else ""
    return text + (f"; none where the figure left the physics: {', '.join(left)}" if left else "")


def figure_cell(r: dict, key: str, fmt: str) -> str:
    """A variant's figure as the table shows it: '—' where no point is ok to take it over; with its 95 %
    interval where the calibration's uncertainty is known; a Hertz pressure over the allowable marked with it."""
    if key in r.get("not_modelled", ()):
        return "not modelled"
    if r[key] is None or not r["ok"]:
        return "—"
    text = fmt.format(r[key])
    interval = r.get(f"{key}_interval")
    if interval is not None and interval[1] - interval[0] > 0.5 * 10 ** -_decimals(fmt):
        text += " [" + ", ".join(fmt.format(v) for v in interval) + "]"
    if key == "max_hertz_pressure_MPa" and r.get("max_hertz_pressure_over_allowable"):
        text += f" > {r['hertz_allowable_pressure_MPa']:.3g} allowed"
    return text


def _decimals(fmt: str) -> int:
    return int(fmt.split(".")[1][0])


def _efficiency_points(row: dict) -> str:
    text = f"{row['name']} {row['efficiency_points']}"
    return text + (f" ({row['no_output_points']} more deliver none)" if row["no_output_points"] else "")
