"""The objectives of a design study, one class per kind: what the study file's `objective.kind` names.

An objective says how it enters the NLP (design.problem): as an epigraph variable t over the envelope's
slip angles (−t ≤ α_k ≤ t, `epigraph`), or as a mean of a model output over the envelope's points
(`per_point`) or over the study's duty cycle (`value`); what its value is (`title`, `unit`); and what the
design code does for it, as methods it calls rather than flags it tests: the NLP's inputs and extra rows
(`inputs`, `add_rows`), what a case of a study runs (`solves`) and the store's power-loss column
(`power_loss`). A new kind is one class here and one entry in OBJECTIVES; the study file's schema,
optimise's tables and the report's axes take it from there.

`pareto` is the ε-constraint problem of the slip/loss front (design.solve.pareto_front): the mean power loss
with worst |α| ≤ ε, ε an input of the NLP. A study whose objective is `pareto` computes the front, and its
optimum is the front's knee (solve.run): `ParetoLoss`.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from cvtdesign.design.life_rows import worst_inverse_life

DEG = 180 / np.pi


@dataclass(frozen=True)
class Objective:
    """One kind of objective (subclasses give `value`)."""
    kind: str
    title: str                  # what it is, in words ('worst |α|')
    unit: str                   # the unit its value is in and shown in ('°', 'W')
    epigraph: bool = False      # minimised as t with −t ≤ α_k ≤ t at every envelope point
    case_column: str | None = None   # the study store's column that holds it too (None: only 'objective')
    robust: bool = False        # a robust study's worst case over the calibration's region is built for it
    life: bool = False          # taken over constraints.life_duty (design.life_rows)

    @property
    def axis(self) -> str:
        return f"{self.title} [{self.unit}]"

    def per_point(self, nlp) -> str | None:
        """The model output the objective averages over the envelope's points (None: not a grid mean)."""
        return None

    def value(self, nlp, grid_values):
        """The objective as a CasADi expression of the NLP's x (grid_values: per point, of `per_point`)."""
        raise NotImplementedError

    def inputs(self, nlp) -> list:
        """The symbols the NLP's functions take (design.problem): x = (z, t)."""
        return [nlp.x]

    def add_rows(self, nlp, rows) -> None:
        """Rows of the objective's own, added to the NLP's design rows (design.rows.design_rows): none."""

    def solves(self, starts: int, pareto: bool) -> tuple[int, bool]:
        """What one case (variant file × sweep point) of a study with this objective runs (design.cases,
        solve.run): (multistart points, whether an ε-constraint chain of the slip/loss front too), given the
        study's `multistart.starts` and `batch.pareto`."""
        return starts, pareto

    def power_loss(self, value: float) -> float:
        """The mean power loss [W] a start case's row in the study's store holds, given the optimum's objective
        `value`: NaN, as this objective is not the power loss (design.study)."""
        return np.nan


class WorstAlpha(Objective):
    def value(self, nlp, grid_values):
        return nlp.t


class RmsAlpha(Objective):
    def per_point(self, nlp) -> str:
        return "alpha"

    def value(self, nlp, grid_values):
        return ca.sqrt(ca.sumsqr(grid_values * DEG) / nlp.npts)


class PowerLoss(Objective):
    def per_point(self, nlp) -> str | None:
        return None if nlp.spec.objective.duty_cycle else "power_loss"

    def value(self, nlp, grid_values):
        if grid_values is not None:
            return ca.sum2(grid_values) / nlp.npts
        return nlp.duty_mean("power_loss")

    def power_loss(self, value: float) -> float:
        return value


class ParetoLoss(PowerLoss):
    """The power loss with worst |α| ≤ ε, ε an input of the NLP: the front's ε-constraint problem, and as a
    study's objective the front itself (its chain is each case's solve, no multistart; its knee the optimum)."""

    def inputs(self, nlp) -> list:
        return [nlp.x, nlp.eps]

    def add_rows(self, nlp, rows) -> None:
        rows.add(nlp.t - nlp.eps, -np.inf, 0, "epsilon", ["worst |α| ≤ ε"])

    def solves(self, starts: int, pareto: bool) -> tuple[int, bool]:
        return 0, True


class MaxLife(Objective):
    def value(self, nlp, grid_values):
        return worst_inverse_life(nlp)


OBJECTIVES = {o.kind: o for o in (
    WorstAlpha("worst_alpha", "worst |α|", "°", epigraph=True, case_column="worst_alpha_deg", robust=True),
    RmsAlpha("rms_alpha", "RMS α", "°"),
    PowerLoss("power_loss", "mean power loss", "W", case_column="power_loss_W"),
    ParetoLoss("pareto", "mean power loss at the knee", "W", epigraph=True, case_column="power_loss_W"),
    MaxLife("max_life", "1 / the shortest wear life over the rollers", "1/h", life=True),
)}


def objective(kind: str) -> Objective:
    """The objective called `kind` (the schema admits only these)."""
    return OBJECTIVES[kind]
