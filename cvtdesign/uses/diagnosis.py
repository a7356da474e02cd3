"""Diagnose rig data against a variant's model, as `cvtdesign diagnose` does (docs/diagnosis.md): where the model
and the data disagree, which effect of the vocabulary causes it, and how far the gap shrinks once it is added.
The data may be a measured-data CSV file or a pandas DataFrame in its columns (docs/measured-data.md)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from cvtdesign.uses.comparison import as_layout
from cvtdesign.uses.result import Result
from cvtdesign.core.effects import check_names
from cvtdesign.diagnosis import diagnose as diagnosis
from cvtdesign.diagnosis import measured
from cvtdesign.diagnosis.diagnose import Report, model_efficiency, residuals
from cvtdesign.errors import InputError
from cvtdesign.io import plots
from cvtdesign.io.output import make_folder


def check_candidates(base, candidates) -> None:
    """Refuse candidates that are already in the base model (one line naming them)."""
    if set(candidates) & set(base):
        raise InputError(f"--candidates: {', '.join(e for e in candidates if e in base)} is already in the base model "
                         f"({', '.join(base)}); expected effects to add to it")


def plot_report(rep: Report, out_dir) -> list:
    """Residual maps (base and diagnosed model) and the fit curves; returns the files written."""
    out_dir = Path(out_dir)
    data, base, final = rep.evidence.data, rep.evidence.base, rep.evidence.final
    r = data.rows
    g, t = r["gamma_cmd_deg"].to_numpy(), r["tau_perp"].to_numpy()
    rb, rf = residuals(data, base.fit.pred), residuals(data, final.fit.pred)     # blank where a model fails
    maps = [(f"α residual, base ({' + '.join(base.effects) or 'ideal'})", g, t, np.where(base.fit.ok, rb["alpha"], np.nan))]
    if final is not base:
        maps.append((f"α residual, with {' + '.join(rep.accepted)}", g, t, np.where(final.fit.ok, rf["alpha"], np.nan)))
    f1 = out_dir / "residual_map.png"
    plots.residual_map_figure(maps, rep.gap["regions"][:6], f1)
    eb, ef = model_efficiency(data, base.pred), model_efficiency(data, final.pred)
    panels = [("slip angle α", "α [deg]", []), ("efficiency", "efficiency [-]", [])]
    for load, idx in _load_slices(t, r["load_bin"].to_numpy() if "load_bin" in r.columns else None):
        idx = idx[np.argsort(g[idx])]
        panels[0][2].append((load, g[idx], r["alpha_deg"].to_numpy()[idx], base.pred["alpha"][idx], final.pred["alpha"][idx]))
        panels[1][2].append((load, g[idx], r["efficiency"].to_numpy()[idx], eb[idx], ef[idx]))
    f2 = out_dir / "fit.png"
    plots.diagnosis_fit_figure({"panels": panels}, f2)
    return [f1, f2]


def _load_slices(load: np.ndarray, level: np.ndarray | None = None) -> list:
    """(load, points) at four loads across the data's range (its extremes and halves). On a grid (load levels
    each measured at several γ: `level`, measured._group's load_bin) the points of the level nearest each,
    one level a line (a window of a tenth of the range took two levels 0.2 N·m apart into one saw-tooth);
    otherwise the points within a tenth of the range of each."""
    lo, hi = float(load.min()), float(load.max())
    targets = sorted({lo, 0.5 * lo, 0.5 * hi, hi})
    if level is not None and len(np.unique(level)) <= len(load) / 3:
        means = {b: float(np.mean(load[level == b])) for b in np.unique(level)}
        chosen = dict.fromkeys(min(means, key=lambda b: abs(means[b] - x)) for x in targets)
        return [(means[b], np.flatnonzero(level == b)) for b in chosen]
    width = 0.1 * (hi - lo) if hi > lo else 1.0
    out = []
    for x in targets:
        idx = np.flatnonzero(np.abs(load - x) <= width / 2 + 1e-12)
        if idx.size:
            out.append((float(np.mean(load[idx])), idx))
    return out


@dataclasses.dataclass(eq=False)
class Diagnosis(Result):
    """The result of `diagnose`.

    Attributes
    ----------
    report : Report
        The diagnosis (cvtdesign.diagnosis.diagnose.Report): ``verdict`` (an effect's name, ``'none'`` or
        ``'unexplained'``), ``accepted`` effects, ``base_fit`` and ``final_fit`` (each fitted parameter's value
        and σ, SI), ``how_far`` (held-out RMS errors before and after: α [°], efficiency [-]), ``gap``, …
    rows : list of dict
        The first round's candidates, best first (the JSON's ``ranking``): each effect and how much of the gap it
        removes.
    """

    report: Report
    rows: list[dict]

    def content(self) -> dict:
        """The ``diagnose --json`` document (Report.to_json: every finding, without the evidence)."""
        return self.report.to_json()

    def plot(self, path=None) -> Path:
        """The diagnosis's figures in the folder `path` (default out/diagnosis): residual_map.png (the α
        residual [°] over γ × τ⊥, base and diagnosed model) and fit.png (α [°] and efficiency against γ at a few
        loads), the folder made if it is missing; returns the folder."""
        folder = make_folder(path if path is not None else "out/diagnosis", kind="plot folder")
        plot_report(self.report, folder)
        return folder


def diagnose(variant, data, base=None, candidates=None, drop_bad: bool = False, progress=None) -> Diagnosis:
    """Diagnose measured data against a variant's model, as ``cvtdesign diagnose`` does.

    Parameters
    ----------
    variant : str, Path or Layout
        The variant the rig is (its file, or a layout from `load_variant`).
    data : str, Path or pandas.DataFrame
        Measured data: a CSV file, or a DataFrame in its columns, ``gamma_cmd_deg`` [°], ``omega_1``,
        ``omega_2`` [rad/s], ``tau_1``, ``tau_2`` [N·m], optionally ``gamma_axis_deg`` [°] and ``time_s`` [s]
        (docs/measured-data.md). A DataFrame's rows are checked as a file's, each named by the line it would
        have in a CSV (the header is line 1).
    base : list of str, optional
        The effects of the base model (``--base``); default the variant's own.
    candidates : list of str, optional
        The effects to try adding (``--candidates``); default every other effect of the vocabulary.
    drop_bad : bool
        Drop and count bad rows instead of refusing the data (``--drop-bad``).
    progress : callable, optional
        ``progress(done, total, what)``, told of each step.

    Returns
    -------
    Diagnosis
        `.report` (the findings), `.rows` (the candidates ranked), `.table` (pandas.DataFrame), `.to_json()`
        (``diagnose --json``'s document), `.plot(folder)`.

    Raises
    ------
    cvtdesign.errors.InputError
        A file, column, row or effect name that is not valid (one line naming it and what was expected).
    """
    layout = as_layout(variant)
    base = tuple(layout.effects) if base is None else check_names(list(base), "base")
    candidates = [] if candidates is None else check_names(list(candidates), "candidates")
    check_candidates(base, candidates)
    if isinstance(data, (str, Path)):
        rows = measured.load_measured(data, layout, drop_bad)
    else:
        rows = measured.measured_frame(data, layout, drop_bad)
    report = diagnosis.diagnose(layout, rows, base, candidates or None, progress)
    return Diagnosis(report, list(report.ranking))
