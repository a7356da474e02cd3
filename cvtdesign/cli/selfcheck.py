"""`cvtdesign selfcheck`: the diagnosis proven on data with withheld effects, against its targets."""
from __future__ import annotations

from rich.console import Console
from rich.table import Table

from cvtdesign.cli.printing import progress_bar
from cvtdesign.io.strict_json import json_text
from cvtdesign.verification import selfcheck
from cvtdesign.verification.selfcheck import meets_targets
from cvtdesign.errors import InputError
from cvtdesign.io.output import write_file
from cvtdesign.io.schema import MAX_COUNT


def run(args):
    if not 1 <= args.seeds <= MAX_COUNT:
        raise InputError(f"--seeds: expected a positive integer up to {MAX_COUNT} (null datasets per noise level "
                         f"/ 2), got {args.seeds}")
    only = [x.strip() for x in args.only.split(",")] if args.only else None
    matrices = [m.strip() for m in args.matrices.split(",")] if args.matrices else selfcheck.MATRICES
    bad = [m for m in matrices if m not in selfcheck.MATRICES]
    if bad:
        raise InputError(f"--matrices: unknown matrix '{bad[0]}' (expected {', '.join(selfcheck.MATRICES)})")
    console = Console(width=120)
    with progress_bar(console, "datasets", lambda row: f"last: {row['id']} → {row['verdict']}") as progress:
        results = selfcheck.run(args.variant, args.quick, args.seeds, args.scheduler, args.workers, progress, only,
                                matrices)
    summ = selfcheck.summary(results)
    if args.json:
        write_file(args.json, json_text({"summary": summ, "datasets": results}), kind="--json")
    print_summary(summ, results, console)
    return 0 if selfcheck.meets_targets(summ) else 1


def print_summary(s: dict, results: list[dict], console):
    for m in (k for k in s if k != "targets"):
        rows = [r for r in results if r["matrix"] == m]
        d = s[m]
        t = Table(title=f"{m} matrix: per withheld effect (top-1 = the verdict names it)")
        for c in ("withheld effect", "datasets", "signal/noise", "top-1", "mean shrink (found)", "verdicts when missed"):
            t.add_column(c, justify="right" if c != "withheld effect" else "left")
        for e, x in d["per_effect"].items():
            missed = [r["verdict"] for r in rows if r["kind"] == "single" and r["withheld"] == e and not r["correct"]]
            t.add_row(e, str(x["cases"]), "{:.1f}..{:.1f}".format(*x["signal_to_noise"]), f"{x['top1']:.0%}",
                      "-" if x["mean_shrink"] is None else f"{x['mean_shrink']:.2f}", ", ".join(missed) or "-")
        console.print(t)
        p = Table(title=f"{m} matrix: nulls, weak effects, pairs and effects outside the vocabulary (right verdict: "
                        "none / none or the effect / both named / unexplained)")
        for c in ("dataset", "signal/noise", "χ", "verdict", "accepted", "lies along", "correct"):
            p.add_column(c)
        for r in rows:
            if r["kind"] != "single":
                part = "; ".join(f"{x['effect']} {x['share']:.0%}" for x in r["shares"]) if r["verdict"] == "unexplained" else ""
                p.add_row(r["id"], f"{r['signal_to_noise']:.2f}", f"{r['signal_chi']:.1f}", r["verdict"],
                          r["accepted"] + (f" (partial: {part})" if part else ""), r["lies_along"] or "-",
                          "yes" if r["correct"] else "[red]no[/red]")
        console.print(p)
        console.print(f"{m}: " + _targets_line(d, s["targets"]))
    console.print("[green]targets met[/green]" if meets_targets(s) else "[red]targets missed[/red]")


def _targets_line(d: dict, t: dict) -> str:
    def pct(v):
        return "-" if v is None else f"{v:.1%}"
    return (f"top-1 on single effects {pct(d['top1_single'])} (target ≥ {t['top1_single']:.0%}); false positives on "
            f"null sets {pct(d['false_positive_null'])} (≤ {t['false_positive_null']:.0%}); names given to sets "
            f"outside the vocabulary {'-' if d['named_out_of_vocabulary'] is None else d['named_out_of_vocabulary']} "
            f"(target 0; unexplained {pct(d['unexplained_out_of_vocabulary'])}); weak effects never given a wrong "
            f"name {pct(d['weak_right'])}; pairs {pct(d['pair_accuracy'])}; mean shrink where found "
            + ("-" if d["mean_shrink_found"] is None else f"{d['mean_shrink_found']:.2f}") + f" (> {t['mean_shrink_found']})")
