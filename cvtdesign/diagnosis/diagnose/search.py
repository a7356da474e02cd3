"""Which effect: each candidate added in turn and refitted, scored held out (crossval), the best significant
one accepted and the search repeated (greedy), so two effects can be found; and the verdict."""
from __future__ import annotations

import numpy as np

from cvtdesign.diagnosis.diagnose.crossval import Score, compare, gap_shrink, score
from cvtdesign.diagnosis.diagnose.fitting import Fit
from cvtdesign.diagnosis.diagnose.predictor import CHANNELS, Models, Predictor, channels
from cvtdesign.diagnosis.diagnose.spatial import AUTO_Z
from cvtdesign.diagnosis.measured import Measured

P_ACCEPT = 0.01        # family-wise significance of accepting an effect (Bonferroni over candidates)
MIN_GAIN = 0.05        # and at least this relative drop of the held-out mean squared z
MAX_ADDED = 2          # greedy rounds: at most two effects are accepted (each round refits every candidate)
SHRINK_MIN = 0.8       # an effect is named only if the accepted effects remove this much of the gap beyond noise
MAX_FAIL = 0.05        # a candidate that fails (gross slip, lost contact) at more of the points is not accepted


def _x0(P: Predictor, prev: Fit | None):
    """Start at the previous accepted fit's values for the parameters it had, defaults for the new ones."""
    x0 = P.defaults.copy()
    if prev is not None:
        for n, v in zip(prev.names, prev.theta):
            if n in P.names:
                x0[P.names.index(n)] = v
    return x0


def signature(base: Score, cand: Score, noise) -> np.ndarray:
    """A candidate's fitted change of the predictions (all three channels, z units, axis even if not measured)."""
    out = []
    for c in CHANNELS:
        s = noise.get(c, noise["alpha"])
        out.append((cand.fit.pred[c] - base.fit.pred[c]) / s)
    return np.nan_to_num(np.array(out))


def search(models: Models, data: Measured, noise: dict, fold, base: Score, candidates, tick) -> tuple:
    """Greedy forward search: each remaining candidate added to the current model and scored held out; the
    best one is accepted when its held-out gain is significant (Wilcoxon p below P_ACCEPT/candidates), above
    MIN_GAIN, lowers the BIC, the candidate fails at no more than MAX_FAIL of the points (where the rig
    measured a steady state), and no channel gets clearly worse (worsens_a_channel). Returns (accepted
    effects, rounds, the final score, the score after each accepted effect)."""
    nch = len(channels(data))
    current, accepted, rounds, steps = base, [], [], []
    remaining = list(candidates)
    while remaining and len(accepted) < MAX_ADDED:
        rows = []
        for e in remaining:
            P = models.get(current.effects + (e,))
            sc = score(P, data, noise, fold, x0=_x0(P, current.fit))
            c = compare(current, sc, nch, data)
            rows.append({"effect": e, "score": sc, "cmp": c, "significant": bool(
                c.p < P_ACCEPT / len(remaining) and c.gain > MIN_GAIN and c.dbic < 0 and sc.failed <= MAX_FAIL
                and not worsens_a_channel(current, sc))})
            tick(f"round {len(rounds) + 1}: {e}")
        rows.sort(key=lambda r: (not r["significant"], -r["cmp"].gain))
        rounds.append(rows)
        if not rows[0]["significant"]:
            break
        accepted.append(rows[0]["effect"])
        current = rows[0]["score"]
        steps.append(current)
        remaining.remove(rows[0]["effect"])
    return accepted, rounds, current, steps


def worsens_a_channel(before: Score, after: Score, factor: float = 2.0) -> bool:
    """Whether `after` fits some channel clearly worse held out than `before`: its mean squared z there more
    than `factor` times before and above `factor` (noise is 1), on the points both predict. A gain in one
    channel bought with another is no explanation: a 1° offset of the axis encoder alone (outside the
    vocabulary) made steering_offset "accepted" on the axis while α got 10× worse."""
    both = before.ok & after.ok
    if not both.any():
        return False
    msz_before, msz_after = (np.mean(s.z[:, both] ** 2, axis=1) for s in (before, after))
    return bool(np.any((msz_after > factor * msz_before) & (msz_after > factor)))


def verdict(data: Measured, accepted, base: Score, steps, structured_after: float, nch: int,
            form_structured: bool) -> tuple[str, list]:
    """The verdict and the partial explanation. An effect is named only when the accepted effects leave no
    structured gap: the spatial structure z of the final residuals is ≤ AUTO_Z, the model-form checks find
    no variable the residual depends on (form_checks), and they remove at least SHRINK_MIN of the
    structured gap (gap_shrink, held out) unless what remains is within 3 standard errors of none.
    Otherwise a structured gap remains: `unexplained`, with each accepted effect's cumulative share of the
    gap (`partial`). Without accepted effects: `unexplained` if the base residual is spatially structured in
    any channel (structured_after, the base being the final model), else `none` (the gap is noise). The form
    checks only stop a name: alone, their nominal p-values proved too optimistic on null data to call a gap."""
    if not accepted:
        return ("unexplained" if structured_after > AUTO_Z else "none"), []
    c = compare(base, steps[-1], nch, data)
    remains = c.power[1] > 3 * c.power_se
    if structured_after <= AUTO_Z and not form_structured and (gap_shrink(c) >= SHRINK_MIN or not remains):
        return accepted[0], []
    return "unexplained", [{"effect": e, "shrink": gap_shrink(compare(base, st, nch, data))}
                           for e, st in zip(accepted, steps)]
