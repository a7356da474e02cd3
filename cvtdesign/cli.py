"""The `cvtdesign` command."""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

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


def write_atomic(path: Path, text: str):
    """Write text to `path` via a temporary file and a rename, so no half-written file is ever left."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


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
        table.add_row(label, *[fmt.format(r[key]) for r in rows])
    console = Console(width=max(100, 30 + 22 * len(rows)))
    console.print(table)
    for r in rows:
        if r["not_converged"]:
            console.print(f"[red]{r['name']}: {r['not_converged']} of {r['points']} operating points did not "
                          "converge (left out of the figures)[/red]")

    figure = Path(args.out) / "compare.png"
    painter.draw("compare_figure", [(L.name, res) for L, res in results], figure)
    if args.json:
        write_atomic(Path(args.json), json.dumps({"variants": rows}, indent=2) + "\n")
        console.print(f"figures written to {args.json}")
    error = painter.wait()
    if error:
        print(f"cvtdesign: error: plotting failed: {error}", file=sys.stderr)
        return 1
    console.print(f"plots: {figure}")
    return 0


def _progress_bar(console, label: str, transient: bool = False):
    """A rich progress bar: label, bar, done/total, elapsed time and a description of the last item."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                    TextColumn("{task.description}"), console=console, transient=transient)


def cmd_optimise(args):
    from rich.console import Console
    from rich.table import Table

    from . import optimise

    console = Console(width=110)
    with _progress_bar(console, "multistart", transient=True) as bar:
        task = bar.add_task("", total=None)

        def progress(done, total, sol):
            bar.update(task, total=total, completed=done, description=f"last: {sol.status}, f = {sol.objective:.5g}")

        res = optimise.run(args.study, args.out, args.starts, progress)
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
    else:
        console.print(f"[red]no successful solve: IPOPT status {res['status']}[/red]")
    if args.json:
        keys = ("status", "objective", "design", "active_constraints", "variant_file")
        write_atomic(Path(args.json), json.dumps({k: res[k] for k in keys} | {"details": res}, indent=2) + "\n")
    return 0 if res["success"] else 1


def cmd_study(args):
    import numpy as np
    from rich.console import Console
    from rich.table import Table

    from . import study

    console = Console(width=120)
    with _progress_bar(console, "cases") as bar:
        task = bar.add_task("", total=None)

        def progress(done, total, row):
            desc = "" if row is None else f"last: {row['case_id']} {row['status']}"
            bar.update(task, total=total, completed=done, description=desc)

        res = study.run_study(args.study, args.out, args.scheduler, args.workers, progress)
    df = res["table"]
    console.print(f"{res['cases']} cases: {res['skipped']} already in {res['out_dir']}, {res['ran']} run in "
                  f"{res['seconds']:.1f} s (cluster start-up {res['startup_seconds']:.1f} s)")
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
    return 0 if df["success"].any() else 1


def build_parser():
    p = argparse.ArgumentParser(prog="cvtdesign", description="Design, optimise and compare spherical CVTs.")
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
    o.set_defaults(func=cmd_optimise)
    b = sub.add_parser("study", help="run a study's cases (sweeps, multistarts, Pareto fronts) in batch on Dask")
    b.add_argument("study", help="study YAML file (studies/*.yaml)")
    b.add_argument("--out", help="results store (default: results/<study name>)")
    b.add_argument("--scheduler", help="address of an existing Dask scheduler (default: a local cluster)")
    b.add_argument("--workers", type=int, help="local cluster size (default: one single-threaded worker per core)")
    b.set_defaults(func=cmd_study)
    return p


def main(argv=None):
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except InputError as e:
        print(f"cvtdesign: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("cvtdesign: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
