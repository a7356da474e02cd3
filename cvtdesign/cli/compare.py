"""`cvtdesign compare`: variants side by side over their envelope, with the ideal CVT and Kim's existing CVT."""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

from rich.console import Console

from cvtdesign.cli import compare_report
from cvtdesign.cli.printing import json_text, left_out_text, report_text, show
from cvtdesign.core import basis
from cvtdesign.core.contact.laws import contact_law
from cvtdesign.core.metrics import ZERO_TORQUE, at_key, envelope, ideal_model, metrics
from cvtdesign.core.model import compile_model
from cvtdesign.core.uncertainty import intervals, point_bands
from cvtdesign.io import plots
from cvtdesign.io.limits import check_envelope_limits
from cvtdesign.io.output import make_folder, named_after, write_file
from cvtdesign.io.points import check_points_path, contact_points, write_points
from cvtdesign.io.report import Note, Table
from cvtdesign.errors import InputError
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
    ("max_steering_torque_Nm", "max steering torque [N·m]", "{:.3f}"),
    ("max_standstill_steering_torque_Nm", "steering at standstill [N·m]", "{:.3f}"),
]


_BASIS_LABELS = [("contact_law", "contact law"), ("calibration", "calibration")]   # the table's first rows


def run(args):
    """Print the comparison table and have args.painter (the plotting process that cli.parser starts before it
    imports this module) draw the figure meanwhile: the table is printed before the figure is waited for,
    which is completely written (and --report after it) when this returns."""
    painter = args.painter
    if args.points:
        check_points_path(args.points)
    files = [Path(f) for f in args.variants]
    layouts = [load_variant(f) for f in files]
    if len(files) == 1:                            # Kim's CVT under the same law, wherever the command runs from
        existing = shipped_variant(contact_law(layouts[0].contact_law).reference_variant)
        if existing.resolve() != files[0].resolve():
            layouts.insert(0, load_variant(existing))
    layouts = one_basis(layouts, layouts[-1] if len(files) == 1 else layouts[0], args)
    names = basis.distinct_names(layouts)
    layouts = [dataclasses.replace(L, name=n) for L, n in zip(layouts, names)]
    models = [compile_model(L) for L in layouts]
    results = [envelope(m) for m in models]
    figure = make_folder(args.out, kind="--out") / named_after(files, ".png")     # another set, another file
    replaced = figure.exists()
    # the figure is drawn while the ideal CVT is evaluated and the table printed
    painter.draw(plots.compare_figure, [(L.name, {k: res[k] for k in plots.COMPARE_KEYS} | point_bands(m, res)
                                     | {"theory_only": basis.calibration(L)["uncalibrated"]})
                                    for L, m, res in zip(layouts, models, results)], figure)
    rows = [with_intervals(m, res, metrics(m, res) | basis.fields(m.layout)) for m, res in zip(models, results)]
    if len(files) == 1:
        ideal = ideal_model(layouts[-1])
        row = metrics(ideal, envelope(ideal)) | basis.fields(ideal.layout)
        row |= {"name": f"ideal ({layouts[-1].name})", "contact_law": "rigid (ideal)",
                "calibration": {"source": "none needed: rigid rolling", "uncalibrated": False, "std": {},
                                "text": "none needed: rigid rolling", "cell": "none needed"}}
        rows.insert(0, row)

    if args.points:
        write_points(args.points, [contact_points(L.name, L, res) for L, res in zip(layouts, results)])
    blocks = comparison_blocks(rows)
    if args.json:
        write_file(args.json, json_text({"variants": rows}), kind="--json")
    console = Console(width=max(100, 30 + 22 * len(rows)))
    # the table while the figure is still drawn; a reader that closes stdout early (`| head`: a BrokenPipeError,
    # or rich's exit) still gets every file, in full
    try:
        show(console, blocks)
    except (BrokenPipeError, SystemExit):
        finish(args, painter, rows, blocks, figure)
        raise
    error = finish(args, painter, rows, blocks, figure)
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


def finish(args, painter, rows: list[dict], blocks: list, figure: Path) -> str | None:
    """Wait for the figure, then write --report (it shows the figure); the plotting error's text or None."""
    error = painter.wait()
    if args.report and not error:
        labels = {k: label for k, label in _BASIS_LABELS} | {"ok": "operating points ok"} | \
            {key: label for key, label, _ in COLUMNS}
        report = compare_report.report_blocks(rows, blocks, figure, labels)
        write_file(args.report, report_text(args, "cvtdesign compare", report), kind="--report")
    return error


def with_intervals(model, res: dict, row: dict) -> dict:
    """The row with a 95 % interval on each figure from the calibration's uncertainty (core.uncertainty)."""
    return row | intervals(model, res, row)


def one_basis(layouts: list, first, args) -> list:
    """The layouts on one basis: one contact law (different laws are refused unless --as-written) and one
    envelope, the first file's or --envelope's (with --as-written each keeps its own)."""
    if args.as_written:
        return layouts
    laws = {L.contact_law for L in layouts}
    if len(laws) > 1:
        which = ", ".join(f"{L.file}: {L.contact_law}" for L in layouts)
        raise InputError(f"compare: the variants use different contact laws ({which}); compare them under one "
                         "law (contact.law), or add --as-written to compare each as written")
    reference = load_variant(args.envelope) if args.envelope else first
    out = []
    for L in layouts:
        if not basis.same_envelope(L, reference):
            L = basis.on_envelope(L, reference)
            check_envelope_limits(L, f"{L.file}: on the envelope of {reference.file}")
        out.append(L)
    return out


def comparison_blocks(rows: list[dict]) -> list:
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
    blocks = [table, Note("¹ over the points with |γ| ≥ 5° and |τ⊥| ≥ 25 % of the largest load that deliver power "
                          "(it leaves at one shaft): " + "; ".join(_efficiency_points(r) for r in rows)),
              Note("² the largest power lost at a point that delivers none (zero load, γ = 0, or power entering "
                   "both shafts), where an efficiency means nothing")]
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


def figure_cell(r: dict, key: str, fmt: str) -> str:
    """A variant's figure as the table shows it: '—' where no point is ok to take it over; with its 95 %
    interval where the calibration's uncertainty is known; a Hertz pressure over the allowable marked with it."""
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
