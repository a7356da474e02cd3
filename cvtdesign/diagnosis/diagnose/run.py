"""The whole diagnosis of a dataset against a base model, and the fitted model that resteering uses."""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from cvtdesign.core.contact.laws import candidates as effect_candidates
from cvtdesign.core.kinematics import ShaftFrame, shaft_frame
from cvtdesign.core.layout import Layout
from cvtdesign.diagnosis.diagnose.crossval import Score, folds, score
from cvtdesign.diagnosis.diagnose.explain import confounded, form_checks
from cvtdesign.diagnosis.diagnose.fitting import Fit, failed_points, fit
from cvtdesign.diagnosis.diagnose.noise import estimate_noise, held, noise_source, refine, row_noise
from cvtdesign.diagnosis.diagnose.outliers import gross_outliers
from cvtdesign.diagnosis.diagnose.predictor import UNITS, Models, Predictor, Switched, channels, residuals, rms
from cvtdesign.diagnosis.diagnose.report import Evidence, Report, by_speed, how_far, ranking, rounds
from cvtdesign.diagnosis.diagnose.search import MAX_ADDED, Search, search
from cvtdesign.diagnosis.diagnose.sequence import Direction, direction_test, drift_test, split_by_direction
from cvtdesign.diagnosis.diagnose.spatial import Neighbours, local_fits, neighbours, regions
from cvtdesign.diagnosis.diagnose.verdict import GAP, structured_gap, verdict
from cvtdesign.diagnosis.measured import Measured, from_rows, merge_points

EVALUATIONS = 60       # evaluations of the rows per candidate's score (its fit and its folds' fits; about 60 on
                       # Kim's 187 rows): what a diagnosis announces to its model (Switched.expect)


@dataclass
class Prepared:
    """A dataset made ready for the search: its rows (gross outliers left out; split by the direction of
    approach where the readings depend on it), operating points, neighbourhoods, models, first fit of the base
    model and noise."""
    raw: Measured
    points: Measured
    nb: Neighbours          # the points' neighbour graph (spatial structure, regions)
    fits: dict              # channel -> the neighbourhoods of its local fits (noise, outliers)
    models: Models
    prelim: Fit
    noise: dict
    outliers: list
    direction: Direction | None


def fit_model(layout: Layout, data: Measured, effects) -> tuple[Predictor, Fit]:
    """Fit the model with `effects` to the data (noise-weighted): the fitted model of resteering."""
    s = _stage(layout, data, tuple(effects), Switched(layout, effects))
    P = s.models.get(tuple(effects))
    return P, fit(P, s.points, s.noise)


def _stage(layout: Layout, raw: Measured, base: tuple, shared: Switched) -> Prepared:
    """Operating points, neighbourhoods, a first (unweighted) fit of the base model, and the noise."""
    points = merge_points(raw)
    nb = neighbours(points, layout)
    models = Models(layout, points, shared.effects, shared)
    P = models.get(base)
    prelim = fit(P, points, {c: np.ones(P.n) for c in channels(points)})
    fits = local_fits(points, layout, held(points, prelim))
    return Prepared(raw, points, nb, fits, models, prelim, estimate_noise(prelim, points, raw, fits, P), [], None)


def prepare(layout: Layout, frame: ShaftFrame, raw: Measured, base: tuple, shared: Switched | None = None) -> Prepared:
    """Split the operating points by the direction they were approached from when the readings depend on
    it (sequence.py), then leave the gross outliers out (outliers.py). `shared`: the model of the effects the
    diagnosis will try (default: the base's)."""
    shared = shared or Switched(layout, base)
    split, direction, s = split_by_direction(raw), None, None
    if split is not None:
        s = _stage(layout, split, base, shared)
        direction = direction_test(s.points, held(s.points, s.prelim), s.noise)
        s = s if direction is not None and direction.found else None
    s = s or _stage(layout, raw, base, shared)
    found = gross_outliers(s.raw, s.points, held(s.points, s.prelim), s.noise, s.fits, frame)
    if found:
        lines = {o.line for o in found}
        keep = s.raw.rows[~s.raw.rows["line"].isin(lines)]
        again = from_rows(keep, frame, raw.file, raw.dropped)
        if direction is not None and direction.found:
            again = split_by_direction(again) or again
        s = _stage(layout, again, base, shared)
    s.outliers, s.direction = [o.to_json() for o in found], direction
    return s


def diagnose(layout: Layout, data: Measured, base, candidates=None, progress=None) -> Report:
    """Run the whole diagnosis of `data` against the model with the `base` effects, trying `candidates`
    (default: every other effect of the vocabulary); `progress(done, total, what)` is told of each step."""
    t0 = time.perf_counter()
    base = tuple(base)
    candidates = [e for e in (candidates or effect_candidates(layout.contact_law)) if e not in base]
    total, done = 1 + len(candidates) * (1 + MAX_ADDED), [0]

    def tick(what):
        done[0] += 1
        if progress:
            progress(min(done[0], total), total, what)

    shared = Switched(layout, base + tuple(candidates))
    shared.expect(EVALUATIONS * (1 + MAX_ADDED) * len(candidates), len(data.rows))
    s = prepare(layout, shaft_frame(layout), data, base, shared)
    fold = folds(s.points)
    base_score, found = _search(s, s.noise, fold, base, candidates, tick)
    noise, refined = refine(s.points, s.raw, s.fits, s.noise, found.final.fit)
    if refined:            # the first noise held gap the diagnosed model removes: search again with the lower
        done[0], total = 0, total * 2
        base_score, found = _search(s, noise, fold, base, candidates, tick)
    if progress:
        progress(total, total, "done")
    return _report(s, noise, refined, base_score, found, base, candidates, time.perf_counter() - t0)


def _search(s: Prepared, noise: dict, fold, base: tuple, candidates, tick) -> tuple[Score, Search]:
    base_score = score(s.models.get(base), s.points, noise, fold)
    tick(f"base {'+'.join(base) or '(none)'}")
    return base_score, search(s.models, s.points, s.nb, noise, fold, base_score, candidates, tick)


def _report(s: Prepared, noise: dict, refined: bool, base_score: Score, found: Search, base: tuple, candidates,
            seconds: float) -> Report:
    data, nb, final = s.points, s.nb, found.final
    nch = len(channels(data))
    rown = row_noise(data, noise)
    gap = structured_gap(data, nb, noise, rown, base_score, final)
    form = form_checks(s.models, data, final, noise)
    hysteresis = bool(s.direction and s.direction.found)
    drift = None if hysteresis else drift_test(s.models, s.raw, final.fit, rown, data)
    form_size = form["size"][form["lies_along"]] if form["lies_along"] else 0.0
    name, shares = verdict(found, base_score, gap, nb, form_size, hysteresis or drift.found, nch)
    # the base model's gap only where its physics holds: elsewhere its "prediction" is an unconverged or
    # slipping solve's last iterate (a region of 14.1° at a point the model had in gross slip)
    res_fit = held(data, base_score.fit)
    regs = regions(data, nb, res_fit["alpha"], noise["alpha"])
    return Report(
        verdict=name, accepted=found.accepted, shares=shares, base=list(base), candidates=candidates,
        rows=int(len(s.raw.rows)), operating_points=int(len(data.rows)), dropped_rows=data.dropped,
        outliers=s.outliers,
        noise={c: {"rms": rms(v), "min": float(np.min(v)), "max": float(np.max(v)), "unit": UNITS[c]}
               for c, v in rown.items()} | {"source": noise_source(s.raw, refined)},
        base_fit=base_score.fit.params(), final_fit=final.fit.params(),
        base_failed=failed_points(s.models.get(base), data, base_score.fit),
        gap={"rms_alpha_deg": rms(res_fit["alpha"]), "heldout_rms_alpha_deg": base_score.rms_alpha,
             "rms_efficiency": base_score.rms_efficiency, "channels": gap.to_json(),
             "structure_z": max(gap.z_before.values()), "structured": any(gap.large(c, "before", GAP) for c in gap.before),
             "structure_z_after": max(gap.z_after.values()), "structured_after": any(gap.large(c) for c in gap.after),
             "regions": [r.to_json() for r in regs]},
        ranking=ranking(found, data, base_score), rounds=rounds(found),
        how_far=how_far(data, nb, s.fits, base_score, final, regs, nch), form=form,
        sequence={"direction": s.direction.to_json() if s.direction else None,
                  "drift": drift.to_json() if drift else None},
        by_speed=by_speed(data, res_fit["alpha"], residuals(data, final.pred)["alpha"]),
        confounded=confounded(found.rounds[0], base_score, noise, data, s.models) if found.rounds else [],
        seconds=seconds, evidence=Evidence(data, base_score, final, noise, nb, regs))
