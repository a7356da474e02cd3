"""The objectives of a design study, one class per kind: what the study file's `objective.kind` names.

An objective says how it enters the NLP (design.problem): as an epigraph variable t over the envelope's
slip angles (−t ≤ α_k ≤ t, `epigraph`), or as a mean of a model output over the envelope's points
(`per_point`) or over the study's duty cycle (`value`); and what its value is (`title`, `unit`). A new kind is one class here and one entry in OBJECTIVES; the study file's schema, optimise's
tables and the report's axes take it from there.

`pareto` is the ε-constraint problem of the slip/loss front (design.solve.pareto_front): the mean power loss
with worst |α| ≤ ε, ε an input of the NLP. A study whose objective is `pareto` computes the front, and its
optimum is the front's knee (solve.run).
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
    eps_row: bool = False       # adds worst |α| ≤ ε, ε an input of the NLP (the Pareto problem)
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


class MaxLife(Objective):
    def value(self, nlp, grid_values):
        return worst_inverse_life(nlp)


OBJECTIVES = {o.kind: o for o in (
    WorstAlpha("worst_alpha", "worst |α|", "°", epigraph=True, case_column="worst_alpha_deg", robust=True),
    RmsAlpha("rms_alpha", "RMS α", "°"),
    PowerLoss("power_loss", "mean power loss", "W", case_column="power_loss_W"),
    PowerLoss("pareto", "mean power loss at the knee", "W", epigraph=True, eps_row=True,
              case_column="power_loss_W"),
    MaxLife("max_life", "1 / the shortest wear life over the rollers", "1/h", life=True),
)}


def objective(kind: str) -> Objective:
    """The objective called `kind` (the schema admits only these)."""
    return OBJECTIVES[kind]
