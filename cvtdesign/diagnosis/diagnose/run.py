"""The whole diagnosis of a dataset against a base model, and the fitted model that resteering uses."""
from __future__ import annotations

import time

import numpy as np

from cvtdesign.core.effects import candidates as effect_candidates
from cvtdesign.core.layout import Layout
from cvtdesign.diagnosis.diagnose.crossval import folds, score
from cvtdesign.diagnosis.diagnose.explain import confounded, form_checks
from cvtdesign.diagnosis.diagnose.fitting import Fit, failed_points, fit
from cvtdesign.diagnosis.diagnose.noise import estimate_noise, noise_source, row_noise
from cvtdesign.diagnosis.diagnose.predictor import UNITS, Models, Predictor, channels, residuals, rms, zscores
from cvtdesign.diagnosis.diagnose.report import Evidence, Report, by_speed, how_far, ranking
from cvtdesign.diagnosis.diagnose.search import MAX_ADDED, search, verdict
from cvtdesign.diagnosis.diagnose.spatial import AUTO_Z, autocorrelation_z, regions, structure
from cvtdesign.diagnosis.measured import Measured, merge_points


def fit_model(layout: Layout, data: Measured, effects) -> tuple[Predictor, Fit]:
    """Fit the model with `effects` to the data (noise-weighted): the fitted model of resteering."""
    points = merge_points(data)
    P = Predictor(layout, effects, points)
    return P, fit(P, points, estimate_noise(P, points, data))


def diagnose(layout: Layout, data: Measured, base, candidates=None, progress=None) -> Report:
    """Run the whole diagnosis of `data` against the model with the `base` effects, trying `candidates`
    (default: every other effect of the vocabulary); `progress(done, total, what)` is told of each step."""
    t0 = time.perf_counter()
    base = tuple(base)
    candidates = [e for e in (candidates or effect_candidates(layout.contact_law)) if e not in base]
    raw, data = data, merge_points(data)
    models = Models(layout, data)
    fold = folds(data)
    total, done = 1 + len(candidates) * (1 + MAX_ADDED), [0]

    def tick(what):
        done[0] += 1
        if progress:
            progress(min(done[0], total), total, what)

    P0 = models.get(base)
    noise = estimate_noise(P0, data, raw)
    base_score = score(P0, data, noise, fold)
    tick(f"base {'+'.join(base) or '(none)'}")
    # the base model's gap only where its physics holds: elsewhere its "prediction" is an unconverged or
    # slipping solve's last iterate (a region of 14.1° at a point the model had in gross slip)
    res_fit = {c: np.where(base_score.fit.ok, v, np.nan) for c, v in residuals(data, base_score.fit.pred).items()}
    structured = autocorrelation_z(data, zscores(res_fit, noise)[0])
    regs = regions(data, res_fit["alpha"], noise["alpha"])
    accepted, rounds, final, steps = search(models, data, noise, fold, base_score, candidates, tick)
    if progress:
        progress(total, total, "done")
    z_final = zscores(residuals(data, final.fit.pred), noise)
    structured_after = structure(data, np.where(final.ok, z_final, np.nan))
    nch = len(channels(data))
    form = form_checks(models, data, final, noise)
    name, partial = verdict(data, accepted, base_score, steps, structured_after, nch, form["lies_along"] is not None)
    return Report(
        verdict=name, accepted=accepted, partial=partial, base=list(base), candidates=candidates,
        rows=int(len(raw.rows)), operating_points=int(len(data.rows)), dropped_rows=data.dropped,
        noise={c: {"rms": rms(v), "min": float(np.min(v)), "max": float(np.max(v)), "unit": UNITS[c]}
               for c, v in row_noise(data, noise).items()} | {"source": noise_source(data, raw)},
        base_fit=base_score.fit.params(), final_fit=final.fit.params(),
        base_failed=failed_points(P0, data, base_score.fit),
        gap={"rms_alpha_deg": rms(res_fit["alpha"], base_score.fit.ok),
             "heldout_rms_alpha_deg": base_score.rms_alpha, "rms_efficiency": base_score.rms_efficiency,
             "structure_z": structured, "structured": bool(structured > AUTO_Z),
             "structure_z_after": structured_after, "structured_after": bool(structured_after > AUTO_Z),
             "regions": [r.to_json() for r in regs]},
        ranking=ranking(rounds[0] if rounds else [], data, noise, base_score, accepted),
        rounds=[[{"effect": r["effect"], "heldout_msz": r["cmp"].msz[1], "p_value": r["cmp"].p,
                  "gain": r["cmp"].gain, "failed_fraction": r["score"].failed, "significant": r["significant"]}
                 for r in rd] for rd in rounds],
        how_far=how_far(data, noise, base_score, final, regs, nch),
        form=form,
        by_speed=by_speed(data, res_fit["alpha"], residuals(data, final.pred)["alpha"]),
        confounded=confounded(rounds[0], base_score, noise, data, models) if rounds else [],
        seconds=time.perf_counter() - t0,
        evidence=Evidence(data, base_score, final, noise, regs))
