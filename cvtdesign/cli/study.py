"""`cvtdesign study`: a study's cases in batch on Dask, with a summary of the optima and Pareto fronts."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from cvtdesign.cli.export import export_steps
from cvtdesign.cli.printing import progress_bar
from cvtdesign.design import study
from cvtdesign.design.optimise import knee
from cvtdesign.io import plots


def run(args):

    console = Console(width=120)
    with progress_bar(console, "cases", lambda row: f"last: {row['case_id']} {row['status']}") as progress:
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
        export_steps(console, [f for f in chosen if isinstance(f, str) and f], Path(res["out_dir"]) / "step")
    return 0 if df["success"].any() else 1
