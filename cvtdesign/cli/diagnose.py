"""`cvtdesign diagnose`: where the model and the data disagree, which effect causes it, how far it shrinks."""
from __future__ import annotations

import tempfile
from datetime import date
from pathlib import Path

from rich.console import Console

from cvtdesign.uses.diagnosis import check_candidates, plot_report
from cvtdesign.cli.arguments import effects_arg
from cvtdesign.cli.diagnosis_text import report_blocks
from cvtdesign.cli.printing import progress_bar, report_text, show
from cvtdesign.io.strict_json import json_text
from cvtdesign.core.effects import CALIBRATION
from cvtdesign.diagnosis import diagnose
from cvtdesign.diagnosis import measured
from cvtdesign.diagnosis.diagnose import Report
from cvtdesign.errors import InputError
from cvtdesign.io import materials
from cvtdesign.io.output import make_folder, write_files
from cvtdesign.io.report import png_figure
from cvtdesign.io.variant import load_spec, load_variant

CAPTIONS = ("α residual (measured − model) at each operating point over γ × τ⊥, base and diagnosed model; the "
            "gap's regions boxed; × where the model has no physical solution",
            "slip angle and efficiency against γ at a few loads: data, base model (dotted), diagnosed model")


def run(args):
    layout = load_variant(args.variant)
    base = effects_arg(args.base, layout.effects, "--base")
    candidates = effects_arg(args.candidates, [], "--candidates")
    if args.save_calibration and not set(CALIBRATION.values()) & set(base):
        raise InputError(f"--save-calibration: the base model ({', '.join(base) or 'no effects'}) fits no creep "
                         f"compliance; expected {' or '.join(CALIBRATION.values())} in --base")
    check_candidates(base, candidates)
    data = measured.load_measured(args.data, layout, args.drop_bad)
    console = Console(width=140)
    with progress_bar(console, "diagnosis", str, transient=True) as progress:
        rep = diagnose.diagnose(layout, data, base, candidates or None, progress)
    # the files first, then the terminal (a reader closing stdout early loses no file)
    written = plot_report(rep, make_folder(args.plots, kind="--plots")) if args.plots else []
    files, kinds = {}, {}
    if args.json:
        files[Path(args.json)], kinds[Path(args.json)] = json_text(rep.to_json()), "--json"
    if args.report:
        files[Path(args.report)], kinds[Path(args.report)] = report_text(
            args, "cvtdesign diagnose", report_blocks(rep, report_figures(rep, written))), "--report"
    if args.save_calibration:
        path = Path(args.save_calibration)
        files[path], kinds[path] = saved_calibration(args, layout, rep), "--save-calibration"
    write_files(files, kind=kinds)
    show(console, report_blocks(rep))
    for f in written:
        console.print(f"plot: {f}")
    if args.json:
        console.print(f"report written to {args.json}")
    if args.report:
        console.print(f"HTML report: {args.report}")
    if args.save_calibration:
        console.print(f"calibration written to {args.save_calibration} (a variant uses it with "
                      f"material_library: [{Path(args.save_calibration).name}]){other_fits(rep)}", markup=False)
    return 0


def saved_calibration(args, layout, rep: Report) -> str:
    """The library file --save-calibration writes: the diagnosed model's fitted creep scales as creep moduli
    of the rollers' materials (io.materials.fitted_calibrations), with their σ and provenance."""
    scales = {role: (rep.final_fit[f"{e}.scale"]["value"], rep.final_fit[f"{e}.scale"]["std"])
              for role, e in CALIBRATION.items() if f"{e}.scale" in rep.final_fit}
    fitted = ", ".join(f"{CALIBRATION[r]}.scale {v:.4g} ± {s:.2g}" for r, (v, s) in scales.items())
    effects = " + ".join(rep.base + rep.accepted)
    entries = materials.fitted_calibrations(
        layout, scales, machine=f"{layout.name} ({args.variant})", data=f"{args.data} ({rep.rows} rows)",
        fit=f"cvtdesign diagnose, {date.today().isoformat()}: {effects}; {fitted} on the variant's compliances")
    return materials.saved_library(args.save_calibration, load_spec(args.variant), entries)


def other_fits(rep: Report) -> str:
    """The diagnosed model's other fitted parameters, as the variant lines that carry them with their σ."""
    other = {k: v for k, v in rep.final_fit.items() if k.split(".")[0] not in CALIBRATION.values()}
    if not other:
        return ""
    values = {}
    for k, v in other.items():
        e, p = k.split(".")
        values.setdefault(e, {})[p] = (v["value"], v["std"])
    params = ", ".join(f"{e}: {{{', '.join(f'{p}: {x:.4g}' for p, (x, _) in ps.items())}}}" for e, ps in values.items())
    stds = ", ".join(f"{e}: {{{', '.join(f'{p}: {s:.2g}' for p, (_, s) in ps.items())}}}" for e, ps in values.items())
    return (f"; the other fitted effects go in the variant (SI): effect_parameters: {{{params}}}, "
            f"effect_uncertainty: {{{stds}}}")


def report_figures(rep: Report, written: list) -> list:
    """The residual map and the fit plot as report Figures: those written to --plots, else drawn into a
    temporary folder that is removed once they are read."""
    if written:
        return [png_figure(f, c) for f, c in zip(written, CAPTIONS)]
    with tempfile.TemporaryDirectory(prefix="cvtdesign-report-") as tmp:
        return [png_figure(f, c) for f, c in zip(plot_report(rep, Path(tmp)), CAPTIONS)]
