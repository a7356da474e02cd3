"""`cvtdesign diagnose`: where the model and the data disagree, which effect causes it, how far it shrinks."""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from rich.console import Console

from cvtdesign.cli.arguments import effects_arg
from cvtdesign.cli.printing import degrees, engineering, json_text, number, progress_bar, report_text, show
from cvtdesign.core.effects import EFFECTS
from cvtdesign.core.model import STATUS
from cvtdesign.diagnosis import diagnose
from cvtdesign.diagnosis.diagnose import Report, model_efficiency, point_grid, residuals
from cvtdesign.diagnosis import measured
from cvtdesign.io import plots
from cvtdesign.io.output import make_folder, write_files
from cvtdesign.io.report import Note, Table, png_figure
from cvtdesign.errors import InputError
from cvtdesign.io.variant import load_variant


def run(args):
    layout = load_variant(args.variant)
    base = effects_arg(args.base, layout.effects, "--base")
    candidates = effects_arg(args.candidates, [], "--candidates")
    if set(candidates) & set(base):
        raise InputError(f"--candidates: {', '.join(e for e in candidates if e in base)} is already in the base model "
                         f"({', '.join(base)}); expected effects to add to it")
    data = measured.load_measured(args.data, layout, args.drop_bad)
    console = Console(width=140)
    with progress_bar(console, "diagnosis", str, transient=True) as progress:
        rep = diagnose.diagnose(layout, data, base, candidates or None, progress)
    blocks = report_blocks(rep)
    show(console, blocks)
    figures = []
    if args.plots:
        figures = plot_report(rep, make_folder(args.plots, kind="--plots"))
        for f in figures:
            console.print(f"plot: {f}")
    files, kinds = {}, {}
    if args.json:
        files[Path(args.json)], kinds[Path(args.json)] = json_text(rep.to_json()), "--json"
    if args.report:
        files[Path(args.report)], kinds[Path(args.report)] = report_text(args, "cvtdesign diagnose", blocks +
                                                                         report_figures(rep, figures)), "--report"
    write_files(files, kind=kinds)
    if args.json:
        console.print(f"report written to {args.json}")
    if args.report:
        console.print(f"HTML report: {args.report}")
    return 0


def report_figures(rep: Report, written: list) -> list:
    """The residual map and the fit plot as report Figures: those written to --plots, else drawn into a
    temporary folder that is removed once they are read."""
    captions = ("α residual (measured − model) over γ × τ⊥, base and diagnosed model; the gap's regions outlined",
                "slip angle and efficiency against γ at a few loads: data, base model (dotted), diagnosed model")
    if written:
        return [png_figure(f, c) for f, c in zip(written, captions)]
    with tempfile.TemporaryDirectory(prefix="cvtdesign-report-") as tmp:
        return [png_figure(f, c) for f, c in zip(plot_report(rep, Path(tmp)), captions)]


def param_kind(name: str) -> str:
    """The kind (units.KINDS) of an effect parameter 'effect.param' (core.effects EFFECTS[...].params)."""
    effect, param = name.split(".", 1)
    return EFFECTS[effect].params[param].kind


def report_blocks(rep: Report) -> list:
    """What diagnose prints and reports: data and noise, the base fit, where the gap is, the ranking, the
    verdict and how far the gap shrinks."""
    n = rep.noise
    dropped = sum(rep.dropped_rows.values())
    blocks = [Note(f"{rep.rows} rows, {rep.operating_points} operating points"
                   + (f", {dropped} bad rows dropped ({rep.dropped_rows})" if dropped else "")
                   + f"; noise ({n['source']}): α {degrees(n['alpha']['rms'])}, "
                     f"τ∥ {engineering(n['tau_par']['rms'], 'torque')}"
                   + (f", axis {degrees(n['axis']['rms'])}" if "axis" in n else ""))]
    t = Table(f"base model fit: {' + '.join(rep.base) or 'ideal CVT'}", ["parameter", "value", "±1σ", "identifiable"])
    for name, p in rep.base_fit.items():
        t.add(name, engineering(p["value"], param_kind(name)), engineering(p["std"], param_kind(name), 2),
              "yes" if p["identifiable"] else "no", style="" if p["identifiable"] else "bad")
    blocks += [t] if rep.base_fit else []
    return blocks + gap_blocks(rep) + [ranking_table(rep)] + verdict_blocks(rep) + [Note(f"({rep.seconds:.1f} s)")]


def gap_blocks(rep: Report) -> list:
    """The gap between the base model and the data: its size, its regions, and by motor speed."""
    g = rep.gap
    blocks = [Note(f"gap: RMS α residual {degrees(g['rms_alpha_deg'])} (held out {degrees(g['heldout_rms_alpha_deg'])}), "
                   f"efficiency {number(g['rms_efficiency'])}; spatial structure z = {g['structure_z']:.1f} "
                   f"({'structured' if g['structured'] else 'like noise'})")]
    failed = rep.base_failed
    if failed["points"]:
        kinds = [f"{k.replace('_', ' ')} {failed[k]}" + (f" ({', '.join(failed[k + '_at'])})" if failed.get(k + "_at") else "")
                 for k in STATUS[1:] if failed[k]]
        where = ", ".join(f"({degrees(p['gamma_cmd_deg'], 3)}, {p['tau_perp_Nm']:+.2f} N·m)" for p in failed["at"][:4])
        blocks.append(Note(f"the base model has no physical solution at {failed['points']} of "
                           f"{rep.operating_points} operating points ({'; '.join(kinds)}), e.g. (γ, τ⊥) = {where}"
                           f"{', …' if failed['points'] > 4 else ''}: left out of the gap, its regions and the map",
                           style="bad"))
    if g["regions"]:
        rt = Table("where the α gap stands out (> 3σ per operating point)",
                   ["region", "γ", "τ⊥", "points", "mean residual"])
        for k, r in enumerate(g["regions"][:6]):
            rt.add(f"R{k + 1}", f"{degrees(r['gamma_deg'][0], 3)} .. {degrees(r['gamma_deg'][1], 3)}",
                   f"{r['load_Nm'][0]:+.2f} .. {r['load_Nm'][1]:+.2f} N·m", str(r["points"]),
                   degrees(r["mean_residual_deg"], 3))
        blocks.append(rt)
    if rep.by_speed:
        blocks.append(Note("by motor speed: " + "; ".join(
            f"ω1 = {engineering(b['omega_1'], 'speed', 3)}: RMS α residual {degrees(b['rms_residual_deg'][0])} → "
            f"{degrees(b['rms_residual_deg'][1])}" for b in rep.by_speed)))
    return blocks


def ranking_table(rep: Report) -> Table:
    """The candidates, each added alone to the base: held-out RMS α and efficiency before → after, the
    shrink, the tests, and the fitted parameters in their units."""
    k = Table("candidates, added one at a time to the base (held-out, cross-validated by operating point)",
              ["effect", "RMS α before → after", "shrink", "RMS η before → after", "p", "ΔBIC", "fails at",
               "fitted", "accepted"])
    for r in rep.ranking:
        new = {n: p for n, p in r["params"].items() if n.split(".")[0] == r["effect"]}
        fitted = ", ".join(f"{n.split('.')[1]} = {engineering(p['value'], param_kind(n), 3)}"
                           + ("" if p["identifiable"] else " (n.i.)") for n, p in new.items())
        k.add(r["effect"], f"{degrees(r['heldout_rms_before'])} → {degrees(r['heldout_rms_after'])}",
              f"{r['shrink']:.2f}", f"{number(r['heldout_rms_efficiency_before'])} → "
              f"{number(r['heldout_rms_efficiency_after'])}", f"{r['p_value']:.1e}", f"{r['bic_change']:+.1f}",
              f"{r['failed_fraction']:.0%}", fitted, "yes" if r["accepted"] else "", style="good" if r["accepted"] else "")
    return k


def verdict_blocks(rep: Report) -> list:
    """The confounded pairs, the verdict, a partial explanation, the form of what remains, and how far."""
    blocks = [Note(f"confounded: {c['effects'][0]} and {c['effects'][1]} change the predictions alike (cosine "
                   f"{c['cosine']:.2f}); to separate them: {c['separate_by']}", "warn") for c in rep.confounded]
    blocks.append(Note(f"verdict: {rep.verdict}" + (f" (accepted: {', '.join(rep.accepted)})"
                                                        if len(rep.accepted) > 1 else ""), "bold"))
    blocks += [Note(f"{p['effect']} explains {max(p['shrink'], 0):.0%} of the gap; a structured gap remains", "warn")
               for p in rep.partial]
    form, h = rep.form, rep.how_far
    if form["lies_along"] and rep.verdict == "unexplained":
        blocks.append(Note(f"the remaining gap lies along {form['lies_along']} (p = {form['p'][form['lies_along']]:.1e}; "
                           "next: " + ", ".join(f"{k} {v:.1e}" for k, v in
                                                sorted(form["p"].items(), key=lambda x: x[1])[1:4]) + ")"))
    if rep.accepted:
        reg = (f"; in the gap's regions {degrees(h['region_rms_alpha_deg'][0])} → {degrees(h['region_rms_alpha_deg'][1])} "
               f"(shrink {h['shrink_region']:.2f})" if h["region_rms_alpha_deg"] else "")
        blocks.append(Note(f"how far: held-out RMS α {degrees(h['heldout_rms_alpha_deg'][0])} → "
                           f"{degrees(h['heldout_rms_alpha_deg'][1])} (gap shrinks by {h['shrink_alpha']:.0%}), "
                           f"efficiency {number(h['heldout_rms_efficiency'][0])} → "
                           f"{number(h['heldout_rms_efficiency'][1])} (shrink {h['shrink_efficiency']:.0%}){reg}"))
    return blocks


def plot_report(rep: Report, out_dir) -> list:
    """Residual maps (base and diagnosed model) and the fit curves; returns the files written."""

    out_dir = Path(out_dir)
    data, base, final = rep.evidence.data, rep.evidence.base, rep.evidence.final
    rb, rf = residuals(data, base.fit.pred), residuals(data, final.fit.pred)     # blank where a model fails
    maps = [(f"α residual, base ({' + '.join(base.effects) or 'ideal'})",
             point_grid(data, np.where(base.fit.ok, rb["alpha"], np.nan)))]
    if final is not base:
        maps.append((f"α residual, with {' + '.join(rep.accepted)}",
                     point_grid(data, np.where(final.fit.ok, rf["alpha"], np.nan))))
    f1 = out_dir / "residual_map.png"
    plots.residual_map_figure(data.gamma_levels, data.load_levels, maps, rep.gap["regions"][:6], f1)
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
