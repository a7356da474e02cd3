"""`cvtdesign diagnose`: where the model and the data disagree, which effect causes it, how far it shrinks."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from cvtdesign.cli.arguments import effects_arg
from cvtdesign.cli.printing import json_text, progress_bar
from cvtdesign.diagnosis import diagnose
from cvtdesign.diagnosis.diagnose import model_efficiency, point_grid, residuals
from cvtdesign.diagnosis import measured
from cvtdesign.io import plots
from cvtdesign.io.output import make_folder, write_file
from cvtdesign.io.variant import load_variant


def run(args):

    layout = load_variant(args.variant)
    base = effects_arg(args.base, layout.effects, "--base")
    candidates = effects_arg(args.candidates, [], "--candidates")
    data = measured.load_measured(args.data, layout, args.drop_bad)
    console = Console(width=120)
    with progress_bar(console, "diagnosis", str, transient=True) as progress:
        rep = diagnose.diagnose(layout, data, base, candidates or None, progress)
    print_report(rep, console)
    if args.plots:
        for f in plot_report(rep, make_folder(args.plots, kind="--plots")):
            console.print(f"plot: {f}")
    if args.json:
        write_file(args.json, json_text(diagnose.public(rep)), kind="--json")
        console.print(f"report written to {args.json}")
    return 0


def print_report(rep: dict, console):
    """A short human report: data and noise, the base fit, where the gap is, the ranking, the verdict."""
    n = rep["noise"]
    dropped = sum(rep["dropped_rows"].values())
    console.print(f"{rep['rows']} rows, {rep['operating_points']} operating points"
                  + (f", {dropped} bad rows dropped ({rep['dropped_rows']})" if dropped else "")
                  + f"; noise ({n['source']}): α {n['alpha']['rms']:.3f}°, τ∥ {n['tau_par']['rms']:.4f} N·m"
                  + (f", axis {n['axis']['rms']:.3f}°" if "axis" in n else ""))
    t = Table(title=f"base model fit: {' + '.join(rep['base']) or 'ideal CVT'}")
    for c in ("parameter", "value", "±1σ", "identifiable"):
        t.add_column(c)
    for name, p in rep["base_fit"].items():
        t.add_row(name, f"{p['value']:.5g}", f"{p['std']:.2g}", "yes" if p["identifiable"] else "[red]no[/red]")
    if rep["base_fit"]:
        console.print(t)
    g = rep["gap"]
    console.print(f"gap: RMS α residual {g['rms_alpha_deg']:.3f}° (held out {g['heldout_rms_alpha_deg']:.3f}°), "
                  f"efficiency {g['rms_efficiency']:.4f}; spatial structure z = {g['structure_z']:.1f} "
                  f"({'structured' if g['structured'] else 'like noise'})")
    if g["regions"]:
        rt = Table(title="where the α gap stands out (> 3σ per operating point)")
        for c in ("region", "γ \\[deg]", "τ⊥ \\[N·m]", "points", "mean residual \\[deg]"):
            rt.add_column(c, justify="right")
        for k, r in enumerate(g["regions"][:6]):
            rt.add_row(f"R{k + 1}", f"{r['gamma_deg'][0]:.0f} .. {r['gamma_deg'][1]:.0f}",
                       f"{r['load_Nm'][0]:+.2f} .. {r['load_Nm'][1]:+.2f}", str(r["points"]),
                       f"{r['mean_residual_deg']:+.3f}")
        console.print(rt)
    if rep["by_speed"]:
        console.print("by motor speed: " + "; ".join(
            f"ω1 = {b['omega_1']:.3g} rad/s: RMS α residual {b['rms_residual_deg'][0]:.3f}° → {b['rms_residual_deg'][1]:.3f}°"
            for b in rep["by_speed"]))
    k = Table(title="candidates, added one at a time to the base (held-out, cross-validated by operating point)")
    for c in ("effect", "RMS α \\[deg] before → after", "shrink", "RMS η before → after", "p", "ΔBIC", "fails at",
              "fitted", "accepted"):
        k.add_column(c)
    for r in rep["ranking"]:
        new = {n: p for n, p in r["params"].items() if n.split(".")[0] == r["effect"]}
        fitted = ", ".join(f"{n.split('.')[1]} = {p['value']:.3g}" + ("" if p["identifiable"] else " (n.i.)")
                           for n, p in new.items())
        k.add_row(r["effect"], f"{r['heldout_rms_before']:.3f} → {r['heldout_rms_after']:.3f}", f"{r['shrink']:.2f}",
                  f"{r['heldout_rms_efficiency_before']:.4f} → {r['heldout_rms_efficiency_after']:.4f}",
                  f"{r['p_value']:.1e}", f"{r['bic_change']:+.1f}", f"{r['failed_fraction']:.0%}", fitted,
                  "[green]yes[/green]" if r["accepted"] else "")
    console.print(k)
    for c in rep["confounded"]:
        console.print(f"[yellow]confounded: {c['effects'][0]} and {c['effects'][1]} change the predictions alike "
                      f"(cosine {c['cosine']:.2f}); to separate them: {c['separate_by']}[/yellow]")
    h = rep["how_far"]
    console.print(f"[bold]verdict: {rep['verdict']}[/bold]" + (f" (accepted: {', '.join(rep['accepted'])})"
                                                                if len(rep["accepted"]) > 1 else ""))
    for p in rep["partial"]:
        console.print(f"[yellow]{p['effect']} explains {max(p['shrink'], 0):.0%} of the gap; a structured gap "
                      "remains[/yellow]")
    form = rep["form"]
    if form["lies_along"] and rep["verdict"] == "unexplained":
        console.print(f"the remaining gap lies along {form['lies_along']} (p = {form['p'][form['lies_along']]:.1e}; next: "
                      + ", ".join(f"{k} {v:.1e}" for k, v in sorted(form["p"].items(), key=lambda x: x[1])[1:4])
                      + ")")
    if rep["accepted"]:
        reg = (f"; in the gap's regions {h['region_rms_alpha_deg'][0]:.3f}° → {h['region_rms_alpha_deg'][1]:.3f}° "
               f"(shrink {h['shrink_region']:.2f})" if h["region_rms_alpha_deg"] else "")
        console.print(f"how far: held-out RMS α {h['heldout_rms_alpha_deg'][0]:.3f}° → {h['heldout_rms_alpha_deg'][1]:.3f}° "
                      f"(gap shrinks by {h['shrink_alpha']:.0%}), efficiency {h['heldout_rms_efficiency'][0]:.4f} → "
                      f"{h['heldout_rms_efficiency'][1]:.4f} (shrink {h['shrink_efficiency']:.0%}){reg}")

    console.print(f"({rep['seconds']:.1f} s)")


def plot_report(rep: dict, out_dir) -> list:
    """Residual maps (base and diagnosed model) and the fit curves; returns the files written."""

    out_dir = Path(out_dir)
    data, base, final = rep["_data"], rep["_base"], rep["_final"]
    rb, rf = residuals(data, base.fit.pred), residuals(data, final.fit.pred)
    maps = [(f"α residual, base ({' + '.join(base.effects) or 'ideal'})", point_grid(data, rb["alpha"]))]
    if final is not base:
        maps.append((f"α residual, with {' + '.join(rep['accepted'])}", point_grid(data, rf["alpha"])))
    f1 = out_dir / "residual_map.png"
    plots.residual_map_figure(data.gamma_levels, data.load_levels, maps, rep["gap"]["regions"][:6], f1)
    r = data.rows
    eb, ef = model_efficiency(data, base.pred), model_efficiency(data, final.pred)
    picks = sorted({int(np.argmin(np.abs(data.load_levels - x))) for x in
                    (data.load_levels.min(), 0.5 * data.load_levels.min(), 0.5 * data.load_levels.max(),
                     data.load_levels.max())})
    panels = [("slip angle α", "α [deg]", []), ("efficiency", "efficiency [-]", [])]
    for j in picks:
        idx = np.flatnonzero(r["load_bin"].to_numpy() == j)
        idx = idx[np.argsort(r["gamma_cmd_deg"].to_numpy()[idx])]
        g = r["gamma_cmd_deg"].to_numpy()[idx]
        lv = float(data.load_levels[j])
        panels[0][2].append((lv, g, r["alpha_deg"].to_numpy()[idx], base.pred["alpha"][idx], final.pred["alpha"][idx]))
        panels[1][2].append((lv, g, r["efficiency"].to_numpy()[idx], eb[idx], ef[idx]))
    f2 = out_dir / "fit.png"
    plots.diagnosis_fit_figure({"panels": panels}, f2)
    return [f1, f2]
