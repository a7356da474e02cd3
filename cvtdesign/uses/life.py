"""Heat, wear and life of every contact of variants over a duty cycle, as `cvtdesign life` computes them
(core.life, docs/life.md): each variant's machine life with its 95 % interval, limit and contact, and each
contact's loss, temperatures, wear rate and life. The command (cli/life.py) prints and writes what life_run
returns; compare --duty adds life_fields."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from cvtdesign.uses.comparison import as_layout
from cvtdesign.uses.result import Result
from cvtdesign.core import basis
from cvtdesign.core.inputs import uncertain_model
from cvtdesign.core.life.run import DutyOutsideModel, life_interval, machine_life, worn_ratio_error
from cvtdesign.errors import InputError
from cvtdesign.io import plots
from cvtdesign.io.ageing import roller_ageing
from cvtdesign.core.life.duty import DutyCycle
from cvtdesign.io.duty_file import load_duty
from cvtdesign.io.output import make_folder, named_after
from cvtdesign.io.variant import load_spec

C0 = 273.15                 # [K] 0 °C
NEEDED = ("loss_fraction", "density", "specific_heat", "conductivity", "max_temperature", "wear_coefficient")


def hours(seconds) -> float | None:
    """Seconds as hours [h]; None where there is no finite number."""
    return None if seconds is None or not math.isfinite(seconds) else seconds / 3600.0


def ageing_of(file: Path, model) -> list:
    """Per roller, (its material's Ageing, the sphere's); a constant the chain needs and no material gives is
    one InputError line naming the material."""
    ages = roller_ageing(str(file), load_spec(file), model.roller_names)
    for n in model.roller_names:
        for a in ages[n]:
            missing = [k for k in NEEDED if k not in a.values]
            if missing:
                raise InputError(f"{file}: materials.{a.material}.ageing: missing {', '.join(missing)}; expected "
                                 f"every constant `cvtdesign life` needs (docs/life.md), in the variant or the "
                                 f"materials library")
    return [ages[n] for n in model.roller_names]


def life_fields(model, duty) -> dict:
    """compare --duty's fields of one variant: its life [h] on the duty cycle (no interval: `cvtdesign life`
    gives it), its limit and contact."""
    try:
        life = machine_life(model, duty, ageing_of(Path(model.layout.file), model))
    except DutyOutsideModel as e:
        raise InputError(f"{duty.file}: {e} of {model.layout.file}; expected duty points where the variant "
                         f"holds (cvtdesign capacity shows its limits)") from None
    return {"life_h": hours(life.life), "life_limit": life.limit, "life_contact": life.contact,
            "life_duty": duty.name}


def variant_record(name: str, life, intervals: dict, shares) -> dict:
    """One variant's JSON record (the `life --json` interface: docs/life.md); `shares`: the duty points'."""
    contacts = [{"contact": c.name, "loss_mean_W": float(np.sum(shares * c.loss)), "loss_peak_W": float(np.max(c.loss)),
                 "T_steady_C": c.T_mean - C0, "T_peak_C": c.T_peak - C0, "wear_um_per_h": c.wear_rate * 3.6e9,
                 "life_h": hours(c.life), "limit": c.limit} for c in life.contacts]
    lo, hi = intervals["machine"]
    return {"name": name, "life_h": hours(life.life), "life_h_interval": [hours(lo), hours(hi)],
            "limit": life.limit, "contact": life.contact, "contacts": contacts}


def life_figures(records, lives, ages, intervals, files, folder: Path) -> list[Path]:
    """The temperature and life figures of `life` results, written into `folder`; returns their paths."""
    curves = [{"name": r["name"], "rollers": {c.name: ((c.curve[0], c.curve[1] - C0), (c.warm_up[0], c.warm_up[1] - C0))
                                           for c in life.contacts},
               "max_C": {c.name: a[0]["max_temperature"] - C0 for c, a in zip(life.contacts, age)}}
              for r, life, age in zip(records, lives, ages)]
    paths = [folder / named_after(files, "_temperature.png"), folder / named_after(files, "_life.png")]
    plots.temperature_figure(curves, paths[0])
    plots.life_figure(records, intervals, paths[1])
    return paths


@dataclasses.dataclass(eq=False)
class Life(Result):
    """The result of `life`.

    Attributes
    ----------
    rows : list of dict
        Per variant the ``life --json`` record (docs/life.md): ``life_h`` [h] with ``life_h_interval`` [h]
        (95 %), the ``limit`` and ``contact`` that end it, and ``contacts``: each contact's ``loss_mean_W``,
        ``loss_peak_W`` [W], ``T_steady_C``, ``T_peak_C`` [°C], ``wear_um_per_h`` [µm/h], ``life_h`` [h] and
        ``limit``.
    duty : DutyCycle
        The duty cycle (core.life.duty.DutyCycle), in SI.
    lives : list
        Each variant's core.life.run result (temperature curves, per contact), for figures of your own.
    """

    rows: list[dict]
    duty: DutyCycle
    lives: list = dataclasses.field(repr=False)
    ages: list = dataclasses.field(repr=False)
    intervals: list = dataclasses.field(repr=False)
    worn: list = dataclasses.field(repr=False)
    files: list = dataclasses.field(default_factory=list, repr=False)

    def content(self) -> dict:
        """The ``life --json`` document: {"variants": rows}."""
        return {"variants": self.rows}

    def table_rows(self) -> list[dict]:
        """One row per variant and contact: ``variant``, the machine's ``machine_life_h`` [h], then the
        contact's fields (losses [W], temperatures [°C], wear [µm/h], life [h], limit)."""
        return [{"variant": r["name"], "machine_life_h": r["life_h"]} | c for r in self.rows for c in r["contacts"]]

    def plot(self, path=None) -> Path:
        """The temperature and life figures (`cvtdesign life --plots`') in the folder `path` (default out/life,
        made if it is missing): <stems>_temperature.png (each roller's temperature [°C] over the cycle) and
        <stems>_life.png (each variant's life [h] with its interval); returns the folder."""
        folder = make_folder(path if path is not None else "out/life", kind="plot folder")
        life_figures(self.rows, self.lives, self.ages, self.intervals, self.files, folder)
        return folder


def life_run(variants, duty: DutyCycle, progress=None) -> Life:
    """Every variant's life over `duty` (core.life.duty.DutyCycle), with its intervals; `progress(done, total, text)`
    told as the intervals are found."""
    progress = progress or (lambda done, total, item: None)
    layouts = [as_layout(v) for v in variants]
    files = [Path(L.file) for L in layouts]
    names = basis.distinct_names(layouts)
    # the uncertain model (core.inputs): its design vector moves the preloads, moduli, friction and spin moment
    models = [uncertain_model(dataclasses.replace(L, name=n)) for L, n in zip(layouts, names)]
    ages = [ageing_of(f, m) for f, m in zip(files, models)]
    records, lives, intervals, worn = [], [], [], []
    for i, (f, m, a) in enumerate(zip(files, models, ages)):
        try:
            life = machine_life(m, duty, a)
        except DutyOutsideModel as e:
            raise InputError(f"{duty.file}: {e} of {f}; expected duty points where the variant holds "
                             f"(cvtdesign capacity shows its limits)") from None
        iv = life_interval(m, duty, a, life, progress=lambda d, t, i=i, n=names[i]: progress(
            i * t + d, len(files) * t, f"{n}: intervals"))
        records.append(variant_record(names[i], life, iv, duty.shares))
        lives.append(life)
        worn.append(worn_ratio_error(m, duty, life))
        intervals.append({k: tuple(hours(x) for x in v) for k, v in iv.items()})
    return Life(records, duty, lives, ages, intervals, worn, files)


def life(*variants, duty) -> Life:
    """Heat, wear and life of every contact of each variant over a duty cycle, as ``cvtdesign life`` gives them.

    Parameters
    ----------
    *variants : str, Path or Layout
        Variant files, or layouts from `load_variant` (their materials' ageing constants are read from the
        variant's file and its materials library).
    duty : str or Path
        A duty-cycle file (docs/life.md): operating points γ [°], τ⊥ [N·m], speeds and their shares of the
        cycle, the ambient temperature [°C] and the wear limit.

    Returns
    -------
    Life
        `.rows` (the ``--json`` records: each machine's life [h] with its interval, each contact's losses [W],
        temperatures [°C], wear [µm/h] and life [h]), `.table` (pandas.DataFrame, a row per variant and
        contact), `.to_json()`, `.plot(folder)`.

    Raises
    ------
    cvtdesign.errors.InputError
        A file or field that is not valid, a material without the constants life needs, or duty points where
        the variant does not hold (one line naming it).
    """
    if not variants:
        raise InputError("life: no variant given; expected one or more variant files")
    return life_run(variants, load_duty(duty))
