"""The diagnosis's report: what diagnose returns, prints and writes as JSON.

`Report` holds the JSON-ready findings as fields and, apart from them, the `Evidence` they were drawn from
(the dataset's operating points, the base and final models' scores, the noise at each point), which the
figures use and the JSON leaves out.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from cvtdesign.diagnosis.diagnose.crossval import Score, compare, gap_shrink, rms_shrink
from cvtdesign.diagnosis.diagnose.noise import efficiency_noise
from cvtdesign.diagnosis.diagnose.predictor import efficiency_mask, model_efficiency, residuals, rms
from cvtdesign.diagnosis.diagnose.spatial import Region, in_regions
from cvtdesign.diagnosis.measured import Measured


@dataclass
class Evidence:
    """What the findings were drawn from: the operating points (replicates merged), the base and the final
    (diagnosed) model's scores, the noise σ of each channel at each point, and the gap's regions."""
    data: Measured
    base: Score
    final: Score
    noise: dict
    regions: list[Region]


@dataclass
class Report:
    """The diagnosis of a dataset (docs/diagnosis.md). Every field but `evidence` is JSON-ready."""
    verdict: str                # an effect's name, 'none' or 'unexplained'
    accepted: list              # the accepted effects, in the order they were accepted
    partial: list               # [{effect, shrink}]: what the accepted effects explain of an unexplained gap
    base: list                  # the base model's effects
    candidates: list            # the effects tried
    rows: int                   # rows read
    operating_points: int       # operating points (replicates merged)
    dropped_rows: dict          # bad rows dropped, by reason (--drop-bad)
    noise: dict                 # per channel {rms, min, max, unit} of a row's noise, and its source
    base_fit: dict              # 'effect.param' -> {value, std, identifiable}, SI
    final_fit: dict             # the same for the diagnosed model
    base_failed: dict           # where the fitted base model has no physical solution
    gap: dict                   # the base model's gap: size, structure, regions
    ranking: list               # the first round's candidates, best first
    rounds: list                # every round of the search
    how_far: dict               # held-out errors before and after, and the shrink
    form: dict                  # model-form checks of what remains
    by_speed: list              # the α residual per motor-speed level
    confounded: list            # pairs of candidates the data cannot tell apart
    seconds: float
    evidence: Evidence = dataclasses.field(repr=False, compare=False)

    def to_json(self) -> dict:
        """The findings as a JSON-ready dict (without the evidence)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "evidence"}

    def calibration(self) -> dict:
        """{effect: {parameter: SI value}} of the diagnosed model's fit: what a design study carries
        (io.fitted reads the same from the JSON's final_fit)."""
        out: dict = {}
        for name, p in self.final_fit.items():
            effect, param = name.split(".", 1)
            out.setdefault(effect, {})[param] = p["value"]
        return out


def heldout_errors(data: Measured, noise: dict, before: Score, after: Score) -> dict:
    """Held-out RMS α [deg] and efficiency [-] of two models on the points both predict, and the fraction of
    each gap beyond its noise floor that `after` removes."""
    both = before.ok & after.ok
    eff, effm = data.rows["efficiency"].to_numpy(), efficiency_mask(data) & both
    ra = [rms(residuals(data, x.pred)["alpha"], both) for x in (before, after)]
    re = [rms(eff - model_efficiency(data, x.pred), effm) for x in (before, after)]
    return {"alpha": ra, "shrink_alpha": rms_shrink(*ra, rms(noise["alpha"], both)),
            "efficiency": re, "shrink_efficiency": rms_shrink(*re, efficiency_noise(data, noise))}


def ranking(first_round, data: Measured, noise: dict, base: Score, accepted) -> list:
    """The first round's candidates, best first: held-out RMS α and efficiency before and after (on the
    points where both models predict), shrink, p-value, ΔBIC, the fraction of points where the candidate
    fails, and its fitted parameters."""
    out = []
    for r in first_round:
        s, c = r["score"], r["cmp"]
        e = heldout_errors(data, noise, base, s)
        out.append({
            "effect": r["effect"], "heldout_rms_before": e["alpha"][0], "heldout_rms_after": e["alpha"][1],
            "shrink": e["shrink_alpha"], "gap_shrink": gap_shrink(c),
            "heldout_rms_efficiency_before": e["efficiency"][0], "heldout_rms_efficiency_after": e["efficiency"][1],
            "shrink_efficiency": e["shrink_efficiency"],
            "heldout_msz_before": c.msz[0], "heldout_msz_after": c.msz[1], "p_value": c.p,
            "bic_change": c.dbic, "failed_fraction": s.failed, "params": s.fit.params(),
            "accepted": r["effect"] in accepted})
    return out


def how_far(data: Measured, noise: dict, base: Score, final: Score, regs: list[Region], nch: int) -> dict:
    """Held-out RMS α and efficiency of the base and the diagnosed model on the points both predict, the
    shrinks (α, efficiency, and over every channel in z units), and the shrink in the gap's largest regions."""
    e = heldout_errors(data, noise, base, final)
    res_b, res_a = residuals(data, base.pred)["alpha"], residuals(data, final.pred)["alpha"]
    in_reg = (in_regions(data, regs[:3]) & base.ok & final.ok) if regs else np.zeros(len(data.rows), bool)
    region = [rms(res_b, in_reg), rms(res_a, in_reg)] if in_reg.any() else None
    return {
        "heldout_rms_alpha_deg": e["alpha"], "shrink_alpha": e["shrink_alpha"],
        "heldout_rms_efficiency": e["efficiency"], "shrink_efficiency": e["shrink_efficiency"],
        "shrink": gap_shrink(compare(base, final, nch, data)) if final is not base else 0.0,
        "region_rms_alpha_deg": region,
        "shrink_region": rms_shrink(*region, rms(noise["alpha"], in_reg)) if region else None,
    }


def by_speed(data: Measured, before, after):
    """The α residual per motor-speed level (only when the speed varies): where in speed the gap lies."""
    if len(data.speed_levels) < 2:
        return []
    sb = data.rows["speed_bin"].to_numpy()
    return [{"omega_1": float(w), "rows": int((sb == k).sum()), "mean_residual_deg": float(np.mean(before[sb == k])),
             "rms_residual_deg": [rms(before, sb == k), rms(after, sb == k)]} for k, w in enumerate(data.speed_levels)]
