"""`cvtdesign resteer`: steering commands for requested speed ratios under a known load (Brokowski sec. 5)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from cvtdesign.cli.arguments import effects_arg
from cvtdesign.cli.printing import json_text
from cvtdesign.core.model import compile_model
from cvtdesign.diagnosis import resteer, rig
from cvtdesign.errors import InputError
from cvtdesign.diagnosis import measured
from cvtdesign.io import plots
from cvtdesign.io.output import make_folder, write_file
from cvtdesign.io.units import to_si
from cvtdesign.io.variant import load_variant


def run(args):
    if args.truth_set and args.truth_effects is None:
        raise InputError("--truth-set: sets a parameter of the rig's effects; expected --truth-effects with it")
    layout = load_variant(args.variant)
    effects = effects_arg(args.effects, layout.effects, "--effects")
    # the arguments first (a finite load inside the envelope, finite positive ratios), then the data
    load = None if args.load is None else resteer.check_load(layout, to_si(args.load, "torque", "--load"), "--load")
    ratios = resteer.check_ratios(layout, resteer.parse_ratios(args.ratios, "--ratios") if args.ratios
                                  else resteer.RATIOS, "--ratios")
    truth = truth_params = None
    if args.truth_effects is not None:
        truth = effects_arg(args.truth_effects, layout.effects, "--truth-effects")
        truth_params = rig.parse_settings(args.truth_set, truth, "--truth-set")
    data = measured.load_measured(args.data, layout, args.drop_bad) if args.data else None
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
    if args.plots and table:
        figure = make_folder(args.plots, kind="--plots") / f"{Path(args.variant).stem}_resteer.png"
        plots.resteer_figure(ratios, load, table, figure)
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
        console.print("fitted: " + ", ".join(f"{n} = {p['value']:.4g} ± {p['std']:.2g}" for n, p in cmds["fit"].items())
                      + f"; lookup at the data's load level {cmds['lookup_load']:+.3g} N·m")
    if figure:
        console.print(f"plot: {figure}")
    return 0
