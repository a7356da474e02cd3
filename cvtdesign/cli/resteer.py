"""`cvtdesign resteer`: steering commands for requested speed ratios under a known load (Brokowski sec. 5)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from cvtdesign.cli.arguments import effects_arg
from cvtdesign.cli.diagnosis_text import bound_mark
from cvtdesign.cli.printing import show
from cvtdesign.io.strict_json import json_text
from cvtdesign.core.model import compile_model
from cvtdesign.diagnosis import resteer, rig
from cvtdesign.errors import InputError
from cvtdesign.diagnosis import measured
from cvtdesign.io import plots
from cvtdesign.io.limits import check_points
from cvtdesign.io.output import make_folder, write_file
from cvtdesign.io.units import to_si
from cvtdesign.io.report import Note
from cvtdesign.io.variant import load_variant


TABLE_ONLY = ("--table-ratios", "--table-loads")                                  # options of --table alone
NOT_WITH_TABLE = ("--load", "--ratios", "--truth-effects", "--truth-set", "--json", "--plots")   # of a few ratios


def inputs(args) -> tuple[str, str | None]:
    """(variant file, measured data file or None): `resteer DATA.csv --variant VARIANT.yaml`, or without data
    `resteer VARIANT.yaml` (a .yaml or .yml file in the data's place is the variant) or `resteer --variant
    VARIANT.yaml`."""
    given = args.data
    if given and Path(given).suffix.lower() in (".yaml", ".yml"):
        if args.variant:
            raise InputError(f"resteer: {given} is a variant file and --variant names another ({args.variant}); "
                             "expected one variant, with measured data as CSV: resteer DATA.csv --variant VARIANT.yaml")
        return given, None
    if not args.variant:
        raise InputError("resteer: no variant; expected resteer VARIANT.yaml, or --variant VARIANT.yaml (with "
                         "measured data: resteer DATA.csv --variant VARIANT.yaml)")
    return args.variant, given


def check_options(args) -> None:
    """--table writes the controller table over its own grid: the options of the few-ratios resteering are
    refused with it, and its grid's without it (each with one line)."""
    for option in NOT_WITH_TABLE if args.table else TABLE_ONLY:
        if getattr(args, option[2:].replace("-", "_")) is not None:
            raise InputError(f"{option}: " + (
                "belongs to resteering a few ratios at one load; with --table the grid is --table-ratios × "
                "--table-loads" if args.table else "sets the grid of the controller table; expected --table with it"))


def run(args):
    check_options(args)
    if args.truth_set and args.truth_effects is None:
        raise InputError("--truth-set: sets a parameter of the rig's effects; expected --truth-effects with it")
    variant, data_file = inputs(args)
    layout = load_variant(variant)
    effects = effects_arg(args.effects, layout.effects, "--effects")
    if args.table:
        return write_table(args, layout, effects, data_file)
    # the arguments first (a finite load inside the envelope, finite positive ratios), then the data
    load = None if args.load is None else resteer.check_load(layout, to_si(args.load, "torque", "--load"), "--load")
    ratios = resteer.check_ratios(layout, resteer.parse_ratios(args.ratios, "--ratios") if args.ratios
                                  else resteer.RATIOS, "--ratios")
    truth = truth_params = None
    if args.truth_effects is not None:
        truth = effects_arg(args.truth_effects, layout.effects, "--truth-effects")
        truth_params = rig.parse_settings(args.truth_set, truth, "--truth-set")
    data = measured.load_measured(data_file, layout, args.drop_bad) if data_file else None
    if load is None:
        load = resteer.default_load(layout, data)
    cmds = resteer.commands(layout, effects, load, ratios, data)
    console = Console(width=120)
    table = None
    if truth is not None:
        tmodel = compile_model(layout.with_effects(truth, truth_params))
        table = resteer.achieved(tmodel, cmds)
    t = Table(title=f"resteering under τ⊥ = {load:+.3g} N·m: commanded γ \\[deg]"
                    + (" / achieved ω2/ω1 / error by Brokowski eq 23 \\[%]" if table else ""))
    t.add_column("requested ω2/ω1", justify="right")
    for m in cmds["methods"]:
        t.add_column(m, justify="right")
    for i, q in enumerate(ratios):
        cells = []
        for m, gs in cmds["methods"].items():
            c = f"{np.degrees(gs[i]):.2f}°" if np.isfinite(gs[i]) else "none"
            if table and np.isfinite(gs[i]):
                got = table[m]["achieved"][i]
                c += f" / {got:.3f} / {table[m]['error_pct'][i]:+.1f}" if np.isfinite(got) else " / no solution"
            cells.append(c)
        t.add_row(f"{q:g}", *cells)
    if table:
        t.add_row("mean |error| \\[%]", *[f"{e:.2f}" if np.isfinite(e := table[m]["mean_abs_error_pct"]) else "—"
                                          for m in cmds["methods"]])
    figure = None          # the files first, then the terminal (a reader closing stdout early loses no file)
    if args.plots:          # scored on the rig with --truth-effects, else the commands' corrections
        figure = make_folder(args.plots, kind="--plots") / f"{Path(variant).stem}_resteer.png"
        plots.resteer_figure(ratios, load, table, figure, cmds)
    if args.json:
        write_file(args.json, json_text({"commands": cmds, "achieved": table}), kind="--json")
    console.print(t)
    if any(not np.isfinite(g) for gs in cmds["methods"].values() for g in gs):
        console.print("none: no commanded γ inside the envelope gives that ratio under this load (by that method)")
    if table and any(np.isfinite(g) and not np.isfinite(q) for m, gs in cmds["methods"].items()
                     for g, q in zip(gs, table[m]["achieved"])):
        console.print("no solution: the CVT (the rig's model) has no physical solution at that command and load "
                      "(gross slip, lost contact or no convergence), so the command is not scored")
    if cmds["fit"]:
        console.print("fitted: " + fitted_text(cmds["fit"]) + f"; lookup at the data's load level {cmds['lookup_load']:+.3g} N·m")
    if figure:
        console.print(f"plot: {figure}")
    return 0


def fitted_text(params: dict) -> str:
    """'name = value ± σ, …' of a fit, each parameter that ended on a bound marked (diagnosis_text.bound_mark)."""
    return ", ".join(f"{n} = {p['value']:.4g} ± {p['std']:.2g}{bound_mark(p)}" for n, p in params.items())


def table_axes(args, layout) -> tuple[list[float], list[float]]:
    """The controller table's ratios and loads [N m]: --table-ratios and --table-loads (each a list or
    START:STOP:COUNT), by default from the envelope (resteer.default_axes); every ratio within the ideal law's
    reach over the envelope's γ and every load within its load range; at most as many scan points as one
    evaluation may hold."""
    ratios, loads = resteer.default_axes(layout)
    if args.table_ratios:
        ratios = resteer.check_ratios(layout, resteer.parse_axis(args.table_ratios, "--table-ratios",
                                                                 resteer.ratio_value), "--table-ratios")
    if args.table_loads:
        loads = [resteer.check_load(layout, t, "--table-loads") for t in resteer.parse_axis(
            args.table_loads, "--table-loads", lambda text, where: to_si(text, "torque", where))]
    check_points(len(ratios) * len(loads) * resteer.SCAN_POINTS, len(layout.rollers), "--table-ratios × --table-loads",
                 f"scan points ({len(ratios)} ratios × {len(loads)} loads × {resteer.SCAN_POINTS})")
    return ratios, loads


def write_table(args, layout, effects, data_file) -> int:
    """`resteer VARIANT.yaml --table FILE.csv`: the controller table (resteer.command_table) written, then a
    summary printed: what it covers, where it gives no command and why, what the ideal command would miss,
    and what interpolating it leaves at the centres of its cells."""
    ratios, loads = table_axes(args, layout)
    data = measured.load_measured(data_file, layout, args.drop_bad) if data_file else None
    model, fit = resteer.model_and_fit(layout, effects, data)
    theta = fit.theta if fit else None
    table = resteer.command_table(model, ratios, loads, theta)
    between = resteer.interpolation_error(model, table, theta)
    write_file(args.table, resteer.table_csv(table), kind="--table")
    console = Console(width=120)
    show(console, table_notes(table, between, "fitted" if fit else "nominal", args.table))
    if fit:
        console.print("fitted: " + fitted_text(fit.params()))
    return 0


def table_notes(table: dict, between: dict, which: str, path) -> list:
    """What the controller table holds, in a few lines (write_table)."""
    q, t, st = table["ratio"], table["tau_perp"], table["status"]
    notes = [Note(f"controller table: γ_cmd from the {which} model for {q.shape[0]} ratios ω2/ω1 ({q.min():.4g}.."
                  f"{q.max():.4g}) × {q.shape[1]} loads τ⊥ ({t.min():.4g}..{t.max():.4g} N·m), written to {path}")]
    for reason, words, style in (("unreachable", "no γ inside the envelope gives the ratio under that load", "warn"),
                                 ("no_solution", "the model has no physical solution where the command would be "
                                                 "(gross slip, lost contact or no convergence)", "bad")):
        where = st == reason
        if where.any():
            first = ", ".join(f"{a:.4g} at {b:+.3g} N·m" for a, b in list(zip(q[where], t[where]))[:3])
            notes.append(Note(f"no command at {int(where.sum())} of {st.size} nodes ({reason}: {words}): "
                              f"{first}{', …' if where.sum() > 3 else ''}", style))
    ideal, resid = np.abs(table["ideal_ratio_error"]), np.abs(table["residual_ratio_error"])
    if np.isfinite(ideal).any():
        k = np.nanargmax(ideal)
        notes.append(Note(f"the ideal command would miss by up to {ideal.flat[k]:.4g} in ω2/ω1 (ratio {q.flat[k]:.4g} "
                          f"at {t.flat[k]:+.3g} N·m); the table's commands leave at most "
                          f"{np.nanmax(resid) if np.isfinite(resid).any() else float('nan'):.2g} at its nodes"))
    if between["max_abs"] is not None:
        notes.append(Note(f"interpolated bilinearly, the commands leave at most {between['max_abs']:.3g} in ω2/ω1 at "
                          f"the centres of its {between['cells']} cells (worst at ratio {between['ratio']:.4g}, "
                          f"{between['tau_perp']:+.3g} N·m); a finer grid there leaves less"))
    return notes
