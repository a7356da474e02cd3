"""`cvtdesign transient`: transient steering dynamics of variants side by side (core.dynamics,
docs/dynamics.md): a step of the command, the fastest ratio change and its limit, the bandwidth at chosen
operating points and the ratio error while rendering a constraint, with the assumed parameters they rest on;
figures and a report."""
from __future__ import annotations

import tempfile
from pathlib import Path

from rich.console import Console

from cvtdesign.cli.printing import progress_bar, report_text, show
from cvtdesign.io.output import make_folder, write_files
from cvtdesign.io.report import Note, Table, png_figure
from cvtdesign.io.units import number
from cvtdesign.uses import transient as uses

NULL = "— ¹"       # a figure where the physics stopped holding, or not computed: its reason in the notes


def _ms(seconds) -> str:
    return NULL if seconds is None else number(seconds * 1e3, 3)


def _cell(value, digits: int = 3) -> str:
    return NULL if value is None else number(value, digits)


def _rate_cell(r: dict) -> str:
    if r["max_rate_deg_s"] is None:
        return NULL
    return f"{number(r['max_rate_deg_s'], 3)} ({r['max_rate_limit']})"


def transient_blocks(rows: list[dict]) -> list:
    """The printed table (one column per variant, the figures as rows) and its notes: why a figure is missing,
    and which parameters each variant's figures rest on as assumed."""
    s = rows[0]["step"]
    t = Table(f"Transient steering: step of γ_cmd {s['gamma_from_deg']:g}° → {s['gamma_to_deg']:g}°",
              ["figure", *[r["name"] for r in rows]])
    t.add("load τ⊥ at the start [N·m]", *[number(r["step"]["load_Nm"], 3) for r in rows])
    t.add("  shaft 2's torque τ2, then held [N·m]", *[_cell(r["step"]["tau_2_Nm"]) for r in rows])
    t.add("lag to 50 % [ms]", *[_ms(r["step"]["lag_s"]) for r in rows])
    t.add("rise 10–90 % [ms]", *[_ms(r["step"]["rise_s"]) for r in rows])
    t.add("settling to 2 % [ms]", *[_ms(r["step"]["settle_s"]) for r in rows])
    t.add("overshoot [%]", *[_cell(r["step"]["overshoot_pct"]) for r in rows])
    t.add("fastest ratio change dγ/dt [°/s] (limit)", *[_rate_cell(r) for r in rows], style="bold")
    for k, b in enumerate(rows[0]["bandwidth_Hz"]):
        t.add(f"bandwidth γ_axis/γ_cmd at γ {b['gamma_deg']:g}° [Hz]",
              *[_cell(r["bandwidth_Hz"][k]["f3dB_Hz"]) for r in rows])
        t.add(f"bandwidth ratio at γ {b['gamma_deg']:g}° [Hz]",
              *[_cell(r["bandwidth_Hz"][k]["ratio_f3dB_Hz"]) for r in rows])
    g = rows[0]["rendering"]
    t.add(f"rendering at {g['frequency_Hz']:g} Hz: RMS ratio error, dynamic",
          *[_cell(r["rendering"]["rms_error_dynamic"]) for r in rows])
    t.add("  quasi-static model's", *[_cell(r["rendering"]["rms_error_quasi_static"]) for r in rows])
    t.add("  largest ratio error, dynamic", *[_cell(r["rendering"]["max_error_dynamic"]) for r in rows])
    return [t] + transient_notes(rows)


def transient_notes(rows: list[dict]) -> list:
    """The table's footer: what each row means, the reasons of its missing figures, the assumed parameters."""
    g = rows[0]["rendering"]
    notes = [Note(f"the load τ⊥ fixes the steady state at γ_cmd {g['gamma_from_deg']:g}°, where every run starts; "
                  "shaft 2's torque there is then held (a brake, or the operator's push on the joint, stays as it "
                  "was while the ratio changes), as it is at each bandwidth point's γ. "
                  f"Step: from the steady state at γ_cmd {g['gamma_from_deg']:g}°, lag the time to 50 % of γ_axis's "
                  "change, settling the last time outside ±2 %; fastest ratio change: the fastest ramp of γ_cmd "
                  "with no contact in gross slip and the steering motor within its torque-speed curve; bandwidth: "
                  "the −3 dB frequency of the linearised model; rendering: the speed ratio swung between the ideal "
                  f"ratios of {g['gamma_from_deg']:g}° and {g['gamma_to_deg']:g}°, errors in ω2/ω1 over the last "
                  "period (docs/dynamics.md)")]
    for r in rows:
        why = [f"step: {r['step']['reason']}"] if r["step"]["reason"] else []
        why += [f"fastest ratio change: {r['max_rate_reason']}"] if r["max_rate_reason"] else []
        why += [f"bandwidth at γ {b['gamma_deg']:g}°: {b['reason']}" for b in r["bandwidth_Hz"] if b["reason"]]
        why += [f"rendering: {r['rendering']['reason']}"] if r["rendering"]["reason"] else []
        if why:
            notes.append(Note(f"¹ {r['name']}: no figure for " + "; ".join(why), "warn"))
    said: dict = {}          # the same assumptions of several variants said once
    for r in rows:
        if r["parameters"]["assumed"]:
            said.setdefault(assumed_text(r["parameters"]), []).append(r["name"])
    notes += [Note(f"{', '.join(names)}: these figures rest on assumed parameters, not the variant's own: {text} "
                   "(give them in the variant's dynamics: section; docs/dynamics.md)", "warn")
              for text, names in said.items()]
    return notes


def assumed_text(p: dict) -> str:
    """'sphere_inertia, …; the steering motor 4 N·m, …': the assumed fields, the motor's with their values and
    sources (the `parameters` record of uses.transient.parameters_record)."""
    motor = [f"{k} {number(p['values'][k]['value'], 3)} {p['values'][k]['unit']} ({p['values'][k]['source']})"
             for k in p["assumed"] if k.startswith("motor") or k == "servo_bandwidth"]
    return ", ".join(p["assumed"]) + (f"; the steering motor: {'; '.join(motor)}" if motor else "")


def run(args):
    s = uses.settings(args.gamma_from or uses.GAMMA_FROM, args.gamma_to or uses.GAMMA_TO, args.load,
                      args.bandwidth_at or uses.BANDWIDTH_AT,
                      uses.RENDER_HZ if args.render_hz is None else args.render_hz, args.quick)
    files = [Path(f) for f in args.variants]
    console = Console(width=max(100, 60 + 24 * len(files)))
    with progress_bar(console, "transient", lambda item: item, transient=True) as progress:
        result = uses.transient_run(files, s, progress)
    blocks = transient_blocks(result.rows)
    # the files first, then the terminal (a reader closing stdout early loses no file)
    written, out, kinds, drawn = [], {}, {}, []
    if args.plots:
        drawn = uses.transient_figures(result.rows, result.curves, files, make_folder(args.plots, kind="--plots"))
        written += [f"plot: {p}" for p in drawn]
    if args.report:         # the figures --plots drew, else drawn for the report alone
        with tempfile.TemporaryDirectory() as tmp:
            paths = drawn or uses.transient_figures(result.rows, result.curves, files, Path(tmp))
            figs = [png_figure(p) for p in paths]
        out[Path(args.report)], kinds[Path(args.report)] = report_text(args, "cvtdesign transient", blocks + figs), \
            "--report"
        written.append(f"report written to {args.report}")
    if args.json:
        out[Path(args.json)], kinds[Path(args.json)] = result.to_json(), "--json"
        written.append(f"figures written to {args.json}")
    write_files(out, kind=kinds)
    show(console, blocks)
    for line in written:
        console.print(line)
    return 0
