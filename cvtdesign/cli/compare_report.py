"""`cvtdesign compare --report`: the comparison as a review reads it. It opens with a summary in plain words
(the answer, then how sure it is), then the figure, then the table with its notes, and it ends with a
glossary of every figure and column."""
from __future__ import annotations

from cvtdesign.core.contact.laws import LAWS
from cvtdesign.io.report import Glossary, Heading, Summary, png_figure

# what each figure of compare's table means (cli.compare.COLUMNS, by key): every row the table shows is here
MEANINGS = {
    "contact_law": None,    # law_meaning(): every law of LAWS, when the glossary is made
    "calibration": "where the contacts' creep compliance comes from: the materials library's calibration, the "
                   "variant's own fitted constants or factors, or THEORY ONLY (uncalibrated: on Kim's CVT the "
                   "theory alone is 3.1–3.6× stiffer than measured)",
    "ok": "how many of the envelope's operating points the physics holds at, shown when under half",
    "max_abs_alpha_deg": "the largest slip angle |α| over the envelope's ok points: how far the sphere's axis is "
                         "from the commanded one, in degrees (0 for the ideal CVT)",
    "rms_alpha_deg": "the root mean square of α over the envelope's ok points, in degrees",
    "max_abs_alpha_steering_deg": "the largest |γ_axis − γ_cmd|: the part of α the steering rollers cause, their "
                                  "lateral creep turning the axis away from where the forks point",
    "max_abs_alpha_drive_deg": "the largest |α − (γ_axis − γ_cmd)|: the part of α the drive rollers' creep causes",
    "ratio_error_pct_at_max_load": "Brokowski's speed-ratio error (his eq 23: (requested − achieved)/requested) "
                                   "at the envelope's largest load, for ratios 0.4 to 2.5, in percent",
    "min_efficiency": "the smallest P_out/P_in over the points that deliver power (|γ| ≥ 5°, |τ⊥| ≥ 25 % of the "
                      "largest load), as a fraction (1: no loss)",
    "max_loss_no_output_W": "the largest power lost where none is delivered (zero load, γ = 0, or power entering "
                            "both shafts), in watts: there an efficiency means nothing",
    "max_traction_utilisation": "the largest |F|/(μN) at any contact: the share of the friction available that a "
                                "contact uses (1: it slides grossly)",
    "max_hertz_pressure_MPa": "the largest Hertz peak pressure at any contact, in MPa, marked when over the "
                              "material's allowable pressure",
    "max_steering_torque_Nm": "the steering motor's largest torque while the contacts roll, through the linkage "
                              "(each fork's share: its contact's lateral force times its lever, spin moment and "
                              "rolling resistance about the fork axis), in N·m",
    "max_standstill_steering_torque_Nm": "the steering motor's torque to resteer with the sphere at rest: every "
                                         "fork's patch sliding (pivoting about its normal, μNℓ, and dragged across "
                                         "the roller where the fork axis misses the contact), at the envelope's "
                                         "largest normal forces, in N·m",
    "life_h": "with --duty: the hours to the first limit of the first contact over the duty cycle (temperature, "
              "wear or fatigue; docs/life.md), with that limit and contact; `cvtdesign life` gives the intervals",
}
FIGURE = ("Figure 1", "compare's figure: per quantity a row of panels against the commanded γ: the slip angle α, "
          "its steering part γ_axis − γ_cmd, its drive part and the efficiency P_out/P_in, at the loads τ⊥ = "
          "±0.5 and ±1 N·m (line style and marker by load), every panel of a row on one scale, the ideal CVT as "
          "the black line (α = 0, efficiency 1); up to three variants overlaid (negative and positive loads in two "
          "columns), more in a column each. The last row maps each variant's efficiency over γ × τ⊥ on one colour "
          "scale: hatched where no power enters (τ⊥ = 0), marked where a point left the physics. Each variant "
          "keeps its colour from run to run (Kim's existing CVT blue, the ideal CVT black).")
TERMS = [
    ("γ (commanded)", "the steering command: the angle of the sphere's commanded axis; the ideal ratio is "
                      "ω2/ω1 = k · tan γ"),
    ("τ⊥ (load)", "the load torque perpendicular to the commanded axis, in N·m; the envelope runs over γ × τ⊥"),
    ("α (slip angle)", "the angle between the sphere's actual and commanded axes, in degrees"),
    ("ideal CVT", "the same layout with rigid contacts: no slip (α = 0) and no loss (efficiency 1)"),
    ("ok point", "an operating point where the model's physics holds; the others (lost contact, gross slip, not "
                 "converged, reversed, two roots) are counted in the notes and left out of every figure"),
]


def basis_text(rows: list[dict]) -> str:
    """What the figures of each column rest on, in plain words, for the summary: the envelope, the contact law
    and each column's calibration, with what the intervals are and which columns are theory only."""
    real = [r for r in rows if not r["name"].startswith("ideal")]
    envelopes = sorted({r["envelope"] for r in rows})
    laws = sorted({r["contact_law"] for r in real})
    text = ("They are the model's figures, not measurements, " +
            (f"all on one envelope ({envelopes[0]})" if len(envelopes) == 1 else "on different envelopes (as written)")
            + (f" and under the {laws[0]} contact law. " if len(laws) == 1 else f" and under different contact "
               f"laws ({', '.join(laws)}; as written). "))
    theory = [r["name"] for r in real if r["calibration"]["uncalibrated"]]
    if theory:
        text += (f"{', '.join(theory)} rest{'s' if len(theory) == 1 else ''} on the contact theory alone "
                 "(THEORY ONLY: on Kim's CVT it is 3.1–3.6× stiffer than measured), so "
                 f"{'its' if len(theory) == 1 else 'their'} slip is likely underestimated. ")
    with_ci = [r["name"] for r in real if r.get("max_abs_alpha_deg_interval")]
    if with_ci:
        text += ("The brackets are 95 % intervals from every uncertain input we know of: the calibration (" +
                 "; ".join(f"{r['name']}: {r['calibration']['text']}" for r in real if r["name"] in with_ci) +
                 "), the preload, each material's modulus, each pair's friction and the contact law's own error; "
                 "each figure's budget (the JSON's <figure>_budget) says which input to measure first.")
    return text


def _ok_text(rows: list[dict]) -> str:
    """'every operating point of every variant is ok (357 each)', or which variants lost how many."""
    lost = [f"{r['name']} {r['points'] - r['ok']} of {r['points']}" for r in rows if r["ok"] < r["points"]]
    if not lost:
        counts = sorted({r["points"] for r in rows})
        return f"every operating point of every variant is ok ({', '.join(map(str, counts))} each)"
    return "points left out of the figures (see the notes): " + "; ".join(lost)


WORDS = {"max_abs_alpha_deg": ("slips less than", "largest slip angle"),
         "min_efficiency": ("keeps a higher worst-case efficiency than", "worst-case efficiency")}


def ordering_sentences(ranked: list[dict], words: dict = WORDS) -> list[str]:
    """One sentence per ordering of the figures in `words` ({figure: (verb, noun)}): stated only where the
    difference is resolved at 95 % (core.uncertainty.orderings), otherwise 'cannot tell' with the input that
    would settle it."""
    out = []
    for o in ranked:
        if o["figure"] not in words:
            continue
        verb, noun = words[o["figure"]]
        if o["resolved"]:
            out.append(f"{o['better']} {verb} {o['worse']} (P = {o['p_better']:.3f})")
        else:
            settle = f"; {o['settle']} would settle it" if o.get("settle") else ""
            out.append(f"cannot tell {o['better']} from {o['worse']} by {noun} at this uncertainty "
                       f"(P = {o['p_better']:.2f} that {o['better']} is better{settle})")
    return out


def summary(rows: list[dict], ranked: list[dict] | None = None) -> Summary:
    """The answer (the orderings of slip and worst efficiency that the intervals resolve, and those they do
    not) and how sure it is (the points the figures cover, their basis)."""
    real = [r for r in rows if not r["name"].startswith("ideal") and r["ok"] and r["max_abs_alpha_deg"] is not None]
    if not real:
        return Summary("No variant has an ok operating point: nothing can be compared.", _ok_text(rows) + ".")
    figures = "; ".join(f"{r['name']} {r['max_abs_alpha_deg']:.3f}°" for r in real)
    answer = f"Largest slip angle: {figures}."
    sentences = ordering_sentences(ranked or [])
    if sentences:
        answer += " " + "; ".join(s[0].upper() + s[1:] for s in sentences) + "."
    sure = (f"How sure: each figure is taken over the variant's whole operating envelope; {_ok_text(rows)}. "
            + basis_text(rows))
    return Summary(answer, sure)


def law_meaning() -> str:
    """What the contact_law row means, with every law of core.contact.laws.LAWS and its title."""
    laws = "; ".join(f"{name}: {law.title}" for name, law in LAWS.items())
    return f"the contact law every column is evaluated under ({laws}; rigid for the ideal CVT)"


def glossary(table_labels: dict) -> Glossary:
    """The figure, the table's rows (table_labels: {key: label} of cli.compare.COLUMNS) and the terms."""
    meanings = {**MEANINGS, "contact_law": law_meaning()}
    return Glossary([FIGURE] + [(label, meanings.get(key, "see docs/comparing.md"))
                                for key, label in table_labels.items()] + TERMS)


def report_blocks(rows: list[dict], blocks: list, figure, table_labels: dict, ranked: list[dict] | None = None) -> list:
    """The report: summary, figure, the printed blocks (table and notes), glossary."""
    caption = "Figure 1. The variants over their envelope: slip angle α, its steering and drive parts and " \
              "efficiency against commanded γ, and each variant's efficiency map (see the glossary)."
    return [summary(rows, ranked), Heading("Figure"), png_figure(figure, caption), Heading("Table"), *blocks,
            glossary(table_labels)]
