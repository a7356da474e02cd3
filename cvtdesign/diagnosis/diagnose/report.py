"""The diagnosis's report: what diagnose returns, prints and writes as JSON.

`Report` holds the JSON-ready findings as fields and, apart from them, the `Evidence` they were drawn from
(the dataset's operating points, the base and final models' scores, the noise at each point, the
neighbourhoods and the regions), which the figures use and the JSON leaves out. Every share of the gap in
it is one quantity, the share of the base model's structured gap removed (crossval.gap_shrink), reported as
a fraction everywhere.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from cvtdesign.diagnosis.diagnose.crossval import Score, compare, gap_shrink
from cvtdesign.diagnosis.diagnose.predictor import efficiency_mask, model_efficiency, residuals, rms
from cvtdesign.diagnosis.diagnose.search import Candidate, Search
from cvtdesign.diagnosis.diagnose.spatial import Neighbours, Region, in_regions
from cvtdesign.diagnosis.measured import Measured


@dataclass
class Evidence:
    """What the findings were drawn from: the operating points (replicates merged), the base and the final
    (diagnosed) model's scores, the noise σ of each channel at each point, the points' neighbourhoods and the
    gap's regions."""
    data: Measured
    base: Score
    final: Score
    noise: dict
    neighbours: Neighbours
    regions: list[Region]


@dataclass
class Report:
    """The diagnosis of a dataset (docs/diagnosis.md). Every field but `evidence` is JSON-ready."""
    verdict: str                # an effect's name, 'none' or 'unexplained'
    accepted: list              # the accepted effects, in the order they were accepted
    shares: list                # [{effect, share}]: each accepted effect's own share of the base model's gap
    base: list                  # the base model's effects
    candidates: list            # the effects tried
    rows: int                   # rows read
    operating_points: int       # operating points (replicates merged)
    dropped_rows: dict          # bad rows dropped, by reason (--drop-bad)
    outliers: list              # [{line, what, sigmas}]: gross outliers left out of the diagnosis
    noise: dict                 # per channel {rms, min, max, unit} of a row's noise, and its source
    base_fit: dict              # 'effect.param' -> {value, std, identifiable}, SI
    final_fit: dict             # the same for the diagnosed model
    base_failed: dict           # where the fitted base model has no physical solution
    gap: dict                   # the base model's gap: size, structure per channel, regions
    ranking: list               # the first round's candidates, best first
    rounds: list                # every round of the search
    how_far: dict               # held-out errors before and after, and the share of the gap removed
    form: dict                  # model-form checks of what remains
    sequence: dict              # the direction of approach and the drift over the test
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


def heldout_errors(data: Measured, before: Score, after: Score) -> dict:
    """Held-out RMS α [deg] and efficiency [-] of two models on the points both predict."""
    both = before.ok & after.ok
    eff, effm = data.rows["efficiency"].to_numpy(), efficiency_mask(data) & both
    return {"alpha": [rms(residuals(data, x.pred)["alpha"], both) for x in (before, after)],
            "efficiency": [rms(eff - model_efficiency(data, x.pred), effm) for x in (before, after)]}


def ranking(search: Search, data: Measured, base: Score) -> list:
    """The first round's candidates, best first: held-out RMS α and efficiency before and after (on the
    points where both models predict), the share of the gap it removes, the tests, the fraction of points
    where the candidate fails, its fitted parameters, and why it was not accepted."""
    out = []
    for r in search.rounds[0] if search.rounds else []:
        e = heldout_errors(data, base, r.score)
        out.append({
            "effect": r.effect, "heldout_rms_before": e["alpha"][0], "heldout_rms_after": e["alpha"][1],
            "share": r.share, "heldout_rms_efficiency_before": e["efficiency"][0],
            "heldout_rms_efficiency_after": e["efficiency"][1], "heldout_msz_before": r.cmp.msz[0],
            "heldout_msz_after": r.cmp.msz[1], "p_value": r.cmp.p, "bic_change": r.cmp.dbic,
            "bic_change_per_point": r.cmp.dbic / max(r.cmp.points, 1), "failed_fraction": r.score.failed,
            "params": r.score.fit.params(), "accepted": r.effect in search.accepted, "not_accepted": r.reason})
    return out


def rounds(search: Search) -> list:
    """Every round's candidates: the share each adds, its held-out mean squared z, the tests, why not."""
    def row(r: Candidate) -> dict:
        return {"effect": r.effect, "share": r.share, "heldout_msz": r.cmp.msz[1], "p_value": r.cmp.p,
                "gain": r.cmp.gain, "failed_fraction": r.score.failed, "not_accepted": r.reason}
    return [[row(r) for r in rd] for rd in search.rounds]


def how_far(data: Measured, nb: Neighbours, fits: dict[str, Neighbours], base: Score, final: Score, regs: list[Region],
            nch: int) -> dict:
    """Held-out RMS α and efficiency of the base and the diagnosed model on the points both predict, the
    share of the base model's structured gap removed, and the RMS α in the gap's three largest regions."""
    e = heldout_errors(data, base, final)
    res_b, res_a = residuals(data, base.pred)["alpha"], residuals(data, final.pred)["alpha"]
    in_reg = in_regions(len(data.rows), regs[:3]) & base.ok & final.ok
    return {"heldout_rms_alpha_deg": e["alpha"], "heldout_rms_efficiency": e["efficiency"],
            "shrink": gap_shrink(compare(base, final, nch, nb)) if final is not base else 0.0,
            "region_rms_alpha_deg": [rms(res_b, in_reg), rms(res_a, in_reg)] if in_reg.any() else None,
            "residue_largest_at": largest(data, fits["alpha"], np.where(final.ok, res_a, np.nan))}


def largest(data: Measured, nb: Neighbours, resid: np.ndarray) -> dict | None:
    """Where the smooth part of a residual (its neighbours' local fits) is largest: γ [deg], τ⊥ [N m], and
    its value there [deg]."""
    s = nb.smooth(np.nan_to_num(resid))
    s = np.where(np.isfinite(resid), s, np.nan)
    if not np.isfinite(s).any():
        return None
    k = int(np.nanargmax(np.abs(s)))
    r = data.rows
    return {"gamma_deg": float(r["gamma_cmd_deg"].iat[k]), "load_Nm": float(r["tau_perp"].iat[k]),
            "alpha_deg": float(s[k])}


def by_speed(data: Measured, before, after):
    """The α residual per motor-speed level (only when the speed varies): where in speed the gap lies."""
    if len(data.speed_levels) < 2:
        return []
    sb = data.rows["speed_bin"].to_numpy()
    return [{"omega_1": float(w), "rows": int((sb == k).sum()), "mean_residual_deg": float(np.mean(before[sb == k])),
             "rms_residual_deg": [rms(before, sb == k), rms(after, sb == k)]} for k, w in enumerate(data.speed_levels)]
