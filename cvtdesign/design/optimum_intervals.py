"""How sure an optimum is: the base design's and the optimum's figures, each with its 95 % interval and budget
from every uncertain input (core.inputs: the calibration, the preloads, the moduli, the pairs' friction, the
law's own error), and whether the optimum's gain over the base design is resolved at that uncertainty.

The two designs share their materials, pairs, calibration and law, so those inputs move both alike and cancel in
the difference; each design's preload is its own (set when it is assembled). The difference's own interval is
taken over their union (core.uncertainty.orderings). Each interval is checked by SAMPLES draws of every input and
replaced by the sampled range where the first order does not hold (the worst efficiency's crosses 0), as
compare's are; the two builds are compared on paired samples, the one-preload question to first order. An optimiser that moves a design by less than
the difference's spread has found no improvement a prototype would show, and the note says so.
"""
from __future__ import annotations

import dataclasses

from cvtdesign.core import basis
from cvtdesign.core.inputs import uncertain_model
from cvtdesign.core.metrics import envelope, metrics
from cvtdesign.core.uncertainty import Spread, checked_by_sampling, intervals, orderings, sampled_figures, spread
from cvtdesign.design.study_file import on_study_envelope
from cvtdesign.io.variant import resolve

SAMPLES = 128      # draws of every input that check each first-order interval and pair the two designs (as compare's)
OWN_PRELOAD = "preload of the design, as built"     # one key for both designs' own preloads (_one_preload)
FIGURES = ("max_abs_alpha_deg", "rms_alpha_deg", "min_efficiency", "max_loss_no_output_W")


def layout_at(problem, design: dict, name: str):
    """The layout of the study's base variant at `design` ({variable: SI value}), on the study's envelope
    where it sets one."""
    layout = resolve(problem.vspec, str(problem.base_file), overrides=problem.fixed | design)
    return dataclasses.replace(on_study_envelope(problem.spec, layout, str(problem.study_file)), name=name)


def optimum_intervals(problem, design: dict) -> dict:
    """{'base': figures, 'optimum': figures, 'orderings': [...], 'orderings_one_preload': [...]}: each design's
    FIGURES with '<figure>_interval', '_budget' and '_interval_method', under the study's effects, each named as
    its variant file is (so compare draws the same samples of its own preload), and for each figure whether the
    optimum is resolved from the base design (core.uncertainty.orderings; 'better' and 'worse' are 'base' or
    'optimum')."""
    base = dict(zip(problem.names, problem.base_values.tolist()))
    rows, spreads, drawn = [], [], []
    names = {"base": problem.vspec.name, "optimum": f"{problem.vspec.name}_{problem.spec.name}"}  # as written
    for role, at in (("base", base), ("optimum", design)):
        model = uncertain_model(layout_at(problem, at, names[role]), effects=problem.spec.effects)
        res = envelope(model)
        s = spread(model, res)
        row = {"name": names[role], "role": role} | {k: v for k, v in metrics(model, res).items() if k in FIGURES}
        drawn.append([{k: v for k, v in d.items() if k in FIGURES} for d in sampled_figures(model, SAMPLES)]
                     if s is not None else None)
        row |= intervals(s, row)
        rows.append(row | (checked_by_sampling(row, drawn[-1]) if drawn[-1] else {})
                    | {"calibration": basis.fields(model.layout)["calibration"]})
        spreads.append(s)
    role = {r["name"]: r["role"] for r in rows}
    ranked = [o | {"better": role[o["better"]], "worse": role[o["worse"]]} for o in orderings(rows, spreads, drawn)
              if o["figure"] in FIGURES]
    same = [o | {"better": role[o["better"]], "worse": role[o["worse"]]}
            for o in orderings(rows, [_one_preload(x) for x in spreads]) if o["figure"] in FIGURES]
    return {"base": rows[0], "optimum": rows[1], "orderings": ranked, "orderings_one_preload": same}


def _one_preload(s: Spread | None) -> Spread | None:
    """The spread with the design's own preload as one quantity shared by both designs (the question 'is the
    optimum better at the same preload as the base?'), the rest as it is."""
    if s is None:
        return None
    own = {k for k in s.std if k.startswith("preload of ")}
    rename = {k: OWN_PRELOAD for k in own}
    grads = {f: {rename.get(k, k): v for k, v in g.items()} for f, g in s.gradients.items()}
    return Spread(grads, {rename.get(k, k): v for k, v in s.std.items()},
                  {rename.get(k, k): v for k, v in s.labels.items()}, {rename.get(k, k): v for k, v in s.assumed.items()})
