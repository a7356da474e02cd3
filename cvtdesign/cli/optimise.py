"""`cvtdesign optimise`: one study's optimum by multistart IPOPT, its constraints and its variant file."""
from __future__ import annotations

from pathlib import Path

from rich.console import Console
from rich.table import Table

from cvtdesign.cli.export import export_steps
from cvtdesign.cli.printing import json_text, progress_bar
from cvtdesign.design import optimise
from cvtdesign.errors import InputError
from cvtdesign.io.output import make_folder, write_files


def run(args):

    if args.starts is not None and args.starts < 1:
        raise InputError(f"--starts: expected a positive number of multistart points, got {args.starts}")
    console = Console(width=110)
    with progress_bar(console, "multistart", lambda sol: f"last: {sol.status}, f = {sol.objective:.5g}",
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
            export_steps(console, [res["variant_file"]], Path(res["variant_file"]).parent / "step")
    else:
        chk = res.get("envelope_check")
        why = f"; worst point {chk['worst']}" if chk and chk.get("worst") else ""
        console.print(f"[red]no successful solve: {res['status']}{why}; no variant file written[/red]")
    return 0 if res["success"] else 1
