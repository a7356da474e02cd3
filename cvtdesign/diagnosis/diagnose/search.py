"""Which effect: each candidate added in turn and refitted, scored held out (crossval); the one that removes
the most of the gap is accepted when it is also significant, and the search repeats (greedy), so two effects
can be found, each accepted only for what it adds."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cvtdesign.diagnosis.diagnose.crossval import Comparison, Score, compare, gap_shrink, score
from cvtdesign.diagnosis.diagnose.fitting import Fit
from cvtdesign.diagnosis.diagnose.predictor import CHANNELS, Models, Predictor, channels
from cvtdesign.diagnosis.diagnose.spatial import Neighbours
from cvtdesign.diagnosis.measured import Measured

P_ACCEPT = 0.01        # family-wise significance of accepting an effect (Bonferroni over candidates)
MIN_GAIN = 0.05        # and at least this relative drop of the held-out mean squared z
MAX_ADDED = 2          # greedy rounds: at most two effects are accepted (each round refits every candidate)
MAX_FAIL = 0.05        # a candidate that fails (gross slip, lost contact) at more of the points is not accepted
MIN_SHARE = 0.1        # a candidate is accepted only if it removes at least this share of the base model's gap


@dataclass
class Candidate:
    """A candidate effect added to the current model in a round of the search."""
    effect: str
    score: Score            # the model with it, fitted and scored held out
    cmp: Comparison         # against the current model
    share: float            # the share of the base model's structured gap it removes on top of the current model
    reason: str             # why it is not accepted ('' if it could be)


@dataclass
class Search:
    """The search's outcome: the accepted effects in order, every round's candidates (best first), the final
    model's score and the score after each accepted effect."""
    accepted: list
    rounds: list            # [[Candidate]]
    final: Score
    steps: list             # [Score]


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


def search(models: Models, data: Measured, nb: Neighbours, noise: dict, fold, base: Score, candidates,
           tick) -> Search:
    """Greedy forward search: each remaining candidate added to the current model, refitted and scored held
    out. The one that removes the largest share of the base model's structured gap (gap_shrink) is accepted
    when it could be (`refusal`: significant, adds at least MIN_SHARE, fails nowhere the rig measured, spoils
    no channel); then the search repeats from the model with it, at most MAX_ADDED times."""
    nch = len(channels(data))
    current, accepted, rounds, steps = base, [], [], []
    remaining = list(candidates)
    while remaining and len(accepted) < MAX_ADDED:
        before = gap_shrink(compare(base, current, nch, nb)) if current is not base else 0.0
        rows = []
        for e in remaining:
            P = models.get(current.effects + (e,))
            sc = score(P, data, noise, fold, x0=_x0(P, current.fit))
            c = compare(current, sc, nch, nb)
            share = gap_shrink(compare(base, sc, nch, nb)) - before
            rows.append(Candidate(e, sc, c, share, refusal(current, sc, c, share, len(remaining))))
            tick(f"round {len(rounds) + 1}: {e}")
        rows.sort(key=lambda r: (bool(r.reason), -r.share))
        rounds.append(rows)
        if rows[0].reason:
            break
        accepted.append(rows[0].effect)
        current = rows[0].score
        steps.append(current)
        remaining.remove(rows[0].effect)
    return Search(accepted, rounds, current, steps)


def refusal(current: Score, sc: Score, c: Comparison, share: float, tried: int) -> str:
    """Why a candidate is not accepted, in words ('' when it can be): its held-out gain must be significant
    (one-sided Wilcoxon p below P_ACCEPT over the `tried` candidates, gain above MIN_GAIN, lower BIC), it must
    remove at least MIN_SHARE of the base model's gap, fail (gross slip, lost contact) at no more than MAX_FAIL
    of the points where the rig measured a steady state, and make no channel clearly worse."""
    if sc.failed > MAX_FAIL:
        return f"no physical solution at {sc.failed:.0%} of the points"
    if worsens_a_channel(current, sc):
        return "fits one channel by spoiling another"
    if share < MIN_SHARE:
        return f"removes only {max(share, 0.0):.0%} of the gap"
    if not (c.p < P_ACCEPT / tried and c.gain > MIN_GAIN and c.dbic < 0):
        return "its gain is not significant (it may be noise)"
    return ""


def worsens_a_channel(before: Score, after: Score, factor: float = 2.0) -> bool:
    """Whether `after` fits some channel clearly worse held out than `before`: its mean squared z there more
    than `factor` times before and above `factor` (noise is 1), on the points both predict. A gain in one
    channel bought with another is no explanation: a 1° offset of the axis encoder alone (outside the
    vocabulary) made the steering-offset effect "accepted" on the axis while α got 10× worse."""
    both = before.ok & after.ok
    if not both.any():
        return False
    msz_before, msz_after = (np.mean(s.z[:, both] ** 2, axis=1) for s in (before, after))
    return bool(np.any((msz_after > factor * msz_before) & (msz_after > factor)))
