"""What `cvtdesign diagnose` prints and reports, in the engineer's words: the answer first, with units; then
where the gap was, as a picture; then the candidates, named in words; then the fits; the statistics last,
each term defined. Every number comes from the Report once, so the terminal, the HTML report and the JSON
agree; a share of the gap is always written as a percentage of the base model's structured gap."""
from __future__ import annotations

import math
import re

import numpy as np

from cvtdesign.core.effects import EFFECTS
from cvtdesign.core.status import STATUS
from cvtdesign.diagnosis.diagnose import Report
from cvtdesign.diagnosis.diagnose.explain import FORM_WORDS
from cvtdesign.diagnosis.diagnose.spatial import AUTO_Z
from cvtdesign.diagnosis.diagnose.verdict import GAP, RESIDUE
from cvtdesign.io.report import Note, Table
from cvtdesign.io.units import degrees, engineering, number

CHANNEL_WORDS = {"alpha": "α", "tau_par": "τ∥", "axis": "γ_axis"}
CHANNEL_KIND = {"alpha": "deg", "tau_par": "torque", "axis": "deg"}
GLOSSARY = [
    "gap: the part of the residual (measured − model) that neighbouring operating points share; noise has "
    "none. Its size is the RMS of that shared part, in the channel's unit.",
    "share of the gap: how much of the base model's gap a model removes, 1 − √(P_after/P_before), with P the "
    "mean product of neighbouring points' held-out residuals over the channels, each in units of its noise.",
    "held out: each operating point predicted by the model fitted without it (5-fold cross-validation by "
    "operating point), so no point scores its own fit.",
    f"a reading's noise: the scatter of one row of data about the truth, as estimated from the data (source "
    f"above). What an effect leaves of the gap stops its name only beyond {RESIDUE:g}× it; without an effect, a "
    f"gap beyond {GAP:g}× it is a gap (docs/diagnosis.md).",
    "structure z: how surely the residuals are smoother than noise (their correlation between neighbouring "
    "points, in standard errors; about 0 ± 1 without a gap). It grows with the amount of data for the same "
    "gap, so it is information, not the verdict's gate.",
    "p: the chance that a candidate's held-out gain over the current model is luck (one-sided Wilcoxon "
    "signed-rank test over the operating points).",
    "ΔBIC per point: the change of the Bayesian information criterion of the full fits, per operating "
    "point; negative favours the candidate.",
    "mean z²: the mean squared held-out residual in units of the noise; 1 for a model that fits to the noise.",
    "determined: whether the data pin a parameter down (its ±1σ below the size of its value).",
]


def report_blocks(rep: Report, figures: list = ()) -> list:
    """The report's blocks in reading order; `figures` (HTML only) go with the picture of the gap."""
    return (answer_blocks(rep) + where_blocks(rep) + list(figures) + [candidates_table(rep)]
            + [Note(f"{r['effect']}: {effect_words(r['effect'])}") for r in rep.ranking] + fit_blocks(rep)
            + statistics_blocks(rep) + [Note(f"({rep.seconds:.1f} s)")])


def effect_words(effect: str) -> str:
    """An effect in words: the first clause of its description (core.effects), at most about 90 characters."""
    text = re.split(r" \(", EFFECTS[effect].doc)[0].rstrip(".")
    if len(text) > 90:
        text = text[:text.rfind(" ", 0, 88)] + " …"
    return text


def param_kind(name: str) -> str:
    """The kind (units.KINDS) of an effect parameter 'effect.param' (core.effects EFFECTS[...].params)."""
    effect, param = name.split(".", 1)
    return EFFECTS[effect].params[param].kind


def quantity(value: float, channel: str, digits: int = 2) -> str:
    """A residual or noise of a channel in its unit: 0.031°, 0.0052 N·m."""
    return degrees(value, digits) if CHANNEL_KIND[channel] == "deg" else engineering(value, "torque", digits)


def fitted(params: dict, effect: str) -> str:
    """The parameters of `effect` in a fit, in their units, each to the precision its ±1σ gives:
    'offset = -0.800° ± 0.011°'; marked where the fit ended on a bound (`bound_mark`) or did not determine it."""
    return ", ".join(f"{n.split('.')[1]} = {value_pm(p['value'], p['std'], param_kind(n))}"
                     + (bound_mark(p) or ("" if p["identifiable"] else " (not determined)"))
                     for n, p in params.items() if n.split(".")[0] == effect)


def bound_mark(p: dict) -> str:
    """' (AT ITS UPPER BOUND: …)' for a fitted parameter that ended on a bound (fitting.ends_at), else ''."""
    bound = p.get("at_bound")
    return f" (AT ITS {bound.upper()} BOUND: the bound's value, not the data's)" if bound else ""


def value_pm(value: float, std: float, kind: str) -> str:
    """'value ± std' in the kind's engineering unit, the value given to the digits its ±1σ resolves (std to
    two significant digits)."""
    if not (std is not None and math.isfinite(std) and std > 0 and value):
        return f"{engineering(value, kind, 3)} ± {engineering(std, kind, 2)}"
    digits = max(3, int(math.floor(math.log10(abs(value)))) - int(math.floor(math.log10(std))) + 2)
    return f"{engineering(value, kind, min(digits, 8))} ± {engineering(std, kind, 2)}"


def answer_blocks(rep: Report) -> list:
    """The answer in one or two sentences with units, then what the test's order and outliers say."""
    h, n = rep.how_far, rep.noise
    if rep.verdict == "none":
        text = (f"No gap beyond the noise: the base model ({' + '.join(rep.base) or 'ideal CVT'}) fits the data to "
                f"{degrees(h['heldout_rms_alpha_deg'][0], 3)} RMS in α (held out), against "
                f"{degrees(n['alpha']['rms'], 2)} of noise in a reading; no effect needs adding.")
    elif rep.verdict == "unexplained":
        text = _unexplained(rep)
    else:
        named = rep.shares[0]
        text = (f"Mostly {rep.verdict.replace('_', ' ')}: {fitted(rep.final_fit, rep.verdict)}. Adding it removes "
                f"{named['share']:.0%} of the gap" + "".join(f", and {s['effect'].replace('_', ' ')} a further "
                                                             f"{s['share']:.0%}" for s in rep.shares[1:])
                + f" (held-out RMS α {degrees(h['heldout_rms_alpha_deg'][0], 3)} → "
                  f"{degrees(h['heldout_rms_alpha_deg'][1], 3)}); " + _residue(rep) + ".")
    blocks = [Note(text, "bold")] + _sequence_notes(rep)
    if rep.outliers:
        blocks.append(Note(f"{len(rep.outliers)} row{'s' if len(rep.outliers) > 1 else ''} left out as gross "
                           "outliers (off the model and their neighbours): " + "; ".join(
                               f"line {o['line']}: {o['what']}, {o['sigmas']:.0f}σ" for o in rep.outliers), "warn"))
    return blocks + _failed_note(rep)


def _residue(rep: Report) -> str:
    """What remains of the gap after the named effects, in the channel's unit against a reading's noise."""
    g, at = rep.gap["channels"], rep.how_far["residue_largest_at"]
    real = [c for c in g if g[c]["after"] > 0 and g[c]["structure_z_after"] > AUTO_Z]
    if not real:
        return f"nothing smoother than the noise remains ({degrees(g['alpha']['noise'], 2)} in α for a reading)"
    worst = max(real, key=lambda c: g[c]["after"] / g[c]["noise"])
    where = (f", largest near γ = {degrees(at['gamma_deg'], 2)}, τ⊥ = {at['load_Nm']:+.2f} N·m"
             if worst == "alpha" and at else "")
    return (f"a residue of {quantity(g[worst]['after'], worst)} remains in {CHANNEL_WORDS[worst]}{where}, against "
            f"{quantity(g[worst]['noise'], worst)} of noise in a reading")


def _unexplained(rep: Report) -> str:
    """The answer when no effect of the vocabulary explains the gap: its size and where, what explains part
    of it, and along what it lies."""
    g, n = rep.gap["channels"], rep.noise
    unsteady = [k for k, s in rep.sequence.items() if s and s["found"]]
    if unsteady and not rep.gap["structured"]:
        return ("Unexplained: the readings " + " and ".join({"direction": "depend on the direction γ was approached",
                                                             "drift": "drift over the test"}[k] for k in unsteady)
                + " (below), which no steady-state model of the vocabulary has.")
    worst = max(g, key=lambda c: g[c]["before"] / g[c]["noise"] if g[c]["noise"] else 0.0)
    text = (f"Unexplained: no effect of the vocabulary removes the gap. The base model misses {CHANNEL_WORDS[worst]} "
            f"by {quantity(g[worst]['before'], worst)} (RMS of the gap, {g[worst]['before'] / n[worst]['rms']:.1f}× "
            "a reading's noise)")
    regs = rep.gap["regions"]
    if regs:
        r = regs[0]
        text += (f", most at γ {_span(r['gamma_deg'], '°', '.0f')}, τ⊥ {_span(r['load_Nm'], ' N·m', '+.2f')} "
                 f"({degrees(r['mean_residual_deg'], 2)} in α)")
    text += "."
    if rep.shares:
        text += " Partly: " + ", ".join(f"{s['effect'].replace('_', ' ')} explains {max(s['share'], 0):.0%}"
                                        for s in rep.shares) + " of it."
    f = rep.form
    if f["lies_along"]:
        text += (f" What remains follows {FORM_WORDS[f['lies_along']]} ({f['size'][f['lies_along']]:.1f}× a reading's "
                 "noise between its lowest and highest values).")
    return text


def _sequence_notes(rep: Report) -> list:
    d, drift = rep.sequence["direction"], rep.sequence["drift"]
    out = []
    if d and d["found"]:
        out.append(Note(f"The readings depend on the direction γ was approached: approached from below, α reads "
                        f"{d['mean_difference']['alpha']:+.3f}° against from above (RMS {degrees(d['rms_difference']['alpha'], 2)}"
                        f" over the {d['points']} points measured both ways, {d['in_reading_noise']:.0f}× a reading's "
                        "noise): backlash or friction in the steering. The two directions are kept apart.", "warn"))
    if drift and drift["found"]:
        moved = [f"{k} {engineering(drift['early_fit'][k]['value'], param_kind(k), 3)} → "
                 f"{engineering(drift['late_fit'][k]['value'], param_kind(k), 3)}" for k in drift["early_fit"]]
        out.append(Note("The readings drift over the test: fitted on the first half of the rows, then on the second, "
                        + ", ".join(moved) + f" (the predictions move by {degrees(drift['prediction_change']['alpha'], 2)}"
                        f" RMS in α, {drift['in_reading_noise']:.1f}× a reading's noise).", "warn"))
    return out


def _failed_note(rep: Report) -> list:
    failed = rep.base_failed
    if not failed["points"]:
        return []
    kinds = [f"{k.replace('_', ' ')} {failed[k]}" + (f" ({', '.join(failed[k + '_at'])})" if failed.get(k + "_at") else "")
             for k in STATUS[1:] if failed[k]]
    where = ", ".join(f"({degrees(p['gamma_cmd_deg'], 3)}, {p['tau_perp_Nm']:+.2f} N·m)" for p in failed["at"][:4])
    return [Note(f"the base model has no physical solution at {failed['points']} of {rep.operating_points} operating "
                 f"points ({'; '.join(kinds)}), e.g. (γ, τ⊥) = {where}{', …' if failed['points'] > 4 else ''}: left out "
                 "of the gap, its regions and the map", "bad")]


def where_blocks(rep: Report) -> list:
    """Where the gap was: the base model's α residual as a picture (mean per cell of γ × τ⊥), the regions
    where it stands out, in words, and by motor speed."""
    data, base = rep.evidence.data, rep.evidence.base
    r = data.rows
    res = np.where(base.fit.ok, r["alpha_deg"].to_numpy() - base.fit.pred["alpha"], np.nan)
    blocks = [gap_picture(r["gamma_cmd_deg"].to_numpy(), r["tau_perp"].to_numpy(), res)]
    for k, reg in enumerate(rep.gap["regions"][:6]):
        blocks.append(Note(f"R{k + 1}: γ {_span(reg['gamma_deg'], '°', '.0f')}, τ⊥ {_span(reg['load_Nm'], ' N·m', '+.2f')} "
                           f"({reg['points']} points): α "
                           f"{degrees(abs(reg['mean_residual_deg']), 2)} "
                           f"{'above' if reg['mean_residual_deg'] > 0 else 'below'} the base model"))
    if rep.by_speed:
        blocks.append(Note("by motor speed: " + "; ".join(
            f"ω1 = {engineering(b['omega_1'], 'speed', 3)}: RMS α residual {degrees(b['rms_residual_deg'][0])} → "
            f"{degrees(b['rms_residual_deg'][1])}" for b in rep.by_speed)))
    return blocks


def _span(lo_hi: list, unit: str, fmt: str) -> str:
    """'20°..70°', or '80°' when both ends are one value."""
    a, b = (format(v, fmt) for v in lo_hi)
    return f"{a}{unit}" if a == b else f"{a}..{b}{unit}"


def gap_picture(gamma: np.ndarray, load: np.ndarray, resid: np.ndarray, ng: int = 9, nt: int = 6) -> Table:
    """The α residual [deg] as a table over γ (rows) × τ⊥ (columns): its mean in each cell of at most ng × nt
    equal bins of the data's own ranges ('·' where no point)."""
    ge = _edges(gamma, ng)
    te = _edges(load, nt)
    gi = np.clip(np.searchsorted(ge, gamma, side="right") - 1, 0, len(ge) - 2)
    ti = np.clip(np.searchsorted(te, load, side="right") - 1, 0, len(te) - 2)
    digits = 2 if np.nanmax(np.abs(resid), initial=0) < 1 else 1
    t = Table("where the gap was: the base model's α residual (measured − model) [°], mean over the points of "
              "each cell of γ (rows) × τ⊥ [N·m] (columns)",
              ["γ"] + [f"{te[j]:+.2f}..{te[j + 1]:+.2f}" for j in range(len(te) - 1)])
    for i in range(len(ge) - 1):
        cells = []
        for j in range(len(te) - 1):
            v = resid[(gi == i) & (ti == j) & np.isfinite(resid)]
            cells.append(f"{np.mean(v):+.{digits}f}" if v.size else "·")
        t.add(f"{ge[i]:.0f}°..{ge[i + 1]:.0f}°", *cells)
    return t


def _edges(v: np.ndarray, n: int) -> np.ndarray:
    """Bin edges: the distinct values' own levels when there are at most n of them, else n equal bins."""
    u = np.unique(np.round(v, 6))
    lo, hi = float(np.min(v)), float(np.max(v))
    if hi - lo < 1e-9:
        return np.array([lo - 0.5, hi + 0.5])
    if len(u) <= n:
        mid = (u[1:] + u[:-1]) / 2
        return np.r_[lo - 1e-9, mid, hi + 1e-9]
    return np.linspace(lo, hi + 1e-9 * max(1.0, abs(hi)), n + 1)


def candidates_table(rep: Report) -> Table:
    """The candidates, each added alone to the base model: its share of the gap, the held-out errors
    before → after, its fitted parameters, and accepted or why not (what each is follows, in words)."""
    t = Table("candidates, each added alone to the base model (held out)",
              ["effect", "share of the gap", "RMS α before → after", "RMS efficiency before → after", "fitted",
               "accepted"])
    for r in rep.ranking:
        t.add(r["effect"], f"{max(r['share'], 0):.0%}",
              f"{degrees(r['heldout_rms_before'], 3)} → {degrees(r['heldout_rms_after'], 3)}",
              f"{number(r['heldout_rms_efficiency_before'], 3)} → {number(r['heldout_rms_efficiency_after'], 3)}",
              fitted(r["params"], r["effect"]), "yes" if r["accepted"] else f"no: {r['not_accepted'] or 'a later round'}",
              style="good" if r["accepted"] else "")
    return t


def fit_blocks(rep: Report) -> list:
    """The fitted parameters of the base model, and of the diagnosed model when it differs."""
    out = []
    for title, params in ((f"base model fit: {' + '.join(rep.base) or 'ideal CVT'}", rep.base_fit),
                          (f"diagnosed model fit: {' + '.join(rep.base + rep.accepted)}", rep.final_fit)):
        if not params or (params is rep.final_fit and not rep.accepted):
            continue
        t = Table(title, ["parameter", "value", "±1σ", "determined"])
        for name, p in params.items():
            good = p["identifiable"] and not p.get("at_bound")
            t.add(name, engineering(p["value"], param_kind(name)), engineering(p["std"], param_kind(name), 2),
                  f"no: at its {p['at_bound']} bound" if p.get("at_bound") else "yes" if good else "no",
                  style="" if good else "bad")
        out.append(t)
    return out


def statistics_blocks(rep: Report) -> list:
    """The statistics, for reference (the verdict rests on the sizes above), each term defined."""
    n = rep.noise
    blocks = [Note("Statistics, for reference: the verdict rests on the sizes above (docs/diagnosis.md)", "bold"),
              Note(f"{rep.rows} rows, {rep.operating_points} operating points"
                   + (f", {sum(rep.dropped_rows.values())} bad rows dropped ({rep.dropped_rows})"
                      if sum(rep.dropped_rows.values()) else "")
                   + f"; a reading's noise ({n['source']}): " + ", ".join(
                       f"{CHANNEL_WORDS[c]} {quantity(n[c]['rms'], c)}" for c in CHANNEL_WORDS if c in n))]
    g = Table("the gap per channel (held out)", ["channel", "gap before → after", "a reading's noise",
                                                 "structure z before → after"])
    for c, x in rep.gap["channels"].items():
        g.add(CHANNEL_WORDS[c], f"{quantity(x['before'], c)} → {quantity(x['after'], c)}", quantity(x["noise"], c),
              f"{x['structure_z_before']:.1f} → {x['structure_z_after']:.1f}")
    s = Table("the candidates' tests (first round)", ["effect", "p", "ΔBIC per point", "mean z² before → after",
                                                       "no physical solution at"])
    for r in rep.ranking:
        s.add(r["effect"], _p(r["p_value"]), f"{r['bic_change_per_point']:+.3g}",
              f"{number(r['heldout_msz_before'], 3)} → {number(r['heldout_msz_after'], 3)}", f"{r['failed_fraction']:.0%}")
    blocks += [g, s] + [Note(f"confounded: {c['effects'][0]} and {c['effects'][1]} change the predictions alike "
                             f"(cosine {c['cosine']:.2f}); to separate them: {c['separate_by']}", "warn")
                        for c in rep.confounded]
    drift = rep.sequence["drift"]
    if drift and not drift["testable"]:
        blocks.append(Note(f"drift over the test: not testable, {drift['why_not']}"))
    blocks += [Note(f"remaining gap along {FORM_WORDS[v]}: p = {_p(rep.form['p'][v])}, "
                    f"{rep.form['size'][v]:.2f}× a reading's noise")
               for v in [rep.form["lies_along"]] if v]
    return blocks + [Note("terms: " + " ".join(f"({k + 1}) {d}" for k, d in enumerate(GLOSSARY)))]


def _p(p: float) -> str:
    """A p-value as text; below 1e-10 as '< 1e-10' (a smaller one says nothing more)."""
    if p is None or not math.isfinite(p):
        return "—"
    return "< 1e-10" if p < 1e-10 else f"{p:.1e}" if p < 0.01 else f"{p:.2f}"
