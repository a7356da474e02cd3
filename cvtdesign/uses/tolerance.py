"""How sensitive a variant is to manufacturing, as `cvtdesign tolerance` finds it (design.tolerance,
docs/tolerances.md): Monte Carlo over the toleranced dimensions (and the physical inputs, unless
dimensions_only) on Dask in a resumable store, against the first order from the model's exact derivatives,
the tolerances and inputs ranked by their effect. The command (cli/tolerance.py) prints and writes what
tolerance_run returns."""
from __future__ import annotations

import dataclasses
import textwrap
from pathlib import Path

import pandas as pd

from cvtdesign.core.tolerances import KINDS
from cvtdesign.design.tolerance import (
    FIGURES,
    ToleranceContent,
    built_model,
    check_directions,
    check_run,
    figures,
    run_samples,
    tolerance_content,
)
from cvtdesign.design.tolerance_stats import effects, first_order, slopes, summary
from cvtdesign.io import plots
from cvtdesign.io.output import make_folder
from cvtdesign.io.units import engineering
from cvtdesign.uses.result import Result

RANKED = 10          # dimensions ranked in the printed table and the figure (all of them in --json)
# compare's label of each figure, without compare's footnote marks
LABELS = {"max_abs_alpha_deg": "max |α| [°]"}


def tolerance_text(d) -> str:
    """A dimension's distribution as an engineer writes it: 'σ 0.1°', '± 0.1 mm', '± 10 %'."""
    kind = KINDS[d.kind]
    size = f"{100 * d.size:.4g} %" if kind == "dimensionless" else engineering(d.size, kind)
    return ("σ " if d.distribution == "normal" else "± ") + size


def source_name(e: dict) -> str:
    """An effect's dimension, or 'input: <label>' for a physical input."""
    return e["dimension"] if "dimension" in e else f"input: {e['input']}"


def source_text(e: dict, content) -> str:
    """An effect's tolerance (tolerance_text), or a physical input's relative spread: 'σ 20 % (assumed)',
    '± 25 %' (uniform: its half-width)."""
    if "dimension" in e:
        return tolerance_text(next(d for d in content.dims if d.label == e["dimension"]))
    s = next(s for s in content.inputs if s.label == e["input"])
    return ("σ " if s.distribution == "normal" else "± ") + f"{100 * s.size:.2g} %" + (" (assumed)" if s.assumed else "")


@dataclasses.dataclass(eq=False)
class Tolerance(Result):
    """The result of `tolerance`.

    Attributes
    ----------
    rows : list of dict
        The ``tolerance --json`` document as one record (docs/tolerances.md): ``figures`` (each of compare's
        figures: nominal, the samples' mean, σ, 5 % and 95 %, the first order's mean and σ, in the figure's
        unit), ``effects`` (per figure, each dimension or input alone, first order, ranked), the counts of
        samples drawn and held, and what was left out.
    samples : pandas.DataFrame
        One row a sample: its deviations (``x.<label>``, SI), status and figures.
    failed : list of str
        The chunks of samples that failed to run (their samples are missing: running again retries them).
    drawn_before : int
        How many samples the store held before this run.
    """

    rows: list[dict]
    samples: pd.DataFrame = dataclasses.field(repr=False)
    failed: list
    drawn_before: int
    content_: ToleranceContent = dataclasses.field(repr=False)
    first: dict = dataclasses.field(repr=False)

    def content(self) -> dict:
        """The ``tolerance --json`` document."""
        return self.rows[0]

    def table_rows(self) -> list[dict]:
        """The ranking of max |α|: per dimension or input, ``source``, its ``tolerance`` as written, its
        ``effect_deg`` [°] (alone, first order) and the sampled and first-order slopes × σ [°]."""
        out = self.rows[0]
        return [{"source": source_name(e), "tolerance": source_text(e, self.content_), "effect_deg": e["effect"],
                 "slope_sampled_deg": e["slope_sampled"], "slope_first_order_deg": e["slope_first_order"]}
                for e in out["effects"][FIGURES[0]]]

    def plot(self, path=None) -> Path:
        """The figure of max |α| (`cvtdesign tolerance --plots`'): its sampled and first-order distributions
        and the tolerances ranked, as <variant stem>_<tolerances stem>_tolerance.png in the folder `path`
        (default out/tolerance, made if it is missing); returns the file."""
        out, content = self.rows[0], self.content_
        name = f"{Path(out['variant_file']).stem}_{Path(out['tolerances_file']).stem}_tolerance.png"
        file = make_folder(path if path is not None else "out/tolerance", kind="plot folder") / name
        key = FIGURES[0]
        ranked = [(textwrap.fill(f"{source_name(e)}, {source_text(e, content)}", 48), e["effect"])  # inputs' labels
                  for e in out["effects"][key]]                                                  # are long
        also = f" and {len(content.inputs)} physical inputs" if content.inputs else ""
        return plots.tolerance_figure(f"{content.layout.name}: {LABELS[key]} under the tolerances of "
                                      f"{Path(out['tolerances_file']).name}{also} (law {content.layout.contact_law})",
                                      LABELS[key], self.samples[key].where(self.samples["status"] == "ok"),
                                      self.first["values"][:, 0], out["figures"][key]["nominal"], ranked, file,
                                      top=RANKED)


def tolerance_run(variant, tolerances, samples: int, dimensions_only: bool = False, store=None,
                  where: tuple = (None, None), progress=None, notice=None) -> Tolerance:
    """The samples drawn (or resumed from `store`) and summed up; `where`: (scheduler, workers);
    `progress(done, total, row)` follows the samples, `notice(text)` is told of stale chunks."""
    check_run(samples, where[1], where[0])
    content = tolerance_content(variant, tolerances, dimensions_only)
    model, nominal = built_model(content)
    check_directions(model, content.dims, tolerances)
    store = Path(store or Path("results") / f"{Path(variant).stem}_{content.name}")
    start = []

    def follow(done, total, row):
        if not start:
            start.append(done)
        if progress:
            progress(done, total, row)
    table, failed = run_samples(content, samples, store, where, follow, notice)
    xs = table[[f"x.{d.label}" for d in content.sources]].to_numpy(float)
    fo = first_order(model, nominal, content, xs)
    eff = effects(model, nominal, fo, content.sources)
    out = {"variant": content.layout.name, "variant_file": str(variant), "tolerances_file": str(tolerances),
           "contact_law": content.layout.contact_law, "store": str(store),
           **summary(table, figures(model, nominal), fo, eff, slopes(table, fo, content.sources), content)}
    return Tolerance([out], table, failed, min(start[0], samples), content, fo)


def tolerance(variant, tolerances, samples: int = 200, dimensions_only: bool = False, store=None,
              scheduler: str | None = None, workers: int | None = None) -> Tolerance:
    """How sensitive a variant is to manufacturing, as ``cvtdesign tolerance`` finds it.

    Parameters
    ----------
    variant : str or Path
        The variant file.
    tolerances : str or Path
        A tolerances file (docs/tolerances.md): each toleranced dimension's distribution (σ or ± in its unit,
        an angle [°], a length [mm] or a share [%]) and the ``seed`` the samples are drawn with.
    samples : int
        Monte Carlo samples (default 200).
    dimensions_only : bool
        Sample the toleranced dimensions alone, the physical inputs held at their values (default False).
    store : str or Path, optional
        The store of the samples, resumed when run again (default results/<variant stem>_<name>).
    scheduler : str, optional
        Address of an existing Dask scheduler (default: a local cluster).
    workers : int, optional
        The local cluster's size (default: one single-threaded worker per core).

    Returns
    -------
    Tolerance
        `.rows` (the ``--json`` document, as one record), `.table` (pandas.DataFrame: the ranking of max |α|
        [°] by dimension or input), `.samples`, `.to_json()`, `.plot(folder)`.

    Raises
    ------
    cvtdesign.errors.InputError
        A file or field that is not valid, or a count that is not (one line naming it).
    """
    return tolerance_run(variant, tolerances, samples, dimensions_only, store, (scheduler, workers))
