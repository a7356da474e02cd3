"""Compare variants over their envelope, as `cvtdesign compare` does (docs/comparing.md): every figure with its
95 % interval and budget from every uncertain input, and the orderings that paired samples resolve.

The command (cli/compare.py) calls the same steps, so that `cvtdesign compare ... --json` and
``compare(...).to_json()`` give the same text: comparison_layouts (read, put on one basis), then each
layout's uncertain model and envelope, then comparison_rows (figures, intervals, orderings)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from cvtdesign.uses.result import Result
from cvtdesign.core import basis
from cvtdesign.core.contact.laws import contact_law
from cvtdesign.core.inputs import uncertain_model
from cvtdesign.core.layout import Layout
from cvtdesign.core.metrics import delivers_power, envelope, ideal_model, metrics
from cvtdesign.core.uncertainty import checked_by_sampling, intervals, orderings, point_bands, sampled_figures, spread
from cvtdesign.errors import InputError
from cvtdesign.io import plots
from cvtdesign.io.limits import check_envelope_limits, check_samples
from cvtdesign.io.output import named_after
from cvtdesign.io.shipped import shipped_variant
from cvtdesign.io.variant import load_variant

DEFAULT_SAMPLES, SAMPLED_POINTS = 128, 2000   # samples by default, on envelopes of at most this many points


def as_layout(variant) -> Layout:
    """A variant given as a file (str or Path) read by io.variant.load_variant, or a Layout as it is."""
    return variant if isinstance(variant, Layout) else load_variant(variant)


def comparison_layouts(variants, envelope_of=None, as_written: bool = False) -> list[Layout]:
    """The layouts that a comparison of `variants` (files or Layouts) sets side by side: with one variant,
    Kim's existing CVT under the same contact law before it; all on one basis (one_basis); each with a
    distinct name (two files of one `name:` get two columns)."""
    layouts = [as_layout(v) for v in variants]
    if len(layouts) == 1:                          # Kim's CVT under the same law, wherever the command runs from
        existing = shipped_variant(contact_law(layouts[0].contact_law).reference_variant)
        if existing.resolve() != Path(layouts[0].file).resolve():
            layouts.insert(0, load_variant(existing))
    layouts = one_basis(layouts, layouts[-1] if len(variants) == 1 else layouts[0], envelope_of, as_written)
    names = basis.distinct_names(layouts)
    return [dataclasses.replace(L, name=n) for L, n in zip(layouts, names)]


def one_basis(layouts: list, first, envelope_of=None, as_written: bool = False) -> list:
    """The layouts on one basis: one contact law (different laws are refused unless `as_written`) and one
    envelope, the first file's or `envelope_of`'s (a variant file; with `as_written` each keeps its own)."""
    if as_written:
        return layouts
    laws = {L.contact_law for L in layouts}
    if len(laws) > 1:
        which = ", ".join(f"{L.file}: {L.contact_law}" for L in layouts)
        raise InputError(f"compare: the variants use different contact laws ({which}); compare them under one "
                         "law (contact.law), or add --as-written to compare each as written")
    reference = load_variant(envelope_of) if envelope_of else first
    out = []
    for L in layouts:
        if not basis.same_envelope(L, reference):
            L = basis.on_envelope(L, reference)
            check_envelope_limits(L, f"{L.file}: on the envelope of {reference.file}")
        out.append(L)
    return out


def sample_count(given: int | None, points: int) -> int:
    """The samples that check the intervals: --samples as given (0, or 20 to MAX_SAMPLES), else DEFAULT_SAMPLES
    on an envelope of at most SAMPLED_POINTS points and none on a larger one (the notes then say unchecked)."""
    if given is None:
        return DEFAULT_SAMPLES if points <= SAMPLED_POINTS else 0
    return check_samples(given)


def with_intervals(spread, row: dict, samples: list[dict] | None) -> dict:
    """The row with a 95 % interval and a budget on each figure from every uncertain input (core.uncertainty),
    each interval checked by the samples of the inputs (replaced where they do not confirm it)."""
    row = row | intervals(spread, row)
    return row | checked_by_sampling(row, samples) if samples else row


def comparison_rows(models: list, results: list[dict], samples: int | None = None, ideal_of: Layout | None = None,
                    extra=None) -> tuple[list[dict], list[dict]]:
    """The `compare --json` content of compiled uncertain models and their envelopes: per variant its figures
    (core.metrics.metrics) with `<figure>_interval` and `<figure>_budget` (checked by `samples` samples of
    the inputs: sample_count), then `extra(model)`'s fields (the command's --duty life) and, with `ideal_of`,
    the ideal CVT of that layout first; and the orderings paired samples resolve. Returns (rows, orderings)."""
    n = sample_count(samples, results[0]["ok"].size)
    spreads = [spread(m, res) for m, res in zip(models, results)]
    drawn = [sampled_figures(m, n) if n and s is not None else None for m, s in zip(models, spreads)]
    rows = [with_intervals(s, metrics(m, res) | basis.fields(m.layout), d)
            for m, res, s, d in zip(models, results, spreads, drawn)]
    ranked = orderings(rows, spreads, drawn if n else None)
    if extra is not None:
        rows = [r | extra(m) for r, m in zip(rows, models)]
    if ideal_of is not None:
        ideal = ideal_model(ideal_of)
        row = metrics(ideal, envelope(ideal)) | basis.fields(ideal.layout)
        row |= {"name": f"ideal ({ideal_of.name})", "contact_law": "rigid (ideal)",
                "calibration": {"source": "none needed: rigid rolling", "uncalibrated": False, "std": {},
                                "text": "none needed: rigid rolling", "cell": "none needed"}}
        rows.insert(0, row)
    return rows, ranked


def figure_data(res: dict) -> dict:
    """What the figure draws of an envelope: its COMPARE_KEYS, with the efficiency undefined (NaN, hatched) where
    the point delivers no power, so that a point with no output is never drawn as an efficiency of 0."""
    data = {k: res[k] for k in plots.COMPARE_KEYS}
    data["efficiency"] = np.where(delivers_power(res), res["efficiency"], np.nan)
    return data


def figure_inputs(layouts: list, models: list, results: list[dict]) -> list[tuple[str, dict]]:
    """io.plots.compare_figure's input: per variant its name and what the figure draws (figure_data, the
    points' 95 % bands, whether its calibration is theory only)."""
    return [(L.name, figure_data(res) | point_bands(m, res) | {"theory_only": basis.calibration(L)["uncalibrated"]})
            for L, m, res in zip(layouts, models, results)]


@dataclasses.dataclass(eq=False)
class Comparison(Result):
    """The result of `compare`.

    Attributes
    ----------
    rows : list of dict
        Per variant (the ideal CVT first when one variant was given) the ``compare --json`` record: every
        figure (``max_abs_alpha_deg`` [°], ``rms_alpha_deg`` [°], ``ratio_error_pct_at_max_load`` [%],
        ``min_efficiency`` [-], ``max_loss_no_output_W`` [W], ``max_traction_utilisation`` [-],
        ``max_hertz_pressure_MPa`` [MPa], ``max_steering_torque_Nm`` [N·m], ...), its 95 % interval
        ``<figure>_interval`` ([low, high], same unit) and budget ``<figure>_budget`` (each input's share of
        the variance), the points ok, the calibration and the envelope (docs/comparing.md).
    orderings : list of dict
        The orderings that paired samples of the inputs resolve at 95 % (P ≥ 97.5 %), each with its P and the
        input that would settle it.
    layouts : list of Layout
        The layouts compared, on one basis, named as in the rows.
    results : list of dict
        Each layout's envelope evaluation (arrays over γ × τ⊥, SI), for figures of your own.
    """

    rows: list[dict]
    orderings: list[dict]
    layouts: list
    models: list = dataclasses.field(repr=False)
    results: list[dict] = dataclasses.field(repr=False)
    files: list = dataclasses.field(default_factory=list, repr=False)

    def content(self) -> dict:
        """The ``compare --json`` document: {"variants": rows, "orderings": orderings}."""
        return {"variants": self.rows, "orderings": self.orderings}

    @property
    def table(self):
        """The figures of each variant as a pandas.DataFrame: one row per variant (index: its name), a column
        per plain field (units in the names), each 95 % interval as ``<figure>_low`` and ``<figure>_high``."""
        return super().table.set_index("name")

    def plot(self, path=None) -> Path:
        """The comparison figure (`cvtdesign compare`'s): a PNG at `path`, default
        out/compare/<the files' stems joined by +>.png; returns the path written."""
        path = Path(path) if path is not None else Path("out/compare") / named_after(self.files, ".png")
        plots.compare_figure(figure_inputs(self.layouts, self.models, self.results), path)
        return path


def compare(*variants, samples: int | None = None, envelope_of=None, as_written: bool = False) -> Comparison:
    """Compare variants over their operating envelope, as ``cvtdesign compare`` does.

    Parameters
    ----------
    *variants : str, Path or Layout
        Variant files (or layouts from `load_variant`). With one, Kim's existing CVT under the same contact law
        and the ideal CVT are compared with it.
    samples : int, optional
        Samples of every uncertain input that check each first-order interval: 0 (first order only) or 20 to
        10,000; default 128 on an envelope of at most 2000 points, else 0 (``--samples``).
    envelope_of : str or Path, optional
        A variant file whose envelope (its grid of γ [°] × τ⊥ [N·m]) every variant is evaluated on (``--envelope``); default
        the first variant's.
    as_written : bool
        Evaluate each variant on its own envelope and contact law (``--as-written``).

    Returns
    -------
    Comparison
        `.rows` and `.orderings` (the ``--json`` content: figures such as ``max_abs_alpha_deg`` [°] and
        ``max_hertz_pressure_MPa`` [MPa] with their intervals), `.table` (pandas.DataFrame), `.to_json()`,
        `.plot(path)`.

    Raises
    ------
    cvtdesign.errors.InputError
        A file, field or option that is not valid (one line naming it).
    """
    if not variants:
        raise InputError("compare: no variant given; expected one or more variant files")
    layouts = comparison_layouts(variants, envelope_of, as_written)
    models = [uncertain_model(L) for L in layouts]
    results = [envelope(m) for m in models]
    rows, ranked = comparison_rows(models, results, samples, layouts[-1] if len(variants) == 1 else None)
    files = [getattr(v, "file", v) for v in variants]
    return Comparison(rows, ranked, layouts, models, results, files)
