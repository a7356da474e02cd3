"""`cvtdesign tolerance`: how sensitive a variant is to manufacturing. Monte Carlo over the toleranced
dimensions of a tolerances file and the variant's physical inputs (unless --dimensions-only) on Dask,
resumable, against the first-order prediction from the model's exact derivatives, with the tolerances and
inputs ranked together by their effect (design.tolerance, docs/tolerances.md)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.console import Console

from cvtdesign.cli.compare import COLUMNS
from cvtdesign.cli.printing import progress_bar, show
from cvtdesign.io.strict_json import json_text
from cvtdesign.design.tolerance import FIGURES, LINEAR_DRAWS
from cvtdesign.io.output import make_folder, write_file
from cvtdesign.io.report import Note, Table
from cvtdesign.uses.tolerance import RANKED, source_name, source_text, tolerance_run

LABELS = {key: label.rstrip(" ¹²³") for key, label, _ in COLUMNS}     # compare's footnotes are compare's
FORMATS = {key: fmt for key, _, fmt in COLUMNS}


def run(args):
    console = Console(width=150)
    with progress_bar(console, "samples", lambda row: f"last: sample {row['sample']} {row['status']}") as progress:
        result = tolerance_run(args.variant, args.tolerances, args.samples, args.dimensions_only, args.store,
                               (args.scheduler, args.workers), progress,
                               lambda text: console.print(text, style="yellow", markup=False, soft_wrap=True))
    out, content = result.content(), result.content_
    written = [f"store: {out['store']} ({result.drawn_before} samples were there, the rest drawn now)"]
    if args.json:
        write_file(args.json, json_text(out), kind="--json")
        written.append(f"figures written to {args.json}")
    if args.plots:
        written.append(f"plot: {result.plot(make_folder(args.plots, kind='--plots'))}")
    show(console, [figure_table(out, content), effect_table(out, content), *notes(out, result.failed, content)])
    for line in written:
        console.print(line, markup=False)
    return 0 if out["samples_held"] else 1


def figure_table(out: dict, content) -> Table:
    """Each figure: nominal, the samples' mean, σ and 5–95 % range, and the first-order mean and σ."""
    also = f" and {len(content.inputs)} physical inputs" if content.inputs else " (dimensions only)"
    t = Table(f"{out['variant']}: compare's figures over {out['samples_held']} samples of {Path(content.path).name}"
              f"{also} (law {out['contact_law']})", ["figure", "nominal", "mean", "σ", "5 % … 95 %", "first order: mean",
                                              "first order: σ"])
    for key in FIGURES:
        f, fmt = out["figures"][key], FORMATS[key]
        t.add(LABELS[key], _cell(f["nominal"], fmt), _cell(f["mean"], fmt), _cell(f["std"], "{:.3g}"),
              f"{_cell(f['p05'], fmt)} … {_cell(f['p95'], fmt)}", _cell(f["first_order_mean"], fmt),
              _cell(f["first_order_std"], "{:.3g}"))
    return t


def _cell(value, fmt: str) -> str:
    return "—" if value is None else fmt.format(value)


def effect_table(out: dict, content) -> Table:
    """The dimensions and physical inputs that matter most for max |α|: each alone, first order; and the check
    of its sensitivity against the samples: the least-squares slope × σ of the samples less that of the first
    order at the same deviations (0 where the exact derivative is the samples' own; the draws' noise is in
    both)."""
    key = FIGURES[0]
    ranked = out["effects"][key]
    what = "tolerance or input" if content.inputs else "tolerance"
    t = Table(f"which {what} matters most for {LABELS[key]}: each alone, first order "
              f"({min(RANKED, len(ranked))} of {len(ranked)}; all in --json)",
              ["dimension" + (" or input" if content.inputs else ""), "tolerance" + (" or σ" if content.inputs else ""),
               "effect [°]", "check: sampled − first-order slope × σ [°]"])
    for e in ranked[:RANKED]:
        check = None if e["slope_sampled"] is None else e["slope_sampled"] - e["slope_first_order"]
        t.add(source_name(e), source_text(e, content), _cell(e["effect"], "{:.3g}"), _cell(check, "{:+.2g}"))
    return t


def inputs_note(out: dict, content) -> Note:
    """Which physical inputs were sampled beside the dimensions (or that none were), and which were left out."""
    if not content.inputs:
        return Note("dimensions only (--dimensions-only): the physical inputs (calibration, preload, moduli, "
                    "friction, the law's own error) are held at their values")
    sampled = ", ".join(f"{s.label} {source_text({'input': s.label}, content)}" for s in content.inputs)
    text = f"physical inputs sampled with the dimensions (as compare's intervals take them): {sampled}"
    if out["inputs_left_out"]:
        text += "; left out: " + "; ".join(f"{k} ({v})" for k, v in out["inputs_left_out"].items())
    return Note(text + "; --dimensions-only leaves them out")


def notes(out: dict, failed: list, content) -> list[Note]:
    """The check of the first order against the samples, what was left out, and how the first order is taken."""
    key = FIGURES[0]
    f, at = out["figures"][key], out["first_order_at_samples"][key]
    lines = []
    if f["std"] is not None and at["std"] is not None:
        lines.append(Note(f"first order at the samples' own deviations, {LABELS[key]}: mean shift "
                          f"{at['mean'] - f['nominal']:+.3g}° (sampled {f['mean'] - f['nominal']:+.3g}°), σ "
                          f"{at['std']:.3g}° ({f['std']:.3g}°), each sample within {at['rms_difference']:.2g}° RMS"))
    lines.append(slope_note(out))
    lines.append(inputs_note(out, content))
    if out["samples_left_out"]:
        why = ", ".join(f"{k} in {v}" for k, v in out["samples_left_out"].items())
        lines.append(Note(f"{out['samples'] - out['samples_held']} of {out['samples']} samples left out, with no figures: "
                          f"points that are ok at the drawing were not there ({why})", "bad"))
    if failed:
        lines.append(Note(f"{len(failed)} chunks of samples failed to run ({failed[0]}); their samples are missing: "
                          "run again to retry them", "bad"))
    lines.append(Note(f"first order: every output at every point linear in the deviations (the model's exact "
                      f"derivatives), each figure taken over that linearised envelope ({LINEAR_DRAWS} draws); no "
                      "second-order term; a figure whose extreme several points share shifts its mean even so "
                      "(docs/tolerances.md)"))
    return lines


def slope_note(out: dict) -> Note:
    """How far the sensitivities of max |α| to each deviation, fitted to the samples, are from the first
    order's at the same deviations (or why they are not checked yet)."""
    key = FIGURES[0]
    pairs = [(e["slope_sampled"], e["slope_first_order"]) for e in out["effects"][key] if e["slope_sampled"] is not None]
    if not pairs:
        return Note(f"the sensitivities are checked against the samples (least-squares slopes) from "
                    f"{len(out['dimensions']) + 2} samples that hold on: run again with more")
    s, f = np.array(pairs, float).T
    worst = float(np.max(np.abs(s - f)))
    largest = max(e["effect"] or 0.0 for e in out["effects"][key])
    return Note(f"sensitivities of {LABELS[key]} checked against the {out['samples_held']} samples: the least-squares "
                f"slopes × σ of the samples and of the first order at the same deviations differ by at most "
                f"{worst:.2g}° ({100 * worst / max(largest, 1e-300):.2g} % of the largest effect)")
