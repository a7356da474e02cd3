"""One study's optimum by multistart IPOPT, as `cvtdesign optimise` finds it (design.solve,
docs/optimisation.md): the design, its constraints, the base design's and the optimum's intervals and the
optimised variant's text. The study file is parsed here, once (design.study_file.load_study); the command
(cli/optimise.py) prints and writes what optimise_run returns."""
from __future__ import annotations

import dataclasses
from pathlib import Path

from cvtdesign.design import solve
from cvtdesign.design.objectives import objective
from cvtdesign.design.study_file import Study, load_study
from cvtdesign.errors import InputError
from cvtdesign.io import plots
from cvtdesign.io.output import make_folder, write_files
from cvtdesign.io.points import data_frame
from cvtdesign.io.schema import MAX_COUNT
from cvtdesign.io.variant import parameter_value
from cvtdesign.uses.result import Result, table_row

JSON_KEYS = ("status", "objective", "design", "active_constraints", "variant_file", "unmet_constraints")


def bounds(loaded: Study, design) -> dict:
    """{design variable: (lower, upper)} [SI] as the study writes them."""
    spec = loaded.spec.design
    return {n: tuple(parameter_value(getattr(spec[n], side), f"{loaded.path}: design.{n}.{side}", {})
                     for side in ("lower", "upper")) for n in design}


def json_content(res: dict) -> dict:
    """The ``optimise --json`` document of design.solve.run's result (without its pending files)."""
    details = {k: v for k, v in res.items() if k != "pending_files"}
    return {k: res[k] for k in JSON_KEYS if k in res} | {"details": details}


@dataclasses.dataclass(eq=False)
class Optimum(Result):
    """The result of `optimise`.

    Attributes
    ----------
    rows : list of dict
        The ``optimise --json`` document as one record (docs/optimisation.md): ``status``, ``objective`` (in
        the objective's unit: [°] or [W]), ``design`` [SI], ``active_constraints``, ``variant_file`` and
        ``details`` (every start, the constraints' rows, the intervals, the whole-envelope checks).
    study : Study
        The study as read (design.study_file.Study).
    files : dict
        {path: text} of the optimised variant file, not written yet (`write`); empty without an optimum.
    """

    rows: list[dict]
    study: Study = dataclasses.field(repr=False)
    files: dict = dataclasses.field(repr=False)

    @property
    def details(self) -> dict:
        """design.solve.run's result: what the command prints and reports."""
        return self.rows[0]["details"]

    @property
    def variant_text(self) -> str | None:
        """The optimised variant file's text (None without an optimum)."""
        return next(iter(self.files.values()), None)

    def content(self) -> dict:
        """The ``optimise --json`` document."""
        return self.rows[0]

    def table_rows(self) -> list[dict]:
        """Per design variable: ``variable``, its ``optimum``, ``base``, ``lower`` and ``upper`` [SI]."""
        res = self.details
        if not res["success"]:
            return []
        return [{"variable": n, "optimum": v, "base": res["base_design"][n], "lower": lo, "upper": hi}
                for (n, v), (lo, hi) in zip(res["design"].items(), bounds(self.study, res["design"]).values())]

    @property
    def intervals(self):
        """The base design's and the optimum's figures with their 95 % intervals (design.optimum_intervals)
        as a pandas.DataFrame, a row each (``design``: 'base' or 'optimum'), in the units the columns give."""
        got = self.details.get("intervals") or {}
        return data_frame([{"design": k} | table_row(got[k]) for k in ("base", "optimum") if k in got])

    def write(self) -> list[Path]:
        """Write the optimised variant file (`variant_file`), through the one writer; returns its path."""
        for p in self.files:
            make_folder(Path(p).parent, kind="out folder")
        return write_files(self.files, kind="variant file")

    def plot(self, path=None) -> Path:
        """How the solve converged (`cvtdesign optimise --report`'s Figure 2): the best start's IPOPT
        iterations and every start's optimum, as <study>_convergence.png in the folder `path` (default
        out/optimise, made if it is missing); returns the file."""
        res = self.details
        if not res["success"]:
            raise InputError(f"{self.study.path}: no optimum (status {res['status']}); nothing to plot")
        file = make_folder(path if path is not None else "out/optimise", kind="plot folder") / \
            f"{res['study']}_convergence.png"
        plots.convergence_figure(res["history"], res["start_objectives"], objective(res["objective_kind"]).axis, file)
        return file


def optimise_run(study, out=None, starts: int | None = None, progress=None, calibration=None) -> Optimum:
    """The study file read (once) and solved; nothing written (Optimum.files); `progress(solution)` told of
    each start."""
    if starts is not None and not 1 <= starts <= MAX_COUNT:
        raise InputError(f"--starts: expected from 1 to {MAX_COUNT} multistart points, got {starts}")
    loaded = load_study(study)           # the one read of the study file; passed down from here
    res = solve.run(loaded, out, starts, progress, write=False, calibration=calibration)
    return Optimum([json_content(res)], loaded, res["pending_files"])


def optimise(study_path, starts: int | None = None, out=None, calibration=None, write: bool = False) -> Optimum:
    """One study's optimum by multistart IPOPT, as ``cvtdesign optimise`` finds it.

    Parameters
    ----------
    study_path : str or Path
        A study file (docs/optimisation.md): the base variant, the design variables with their bounds, the
        objective, the constraints and the envelope.
    starts : int, optional
        Multistart points (default: the study's ``multistart.starts``).
    out : str or Path, optional
        The folder of the optimised variant file (default results/<study name>).
    calibration : str or Path, optional
        A diagnosis report whose fitted effect parameters the base variant carries (overrides the study's).
    write : bool
        Write the optimised variant file now (default False: `Optimum.write()` writes it).

    Returns
    -------
    Optimum
        `.rows` (the ``--json`` document, as one record), `.table` (pandas.DataFrame: each design variable's
        optimum, base value and bounds in SI: [m] for a length, [rad] for an angle), `.intervals` (the base design's and the optimum's figures with
        their 95 % intervals), `.variant_text`, `.to_json()`, `.plot(folder)`.

    Raises
    ------
    cvtdesign.errors.InputError
        A study or variant file or field that is not valid, or a count of starts that is not (one line).
    """
    result = optimise_run(study_path, out, starts, calibration=calibration)
    if write:
        result.write()
    return result
