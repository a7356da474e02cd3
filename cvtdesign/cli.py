"""The `cvtdesign` command."""
from __future__ import annotations

import argparse
import contextlib
import json
import sys
from pathlib import Path

import numpy as np

from .output import check_folder, check_target, make_folder, write_file, write_files
from .units import InputError

COLUMNS = [
    ("max_abs_alpha_deg", "max |α| [°]", "{:.3f}"),
    ("rms_alpha_deg", "RMS α [°]", "{:.3f}"),
    ("max_abs_alpha_steering_deg", "max |α| steering [°]", "{:.3f}"),
    ("max_abs_alpha_drive_deg", "max |α| drive [°]", "{:.3f}"),
    ("ratio_error_pct_at_max_load", "ratio error at max load [%]", "{:.2f}"),
    ("min_efficiency", "worst efficiency", "{:.3f}"),
    ("max_traction_utilisation", "max F/(μN)", "{:.3f}"),
    ("max_hertz_pressure_MPa", "max Hertz p [MPa]", "{:.2f}"),
]


def _finite(obj):
    """obj with numpy scalars and arrays as Python numbers and lists, and NaN or ±inf as None."""
    if isinstance(obj, dict):
        return {str(k): _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [_finite(v) for v in obj]
    if isinstance(obj, (np.integer, np.bool_)):
        return obj.item()
    if isinstance(obj, (float, np.floating)):
        return float(obj) if np.isfinite(obj) else None
    return obj


def json_text(obj) -> str:
    """Strict JSON (RFC 8259: no NaN or Infinity; a number that does not exist is null), indented."""
    return json.dumps(_finite(obj), indent=2, allow_nan=False, default=str) + "\n"


def left_out_text(counts: dict) -> str:
    """'gross slip at 12 points (D1 ×8, S1 ×4); lost contact at 3 points (S2 ×3)' from model.status_counts."""
    parts = []
    for key in ("lost_contact", "gross_slip", "not_converged"):
        if counts.get(key):
            at = counts.get(f"{key}_at") or {}
            where = f" ({', '.join(f'{k} ×{v}' for k, v in at.items())})" if at else ""
            parts.append(f"{key.replace('_', ' ')} at {counts[key]} points{where}")
    return "; ".join(parts)


def cmd_compare(args):
    from . import plots

    painter = plots.Background()   # imports matplotlib in a second process while we compute
    try:
        return _compare(args, painter)
    finally:
        painter.close()


def _compare(args, painter):
    from .evaluate import envelope, metrics
    from .model import compile_model
    from .variant import load_variant

    files = [Path(f) for f in args.variants]
    layouts = [load_variant(f) for f in files]
    rows, results = [], []
    if len(files) == 1:
        ideal = compile_model(layouts[0], effects=())
        res = envelope(ideal)
        row = metrics(ideal, res)
        row["name"] = f"ideal ({layouts[0].name})"
        rows.append(row)
        existing = Path("variants/existing.yaml")
        if not existing.exists():
            existing = files[0].parent / "existing.yaml"
        if existing.exists() and existing.resolve() != files[0].resolve():
            layouts.insert(0, load_variant(existing))
    for L in layouts:
        m = compile_model(L)
        res = envelope(m)
        rows.append(metrics(m, res))
        results.append((L, res))

    from rich.console import Console
    from rich.table import Table

    table = Table(title="CVT comparison over the operating envelope (γ × τ⊥)")
    table.add_column("figure")
    for row in rows:
        table.add_column(row["name"], justify="right")
    for key, label, fmt in COLUMNS:
        table.add_row(label, *["—" if r[key] is None else fmt.format(r[key]) for r in rows])
    console = Console(width=max(100, 30 + 22 * len(rows)))
    console.print(table)
    for r in rows:
        console.print(f"{r['name']}: {r['ideal_law']}")
        if r["ok"] < r["points"]:
            console.print(f"[red]{r['name']}: {r['points'] - r['ok']} of {r['points']} operating points left out "
                          f"of the figures: {left_out_text(r)}[/red]")

    figure = make_folder(args.out, kind="--out") / "compare.png"
    painter.draw("compare_figure", [(L.name, res) for L, res in results], figure)
    if args.json:
        write_file(args.json, json_text({"variants": rows}), kind="--json")
        console.print(f"figures written to {args.json}")
    error = painter.wait()
    if error:
        print(f"cvtdesign: error: plotting failed: {error}", file=sys.stderr)
        return 1
    console.print(f"plots: {figure}")
    return 0


@contextlib.contextmanager
def _progress(console, label: str, describe, transient: bool = False):
    """A rich progress bar (label, bar, done/total, elapsed time, the last item) as the callback
    progress(done, total, item) that long computations take; `describe(item)` says what the item was
    (item None: nothing finished yet)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("{task.description}"), console=console, transient=transient) as bar:
        task = bar.add_task("", total=None)
        yield lambda done, total, item: bar.update(task, total=total, completed=done,
                                                   description="" if item is None else describe(item))


def _export_steps(console, variant_files, out_dir: Path):
    """The STEP assembly (+ SVG, PNG) of each variant file, for mechanical review (`--step`)."""
    from .cad import export_variant

    files = list(dict.fromkeys(str(f) for f in variant_files if f))
    with _progress(console, "STEP export", lambda res: f"{Path(res['step']).name} ({len(res['parts'])} parts)") as progress:
        for k, f in enumerate(files):
            progress(k + 1, len(files), export_variant(f, out_dir))
    console.print(f"STEP assemblies of {len(files)} design(s) in {out_dir}")


def cmd_optimise(args):
    from rich.console import Console
    from rich.table import Table

    from . import optimise

    if args.starts is not None and args.starts < 1:
        raise InputError(f"--starts: expected a positive number of multistart points, got {args.starts}")
    console = Console(width=110)
    with _progress(console, "multistart", lambda sol: f"last: {sol.status}, f = {sol.objective:.5g}",
                   transient=True) as progress:
        res = optimise.run(args.study, args.out, args.starts, progress, write=False)
    # the optimum's variant file and the JSON report: written together, all or nothing
    files = res.pop("pending_files")
    kinds = {p: "variant file" for p in files}
    if files and args.out:
        make_folder(args.out, kind="--out")
    if args.json:
        keys = ("status", "objective", "design", "active_constraints", "variant_file")
        files[Path(args.json)] = json_text({k: res[k] for k in keys} | {"details": res})
        kinds[Path(args.json)] = "--json"
    write_files(files, kind=kinds)
    statuses = ", ".join(f"{s} ×{res['statuses'].count(s)}" for s in dict.fromkeys(res["statuses"]))
    console.print(f"study {res['study']}: {res['starts']} starts ({statuses}); "
                  f"{len(res['optima'])} distinct optima found " +
                  ", ".join(f"f = {o['objective']:.6g} ({o['found']}×)" for o in res["optima"]))
    if res["success"]:
        t = Table(title=f"optimum: {res['objective_kind']} = {res['objective']:.6g}")
        for c in ("variable", "optimum", "base"):
            t.add_column(c, justify="right")
        for n, v in res["design"].items():
            t.add_row(n, f"{v:.6g}", f"{res['base_design'][n]:.6g}")
        console.print(t)
        c = Table(title="constraints (most binding row of each; multiplier = objective change per unit of bound)")
        for col in ("constraint", "where", "value", "bound", "slack", "multiplier", "active"):
            c.add_column(col)
        for r in res["constraints"]:
            c.add_row(r["name"], r["where"], f"{r['value']:.5g}", f"{r['bound']:.5g}", f"{r['slack']:.3g}",
                      f"{r['multiplier']:.3g}", "yes" if r["active"] else "")
        console.print(c)
        console.print(f"optimised variant: {res['variant_file']}  (try: cvtdesign compare {res['variant_file']})")
        if args.step:
            _export_steps(console, [res["variant_file"]], Path(res["variant_file"]).parent / "step")
    else:
        chk = res.get("envelope_check")
        why = f"; worst point {chk['worst']}" if chk and chk.get("worst") else ""
        console.print(f"[red]no successful solve: {res['status']}{why}; no variant file written[/red]")
    return 0 if res["success"] else 1


def cmd_study(args):
    import numpy as np
    from rich.console import Console
    from rich.table import Table

    from . import study

    console = Console(width=120)
    with _progress(console, "cases", lambda row: f"last: {row['case_id']} {row['status']}") as progress:
        res = study.run_study(args.study, args.out, args.scheduler, args.workers, progress,
                              lambda text: console.print(text, style="yellow", markup=False, highlight=False,
                                                           soft_wrap=True))
    df = res["table"]
    if res["ran"]:
        console.print(f"{res['cases']} cases: {res['skipped']} already in {res['out_dir']}, {res['ran']} run in "
                      f"{res['seconds']:.1f} s (cluster start-up {res['startup_seconds']:.1f} s)")
    else:
        console.print(f"{res['cases']} cases: all already in {res['out_dir']}; nothing to run")
    t = Table(title="cases by status")
    t.add_column("status")
    t.add_column("cases", justify="right")
    for status, n in df.groupby("status")["case_id"].nunique().items():
        t.add_row(status, str(n))
    console.print(t)
    starts_ = df[(df["kind"] == "start") & df["success"]]
    if len(starts_):
        best = starts_.sort_values("objective").groupby(["variant", "fixed"], sort=False).head(1)
        b = Table(title="best optimum per variant and sweep point")
        for c in ("variant", "fixed", "objective", "found by", "variant file"):
            b.add_column(c)
        for _, r in best.iterrows():
            same = starts_[(starts_["variant"] == r["variant"]) & (starts_["fixed"] == r["fixed"]) &
                           (np.abs(starts_["objective"] - r["objective"]) <= 1e-6 * max(1, abs(r["objective"])))]
            b.add_row(r["variant"], r["fixed"], f"{r['objective']:.6g}", f"{len(same)} starts", str(r["variant_file"]))
        console.print(b)
    pareto = df[df["kind"] == "pareto"]
    if len(pareto):
        from . import plots
        from .optimise import knee

        chains = []
        for cid, grp in pareto.groupby("case_id", sort=False):
            pts = [dict(r) | {"index": r["point"]} for _, r in grp.sort_values("point").iterrows()]
            chains.append((cid, pts, knee(pts)))
            console.print(f"Pareto {cid}: knee at point {chains[-1][2]}")
        figure = Path(res["out_dir"]) / "pareto.png"
        plots.pareto_figure(chains, figure)
        console.print(f"Pareto plot: {figure}")
    if args.step:
        chosen = list(best["variant_file"]) if len(starts_) else []
        chosen += list(pareto[pareto["success"]]["variant_file"]) if len(pareto) else []
        _export_steps(console, [f for f in chosen if isinstance(f, str) and f], Path(res["out_dir"]) / "step")
    return 0 if df["success"].any() else 1


def _effects_arg(text, default, where):
    """'a,b' → effect names (checked, near names suggested); 'none' → no effects; None → default."""
    from .effects import check_effects

    if text is None:
        return tuple(default)
    if text.strip().lower() in ("", "none"):
        return ()
    return check_effects([e.strip() for e in text.split(",") if e.strip()], where)


def cmd_rig(args):
    from rich.console import Console

    from . import rig
    from .variant import load_variant

    if args.replicates is not None and args.replicates < 1:
        raise InputError(f"--replicates: expected at least 1 replicate of each operating point, got {args.replicates}")
    layout = load_variant(args.variant)
    effects = _effects_arg(args.effects, layout.effects, "--effects")
    params = rig.parse_settings(args.set, effects)
    protocol = rig.read_protocol(args.protocol, layout) if args.protocol else rig.kim_protocol(layout)
    if args.replicates is not None:
        protocol = rig.Protocol(protocol.gammas, protocol.loads, protocol.speeds, protocol.load_kind, args.replicates)
    noise = rig.parse_noise(args.noise)
    rows, failed = rig.simulate(layout, effects, params, protocol, noise, args.seed, axis=not args.no_axis)
    write_file(args.out, rig.to_csv_text(rows), kind="--out")
    console = Console()
    console.print(f"{len(rows)} rows ({protocol.replicates} replicate(s)) of {layout.name} with "
                  f"{', '.join(effects) or 'no effects'} written to {args.out}; noise σ: speed {noise.speed:g} rad/s, "
                  f"torque {noise.torque:g} N·m, axis {noise.axis * 57.29577951308232:g}°")
    if failed:
        console.print(f"[yellow]operating points not measured (the model's physics stops there): "
                      f"{left_out_text(failed)}[/yellow]")
    return 0


def cmd_diagnose(args):
    from rich.console import Console

    from . import diagnose, measured
    from .variant import load_variant

    layout = load_variant(args.variant)
    base = _effects_arg(args.base, layout.effects, "--base")
    candidates = _effects_arg(args.candidates, [], "--candidates")
    data = measured.load_measured(args.data, layout, args.drop_bad)
    console = Console(width=120)
    with _progress(console, "diagnosis", str, transient=True) as progress:
        rep = diagnose.diagnose(layout, data, base, candidates or None, progress)
    diagnose.print_report(rep, console)
    if args.plots:
        for f in diagnose.plot_report(rep, make_folder(args.plots, kind="--plots")):
            console.print(f"plot: {f}")
    if args.json:
        write_file(args.json, json_text(diagnose.public(rep)), kind="--json")
        console.print(f"report written to {args.json}")
    return 0


def cmd_selfcheck(args):
    from rich.console import Console

    from . import selfcheck

    if args.seeds < 1:
        raise InputError(f"--seeds: expected a positive integer (null datasets per noise level / 2), got {args.seeds}")
    console = Console(width=120)
    with _progress(console, "datasets", lambda row: f"last: {row['id']} → {row['verdict']}") as progress:
        only = [x.strip() for x in args.only.split(",")] if args.only else None
        matrices = [m.strip() for m in args.matrices.split(",")] if args.matrices else selfcheck.MATRICES
        bad = [m for m in matrices if m not in selfcheck.MATRICES]
        if bad:
            raise InputError(f"--matrices: unknown matrix '{bad[0]}' (expected {', '.join(selfcheck.MATRICES)})")
        results = selfcheck.run(args.variant, args.quick, args.seeds, args.scheduler, args.workers, progress, only,
                                matrices)
    summ = selfcheck.summary(results)
    selfcheck.print_summary(summ, results, console)
    if args.json:
        write_file(args.json, json_text({"summary": summ, "datasets": results}), kind="--json")
    return 0 if selfcheck.meets_targets(summ) else 1


def cmd_resteer(args):
    from rich.console import Console
    from rich.table import Table

    from . import measured, resteer, rig
    from .model import compile_model
    from .units import to_si
    from .variant import load_variant

    if args.truth_set and args.truth_effects is None:
        raise InputError("--truth-set: sets a parameter of the rig's effects; expected --truth-effects with it")
    layout = load_variant(args.variant)
    effects = _effects_arg(args.effects, layout.effects, "--effects")
    # the arguments first (a finite load inside the envelope, finite positive ratios), then the data
    load = None if args.load is None else resteer.check_load(layout, to_si(args.load, "torque", "--load"), "--load")
    ratios = resteer.parse_ratios(args.ratios, "--ratios") if args.ratios else list(resteer.RATIOS)
    truth = truth_params = None
    if args.truth_effects is not None:
        truth = _effects_arg(args.truth_effects, layout.effects, "--truth-effects")
        truth_params = rig.parse_settings(args.truth_set, truth, "--truth-set")
    data = measured.load_measured(args.data, layout, args.drop_bad) if args.data else None
    if load is None:
        load = float(data.load_levels.max()) if data is not None else float(layout.load_grid.max())
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
            c = f"{np.degrees(gs[i]):.2f}°"
            if table:
                c += f" / {table[m]['achieved'][i]:.3f} / {table[m]['error_pct'][i]:+.1f}"
            cells.append(c)
        t.add_row(f"{q:g}", *cells)
    if table:
        t.add_row("mean |error| \\[%]", *[f"{table[m]['mean_abs_error_pct']:.2f}" for m in cmds["methods"]])
    console.print(t)
    if cmds["fit"]:
        console.print("fitted: " + ", ".join(f"{n} = {p['value']:.4g} ± {p['std']:.2g}" for n, p in cmds["fit"].items())
                      + f"; lookup at the data's load level {cmds['lookup_load']:+.3g} N·m")
    if args.plots and table:
        from . import plots

        f = make_folder(args.plots, kind="--plots") / "resteer.png"
        plots.resteer_figure(ratios, load, table, f)
        console.print(f"plot: {f}")
    if args.json:
        write_file(args.json, json_text({"commands": cmds, "achieved": table}), kind="--json")
    return 0
def cmd_export(args):
    from rich.console import Console
    from rich.table import Table

    from .cad import export_variant

    res = export_variant(args.variant, args.out, args.gamma, args.check)
    console = Console(width=120)
    console.print(f"{res['step']}: {len(res['parts'])} parts at γ = {res['gamma_deg']:g}° (φ = {res['phi_deg']:.3f}°) "
                  f"in {res['seconds']:.1f} s; drawings {res['svg']}, {res['png']}")
    if not args.check:
        return 0
    t = Table(title=f"checks of the re-read STEP file ({res['check_seconds']:.1f} s)")
    for c in ("check", "result", "detail"):
        t.add_column(c)
    for row in res["checks"]:
        t.add_row(row["check"], "ok" if row["ok"] else "[red]FAILED[/red]", row["detail"])
    console.print(t)
    return 0 if all(row["ok"] for row in res["checks"]) else 1


class _Parser(argparse.ArgumentParser):
    """argparse with its errors as one line (no usage block): 'cvtdesign rig: error: argument --seed: invalid
    int value: 'x' (see cvtdesign rig --help)', exit status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())} (see {self.prog} --help)\n")


def build_parser():
    p = _Parser(prog="cvtdesign", description="Design, optimise and compare spherical CVTs.")
    sub = p.add_subparsers(dest="command", required=True)
    c = sub.add_parser("compare", help="evaluate variants over their envelope and print a side-by-side table")
    c.add_argument("variants", nargs="+", help="variant YAML files")
    c.add_argument("--out", default="out/compare", help="folder for the plots (default: out/compare)")
    c.add_argument("--json", help="also write the figures to this JSON file")
    c.set_defaults(func=cmd_compare)
    o = sub.add_parser("optimise", help="optimise a variant's parameters under slip/efficiency objectives (IPOPT)")
    o.add_argument("study", help="study YAML file (studies/*.yaml)")
    o.add_argument("--out", help="folder for the optimised variant (default: results/<study name>)")
    o.add_argument("--starts", type=int, help="number of multistart points (default: the study's)")
    o.add_argument("--json", help="also write the result to this JSON file")
    o.add_argument("--step", action="store_true", help="also export the optimum as a STEP assembly (+ SVG, PNG)")
    o.set_defaults(func=cmd_optimise)
    b = sub.add_parser("study", help="run a study's cases (sweeps, multistarts, Pareto fronts) in batch on Dask")
    b.add_argument("study", help="study YAML file (studies/*.yaml)")
    b.add_argument("--out", help="results store (default: results/<study name>)")
    b.add_argument("--scheduler", help="address of an existing Dask scheduler (default: a local cluster)")
    b.add_argument("--workers", type=int, help="local cluster size (default: one single-threaded worker per core)")
    b.add_argument("--step", action="store_true",
                   help="also export the best optimum of each variant/sweep point and every Pareto point as STEP")
    b.set_defaults(func=cmd_study)
    r = sub.add_parser("rig", help="virtual test rig: measured-like data (the measured-data CSV format) from the full model")
    r.add_argument("variant", help="variant YAML file")
    r.add_argument("--effects", help="effects on, comma-separated (default: the variant's; 'none' for the ideal CVT)")
    r.add_argument("--set", action="append", metavar="EFFECT.PARAM=VALUE",
                   help="an effect parameter, e.g. steering_lateral_creep.scale=1.2 or 'rolling_resistance.offset=0.2 mm'")
    r.add_argument("--noise", help="measurement noise σ, e.g. 'speed=0.01 rad/s,torque=0.005 N*m,axis=0.05 deg' "
                                   "(these are the defaults; plain numbers are SI)")
    r.add_argument("--protocol", help="protocol YAML (gamma, load, load_kind, motor_speed, replicates); default Kim's")
    r.add_argument("--replicates", type=int, help="repeat every operating point this many times")
    r.add_argument("--seed", type=int, default=0, help="random seed of the noise (default 0)")
    r.add_argument("--no-axis", action="store_true", help="do not record the axis angle gamma_axis_deg")
    r.add_argument("--out", required=True, help="CSV file to write")
    r.set_defaults(func=cmd_rig)
    d = sub.add_parser("diagnose", help="where the model and the data disagree, which effect causes it, how far it shrinks")
    d.add_argument("data", help="measured data CSV (columns gamma_cmd_deg, omega_1, omega_2, tau_1, tau_2 [, gamma_axis_deg])")
    d.add_argument("--variant", required=True, help="variant YAML file the data was measured on")
    d.add_argument("--base", help="effects of the model to diagnose, comma-separated (default: the variant's)")
    d.add_argument("--candidates", help="candidate effects to try (default: every effect not in the base)")
    d.add_argument("--drop-bad", action="store_true", help="drop (and count) bad rows instead of stopping")
    d.add_argument("--json", help="write the report to this JSON file")
    d.add_argument("--plots", help="folder for the residual-map and fit plots")
    d.set_defaults(func=cmd_diagnose)
    s = sub.add_parser("selfcheck", help="prove the diagnosis on rig data with withheld effects; exit 1 if a target is missed")
    s.add_argument("--variant", help="variant of the rig matrix (default: variants/existing.yaml)")
    s.add_argument("--matrices", help="comma-separated: rig (the project's own model makes the data), independent "
                                      "(an independently written simulator of Kim's CVT); default: both")
    s.add_argument("--quick", action="store_true", help="a reduced matrix (one value and noise level per effect)")
    s.add_argument("--seeds", type=int, default=3, help="null datasets per noise level / 2 (default 3)")
    s.add_argument("--scheduler", help="address of an existing Dask scheduler (default: a local cluster)")
    s.add_argument("--workers", type=int, help="local cluster size (default: one worker per core)")
    s.add_argument("--only", help="run only the datasets whose id contains one of these comma-separated texts")
    s.add_argument("--json", help="write the per-dataset results and the summary to this JSON file")
    s.set_defaults(func=cmd_selfcheck)
    t = sub.add_parser("resteer", help="steering commands for requested speed ratios under a known load (Brokowski sec. 5)")
    t.add_argument("data", nargs="?", help="measured data CSV: fit the model to it and add the inverted data lookup")
    t.add_argument("--variant", required=True, help="variant YAML file")
    t.add_argument("--effects", help="effects of the model (default: the variant's)")
    t.add_argument("--load", help="lateral load τ⊥, e.g. '1 N*m' (default: the data's highest load level)")
    t.add_argument("--ratios", help="requested ω2/ω1, comma-separated (default Brokowski's 0.4,0.5,0.8,1,1.25,2,2.5)")
    t.add_argument("--truth-effects", help="score each command on the virtual rig with these effects (eq 23)")
    t.add_argument("--truth-set", action="append", metavar="EFFECT.PARAM=VALUE", help="a parameter of the rig's effects")
    t.add_argument("--drop-bad", action="store_true", help="drop (and count) bad data rows instead of stopping")
    t.add_argument("--json", help="write the commands and scores to this JSON file")
    t.add_argument("--plots", help="folder for the Fig. 17-style plot")
    t.set_defaults(func=cmd_resteer)
    e = sub.add_parser("export", help="write the variant's assembly as STEP (+ SVG, PNG) for mechanical review")
    e.add_argument("variant", help="variant YAML file")
    e.add_argument("--out", default="cad_out", help="folder for <name>.step/.svg/.png (default: cad_out)")
    e.add_argument("--gamma", type=float, default=45.0, help="commanded γ [deg] the forks are turned for (default 45)")
    e.add_argument("--check", action="store_true", help="re-read the STEP file and check names, validity, contacts, "
                   "interference and bounding box (exit status 1 if a check fails)")
    e.set_defaults(func=cmd_export)
    return p


def check_outputs(args):
    """Refuse an output path that cannot be written before any computation (each write checks again):
    --json and rig's --out are files, --plots and the other commands' --out are folders."""
    if getattr(args, "json", None):
        check_target(args.json, kind="--json")
    if getattr(args, "plots", None):
        check_folder(args.plots, kind="--plots")
    if getattr(args, "out", None):
        if args.command == "rig":
            check_target(args.out, kind="--out")
        else:
            check_folder(args.out, kind="--out")


def main(argv=None):
    args = build_parser().parse_args(argv)
    try:
        check_outputs(args)
        return args.func(args)
    except InputError as e:
        print(f"cvtdesign: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as e:   # study.Interrupted says how much is kept
        print(f"cvtdesign: {str(e) or 'interrupted'}", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
