"""The verdict, from effect sizes in physical units (docs/diagnosis.md, "The verdict").

The gap of a model is the smooth (structured) part of its held-out residuals: per channel, the RMS that
neighbouring points share (√ of the mean product of neighbours' residuals, spatial.structured_power), in °
for α and the axis angle and N·m for τ∥. Noise has no shared part, so this does not depend on the noise
estimate. The rule:

* an effect is named when the accepted effects remove at least SHRINK_MIN of the base model's structured
  gap (over every channel, in units of each channel's noise; or what remains is within 3 standard errors of
  none) and what remains is small: in every channel at most RESIDUE of one reading's noise, and no
  dependence on a variable of the model-form checks larger than that;
* nothing is accepted, the base model's gap is below GAP of a reading's noise in every channel (and along
  every model-form variable), and the readings depend neither on the direction γ was approached from nor on
  the time (sequence.py): `none` (a gap of 0.6 to 0.9 of a reading, real at z 6 to 8, is no noise: two
  effects outside the vocabulary leave one);
* otherwise `unexplained`, with what each accepted effect explains.

A remaining gap counts only where it is also real: its spatial structure significant (z > AUTO_Z). The
significance is reported, but it is not the gate: it grows like √n for the same residue, so a gate on it
would call a right answer unexplained once a rig collects enough data. The same rig replicated 1, 3 or 10
times gives the same gap in degrees, and so the same verdict.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cvtdesign.diagnosis.diagnose.crossval import Score, compare, gap_shrink
from cvtdesign.diagnosis.diagnose.predictor import UNITS, channels, residuals, rms, zscores
from cvtdesign.diagnosis.diagnose.search import Search
from cvtdesign.diagnosis.diagnose.spatial import AUTO_Z, Neighbours, autocorrelation_z, structured_power
from cvtdesign.diagnosis.measured import Measured

SHRINK_MIN = 0.8       # an effect is named only if the accepted effects remove this share of the structured gap
RESIDUE = 1.0          # and what remains is at most one reading's noise, in every channel
GAP = 0.5              # without an accepted effect, a gap of half a reading's noise is a gap: not `none`


@dataclass
class Gap:
    """A model's structured gap per channel in the channel's unit (held out, on the points both the base
    and the final model predict), its significance, and one reading's noise."""
    before: dict           # channel -> RMS of the base model's structured gap [unit]
    after: dict            # the same for the final model
    z_before: dict         # channel -> spatial structure z of the base model's held-out residuals
    z_after: dict
    noise: dict            # channel -> RMS noise of one reading [unit]

    def large(self, c: str, which: str = "after", limit: float = RESIDUE) -> bool:
        """Whether channel c's gap is real (structure z > AUTO_Z) and larger than `limit` of a reading's noise."""
        size, z = (self.after, self.z_after) if which == "after" else (self.before, self.z_before)
        return bool(z[c] > AUTO_Z and size[c] > limit * self.noise[c])

    def to_json(self) -> dict:
        return {c: {"before": self.before[c], "after": self.after[c], "structure_z_before": self.z_before[c],
                    "structure_z_after": self.z_after[c], "noise": self.noise[c], "unit": UNITS[c]}
                for c in self.before}


def structured_gap(data: Measured, nb: Neighbours, noise: dict, row_noise: dict, base: Score, final: Score) -> Gap:
    """The base and final models' structured gaps (module docstring)."""
    both = base.ok & final.ok
    size, zs = {}, {}
    for which, s in (("before", base), ("after", final)):
        res = residuals(data, s.pred)
        z = zscores(res, noise)
        size[which] = {c: float(np.sqrt(max(structured_power(nb, np.where(both, res[c], np.nan))[0], 0.0)))
                       for c in res}
        zs[which] = {c: autocorrelation_z(nb, np.where(both, z[k], np.nan)) for k, c in enumerate(res)}
    return Gap(size["before"], size["after"], zs["before"], zs["after"],
               {c: rms(row_noise[c]) for c in channels(data)})


def verdict(search: Search, base: Score, gap: Gap, nb: Neighbours, form_size: float, unsteady: bool,
            nch: int) -> tuple[str, list]:
    """(the verdict, each accepted effect's own share of the base model's structured gap): the rule of the
    module docstring. `form_size`: the dependence the model-form checks found, in a reading's noise (0 if
    none); `unsteady`: the readings depend on the direction of approach or drift over the test
    (sequence.py), which no steady-state model has, so the data are never `none` then."""
    shares = effect_shares(search, base, nb, nch)
    if not search.accepted:
        large = any(gap.large(c, "before", GAP) for c in gap.before) or form_size > GAP or unsteady
        return ("unexplained" if large else "none"), []
    c = compare(base, search.final, nch, nb)
    remains = c.power[1] > 3 * c.power_se
    small = not any(gap.large(ch) for ch in gap.after) and form_size <= RESIDUE
    return (search.accepted[0] if small and (gap_shrink(c) >= SHRINK_MIN or not remains) else "unexplained"), shares


def effect_shares(search: Search, base: Score, nb: Neighbours, nch: int) -> list[dict]:
    """Each accepted effect's own share of the base model's structured gap: what the model with it removes
    beyond the model before it (gap_shrink, held out)."""
    out, before = [], 0.0
    for e, st in zip(search.accepted, search.steps):
        now = gap_shrink(compare(base, st, nch, nb))
        out.append({"effect": e, "share": now - before})
        before = now
    return out
