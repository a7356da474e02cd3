"""`cvtdesign study`: a study's cases in batch on Dask, with a summary of the optima and Pareto fronts."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from rich.console import Console

from cvtdesign.cli.export import export_steps
from cvtdesign.cli.optimise import SHOW
from cvtdesign.design.objectives import objective
from cvtdesign.cli.printing import kind_of, progress_bar, show
from cvtdesign.design import study
from cvtdesign.design.solve import knee
from cvtdesign.design.study_file import Study, load_study
from cvtdesign.io import plots
from cvtdesign.io.report import Note, Table
from cvtdesign.io.units import degrees, engineering
from cvtdesign.io.variant import load_spec


def run(args):
    console = Console(width=140)
    loaded = load_study(args.study)         # the one read of the study file; passed down from here
    with progress_bar(console, "cases", lambda row: f"last: {row['case_id']} {row['status']}") as progress:
        res = study.run_study(loaded, args.out, args.scheduler, args.workers, progress,
                              lambda text: console.print(text, style="yellow", markup=False, highlight=False,
                                                           soft_wrap=True))
    df = res["table"]
    if res["ran"]:
        console.print(f"{res['cases']} cases: {res['skipped']} already in {res['out_dir']}, {res['ran']} run in "
                      f"{res['seconds']:.1f} s (cluster start-up {res['startup_seconds']:.1f} s)")
    else:
        console.print(f"{res['cases']} cases: all already in {res['out_dir']}; nothing to run")
    t = Table("cases by status", ["status", "cases"])
    for status, n in df.groupby("status")["case_id"].nunique().items():
        t.add(status, str(n))
    failed = failure_note(df)
    if not df["success"].any():         # nothing to report: no optimum, front or knee from failed cases
        show(console, [t, failed])
        return 1
    spec, kinds = study_kinds(loaded)
    starts_ = df[(df["kind"] == "start") & df["success"]]
    best = best_optima(starts_)
    blocks = [t] + ([failed] if failed else [])
    if len(best):
        blocks.append(optima_table(best, starts_, spec.objective.kind, kinds))
    files = [f for f in df["variant_file"] if isinstance(f, str) and f]
    if files:
        blocks.append(Note(f"variant files in {Path(files[0]).parent}"))
    pareto = df[df["kind"] == "pareto"]
    chains = []
    for cid, grp in pareto.groupby("case_id", sort=False):
        pts = [dict(r) | {"index": r["point"]} for _, r in grp.sort_values("point").iterrows()]
        same = label_points(pts, kinds)              # the figure labels each point with its design
        k = knee(pts)
        blocks += pareto_blocks(cid, pts, k, kinds)
        if any(p["success"] for p in pts):          # a chain with no successful point has no front to draw
            chains.append((cid + (f" ({same} at every point)" if same else ""), pts, k))
    figure = Path(res["out_dir"]) / "pareto.png" if chains else None   # the files first, then the table
    if figure:
        plots.pareto_figure(chains, figure)
    if args.step:
        chosen = list(best["variant_file"]) + (list(pareto[pareto["success"]]["variant_file"]) if len(pareto) else [])
        export_steps(console, [f for f in chosen if isinstance(f, str) and f], Path(res["out_dir"]) / "step")
    show(console, blocks)
    if figure:
        console.print(f"Pareto plot: {figure}")
    return 0


def failure_note(df) -> Note | None:
    """How many of the store's cases failed (no successful row), grouped by why: the constraint no design within
    the bounds meets (design.infeasibility), else the status; or None."""
    ok = df.groupby("case_id", sort=False)["success"].any()
    failed = df[df["case_id"].isin(ok.index[~ok])].drop_duplicates("case_id")
    if not len(failed):
        return None
    reasons = failed["reason"].fillna("").astype(str) if "reason" in failed else failed["status"].astype(str)
    reasons = reasons.where(reasons != "", failed["status"].astype(str))
    key = reasons.str.replace(r" (only )?reaches .*", "", regex=True)     # the family and the part
    why = key.value_counts()
    n, total = int(why.sum()), len(ok)
    first = {k: r[len(k):].strip() for k, r in zip(key, reasons)}
    groups = "; ".join(f"{k} ×{v}" + (f" (e.g. {first[k]})" if first[k] else "") for k, v in why.items())
    if n == total:
        return Note(f"no case succeeded: all {total} cases failed: {groups}; no optimum, Pareto front or knee to "
                    "report", "bad")
    return Note(f"{n} of {total} cases failed: {groups}", "bad")


def study_kinds(loaded: Study) -> tuple:
    """(the study spec, {variable: kind}) for its design variables and swept parameters, as the base variant
    writes the parameter (or, for an expression or a plain number, as the study writes its bounds or values)."""
    spec = loaded.spec
    params = load_spec(loaded.base).parameters
    kinds = {n: kind_of(params.get(n), v.lower, v.upper) for n, v in spec.design.items()}
    kinds |= {n: kind_of(params.get(n), *values) for n, values in spec.batch.sweep.items()}
    return spec, kinds


def best_optima(starts_):
    """The best successful start per variant and sweep point (the store's rows)."""
    if not len(starts_):
        return starts_
    return starts_.sort_values("objective").groupby(["variant", "fixed"], sort=False).head(1)


def label_points(pts: list[dict], kinds: dict) -> str:
    """Give each point of a front its 'label', the design variables that vary along the front in their
    units ('preload = 121.9 N'); returns those that do not ('d = 48.8 mm', '' if none)."""
    names = [n for n in kinds if pts and f"design.{n}" in pts[0]]
    texts = {n: {design_text(p, {n: kinds[n]}) for p in pts if p["success"]} for n in names}
    same = {n: kinds[n] for n in names if len(texts[n]) == 1}
    for p in pts:
        p["label"] = design_text(p, {n: kinds[n] for n in names if n not in same})
    return design_text(next((p for p in pts if p["success"]), pts[0]), same) if same else ""


def design_text(row, kinds: dict) -> str:
    """A store row's design in its units: 'preload = 121.9 N, d = 48.8 mm'."""
    return ", ".join(f"{n} = {engineering(row.get(f'design.{n}'), k)}" for n, k in kinds.items() if f"design.{n}" in row)


def design_cells(row, kinds: dict) -> list[str]:
    """The design variables of a store row (its design.<name> columns) in their units."""
    return [engineering(row.get(f"design.{n}"), k) for n, k in kinds.items() if f"design.{n}" in row]


def file_name(path) -> str:
    """The name of a variant file of the store (its folder is named once, in a note), '—' for none."""
    return Path(path).name if isinstance(path, str) and path else "—"


def sweep_text(fixed: str, kinds: dict) -> str:
    """A case's sweep point (the store's JSON of SI values) in units: 'r_steer = 30 mm' ('—': none)."""
    point = json.loads(fixed) if isinstance(fixed, str) and fixed else {}
    return ", ".join(f"{n} = {engineering(v, kinds.get(n, 'dimensionless'))}" for n, v in point.items()) or "—"


def optima_table(best, starts_, kind: str, kinds: dict) -> Table:
    """Each variant and sweep point's best optimum: its design in units, worst |α| over the envelope (from the
    optimum's envelope check), the objective when it is another figure, power loss when it is the objective,
    and how many starts found it."""
    names = [n for n in kinds if f"design.{n}" in best.columns]
    goal = objective(kind)
    extra = [goal.title] if goal.case_column is None else []      # an objective with no column of its own
    b = Table("best optimum per variant and sweep point", ["variant", "sweep point", *names, "worst |α|", *extra,
                                                             "power loss", "found by", "variant file"])
    for _, r in best.iterrows():
        same = starts_[(starts_["variant"] == r["variant"]) & (starts_["fixed"] == r["fixed"]) &
                       (np.abs(starts_["objective"] - r["objective"]) <= 1e-6 * max(1, abs(r["objective"])))]
        b.add(r["variant"], sweep_text(r["fixed"], kinds), *design_cells(r, {n: kinds[n] for n in names}),
              degrees(r["worst_alpha_deg"]), *[SHOW[goal.unit](r["objective"]) for _ in extra],
              engineering(r["power_loss_W"], "power"), f"{len(same)} starts", file_name(r["variant_file"]))
    return b


def pareto_blocks(case_id: str, pts: list[dict], k: int, kinds: dict) -> list:
    """A Pareto front: every point with its worst α, power loss and design, and the knee named as a design."""
    names = [n for n in kinds if f"design.{n}" in pts[0]] if pts else []
    t = Table(f"Pareto front {case_id}", ["point", "worst α", "power loss", *names, "status", "variant file"])
    for p in pts:
        t.add(str(p["point"]), degrees(p["worst_alpha_deg"]), engineering(p["power_loss_W"], "power"),
              *design_cells(p, {n: kinds[n] for n in names}), p["status"], file_name(p["variant_file"]),
              style="good" if p["point"] == k and p["success"] else "")
    kp = next((p for p in pts if p["point"] == k and p["success"]), None)
    if kp is None:
        return [t, Note(f"Pareto {case_id}: no successful point, no knee", "bad")]
    design = design_text(kp, {n: kinds[n] for n in names})
    return [t, Note(f"Pareto {case_id}: knee: point {k} — {design}, worst α {degrees(kp['worst_alpha_deg'])}, "
                    f"loss {engineering(kp['power_loss_W'], 'power')}", "good")]
