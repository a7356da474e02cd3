"""`cvtdesign optimise`: one study's optimum by multistart IPOPT, its constraints and its variant file."""
from __future__ import annotations

import math
from pathlib import Path

from rich.console import Console

from cvtdesign.cli import optimise_report
from cvtdesign.cli.compare_report import ordering_sentences
from cvtdesign.cli.export import export_steps
from cvtdesign.cli.printing import kind_of, progress_bar, report_text, show
from cvtdesign.core.contact.laws import contact_law
from cvtdesign.design.objectives import objective
from cvtdesign.design.study_file import Study
from cvtdesign.io.output import make_folder, write_files
from cvtdesign.io.report import Note, Table
from cvtdesign.io.units import ENGINEERING, degrees, engineering, number
from cvtdesign.io.variant import load_spec
from cvtdesign.uses.optimum import bounds, optimise_run

# the kind of each constraint family's rows (design.report.constraint_report), and the factor from the
# row's units to SI: the worst-|α| and ε rows are in degrees, Hertz p_max/p_allow, traction and the linkage
# misfit are ratios, normal force in newtons, clearance and envelope radius in metres
# a constraint row's unit (design.report.ROW_UNITS) → the kind it is shown as and its factor to SI
UNIT_KIND = {"deg": ("angle", math.pi / 180), "N": ("force", 1.0), "m": ("length", 1.0), "": ("dimensionless", 1.0)}
# an objective's unit (design.objectives) → how its value is shown
SHOW = {"°": degrees, "W": lambda v: engineering(v, "power"),
        "1/h": lambda v: f"{number(v, 4)} 1/h (life {number(1 / v, 4)} h)" if v else f"{number(v, 4)} 1/h"}


def run(args):
    console = Console(width=120)
    with progress_bar(console, "multistart", lambda sol: f"last: {sol.status}, f = {sol.objective:.5g}",
                      transient=True) as progress:
        result = optimise_run(args.study, args.out, args.starts, progress, calibration=args.calibration)
    loaded, res = result.study, result.details
    variables = design_kinds(loaded, res["design"])
    blocks = result_blocks(res, variables) + law_notes(loaded, res, variables)
    # the optimum's variant file, the JSON and the HTML report: written together, all or nothing
    files = dict(result.files)
    kinds = {p: "variant file" for p in files}
    if files and args.out:
        make_folder(args.out, kind="--out")
    if args.json:
        files[Path(args.json)] = result.to_json()
        kinds[Path(args.json)] = "--json"
    if args.report:
        objective = objective_text(res["objective_kind"], res["objective"]) if res["success"] else ""
        report = optimise_report.report_blocks(res, blocks, variables, objective,
                                               constraint_table(res, variables) if res["success"] else None)
        files[Path(args.report)] = report_text(args, f"cvtdesign optimise: study {res['study']}", report)
        kinds[Path(args.report)] = "--report"
    write_files(files, kind=kinds)
    if res["success"] and args.step:          # the files first, then the table
        export_steps(console, [res["variant_file"]], Path(res["variant_file"]).parent / "step")
    show(console, blocks)
    if args.report:
        console.print(f"report: {args.report}")
    return 0 if res["success"] else 1


def design_kinds(loaded: Study, design: dict) -> dict:
    """{design variable: (kind, lower [SI], upper [SI])} from the study and its base variant: the variable's
    kind as the variant writes the parameter (or, for an expression or a plain number, as its bounds are
    written: a variable declared '30 mm' is a length)."""
    params = load_spec(loaded.base).parameters
    return {n: (kind_of(params.get(n), loaded.spec.design[n].lower, loaded.spec.design[n].upper), lo, hi)
            for n, (lo, hi) in bounds(loaded, design).items()}


def law_notes(loaded: Study, res: dict, variables: dict) -> list:
    """Under a contact law with fitted creep constants (Kim's), the creep does not depend on a roller's radius,
    crown or material: a length that ends on its bound is said to rest on that, not on the physics."""
    law = contact_law(load_spec(loaded.base).contact.law)
    if not (law.fitted and res["success"]):
        return []
    ends = [n for n, (k, lo, hi) in variables.items() if k == "length" and
            min(abs(res["design"][n] - lo), abs(res["design"][n] - hi)) <= 1e-6 * max(abs(lo), abs(hi))]
    if not ends:
        return []
    return [Note(f"{', '.join(ends)} ended on {'its bound' if len(ends) == 1 else 'their bounds'} under contact law "
                 f"{law.name}, whose fitted creep constants do not depend on a roller's radius, crown or material: "
                 "nothing in that law holds a roller's size back. The default law's creep does depend on them "
                 "(docs/optimisation.md).", "bad")]


def objective_text(kind: str, value) -> str:
    """'worst |α| = 3.712°', 'mean power loss = 1.25 W'."""
    goal = objective(kind)
    return f"{goal.title} = {SHOW[goal.unit](value)}"


def result_blocks(res: dict, kinds: dict) -> list:
    """What optimise prints and reports: the starts, the optimum's design and its constraints (units shown)."""
    statuses = ", ".join(f"{s} ×{res['statuses'].count(s)}" for s in dict.fromkeys(res["statuses"]))
    kind = res.get("objective_kind", "worst_alpha")
    found = ", ".join(f"{SHOW[objective(kind).unit](o['objective'])} ({o['found']}×)" for o in res["optima"])
    if "front" in res:                     # objective kind pareto: the front, its knee the optimum
        points = "; ".join(f"{degrees(p['worst_alpha_deg'])}, {engineering(p['power_loss_W'], 'power')}"
                           for p in res["front"] if p["status"] in ("Solve_Succeeded", "Solved_To_Acceptable_Level"))
        blocks = [Note(f"study {res['study']}: the slip/loss front, {len(res['front'])} points ({statuses}): "
                       f"worst |α|, mean power loss = {points}; the optimum is its knee")]
    else:
        blocks = [Note(f"study {res['study']}: {res['starts']} starts ({statuses}); {len(res['optima'])} distinct "
                       f"optima found" + (f": {found}" if found else ""))]
    if not res["success"]:
        chk = res.get("envelope_check")
        why = f"; worst point {chk['worst']}" if chk and chk.get("worst") else ""
        return blocks + [Note(f"no successful solve: {res['status']}{why}; no variant file written", "bad")] + \
            [Note(f"cannot be met: {u['text']}", "bad") for u in res.get("unmet_constraints", [])]
    t = Table(f"optimum: {objective_text(kind, res['objective'])}", ["variable", "optimum", "base", "lower", "upper"])
    for n, v in res["design"].items():
        k, lo, hi = kinds[n]
        t.add(n, *(engineering(x, k) for x in (v, res["base_design"][n], lo, hi)))
    if "robust" in res:
        r = res["robust"]
        blocks.append(Note(f"robust over the calibration's {r['confidence']:.0%} region: worst |α| "
                           f"{degrees(r['worst_alpha_deg'])} over its {len(r['corners'])} corners "
                           f"({'; '.join(r['corners'])}); {degrees(r['nominal_worst_alpha_deg'])} at the nominal "
                           "calibration"))
    return blocks + [t, *interval_blocks(res["intervals"]), constraint_table(res, kinds),
                     Note(f"optimised variant: {res['variant_file']}  (try: cvtdesign compare {res['variant_file']})")]


GAIN_WORDS = {"max_abs_alpha_deg": ("slips less than", "largest slip angle"),
              "rms_alpha_deg": ("slips less on average than", "RMS slip angle"),
              "min_efficiency": ("keeps a higher worst-case efficiency than", "worst-case efficiency"),
              "max_loss_no_output_W": ("loses less with no output than", "loss with no output")}
INTERVAL_ROWS = [("max_abs_alpha_deg", "max |α| [°]", "{:.3f}"), ("rms_alpha_deg", "RMS α [°]", "{:.3f}"),
                 ("min_efficiency", "worst efficiency", "{:.3f}"), ("max_loss_no_output_W", "loss, no output [W]", "{:.3g}")]


def interval_blocks(got: dict) -> list:
    """The base design's and the optimum's figures with their 95 % intervals (design.optimum_intervals), and
    whether the optimum's gain is resolved at that uncertainty or which input would settle it."""
    t = Table("the base design and the optimum, each figure with its 95 % interval from every uncertain input",
              ["figure", "base", "optimum", "first in the optimum's budget"])
    for key, label, fmt in INTERVAL_ROWS:
        cells = []
        for row in (got["base"], got["optimum"]):
            iv = row.get(f"{key}_interval")
            value = row.get(key)
            cells.append("—" if value is None else fmt.format(value)
                         + ("" if iv is None else f" [{fmt.format(iv[0])}, {fmt.format(iv[1])}]"))
        budget = got["optimum"].get(f"{key}_budget") or {}
        t.add(label, *cells, next((f"{k} ({v:.0%})" for k, v in budget.items()), "—"))
    blocks = [t]
    for key, how in (("orderings", "as two builds, each with its own preload"),
                     ("orderings_one_preload", "at one preload")):
        named = [o | {"better": f"the {o['better']}", "worse": f"the {o['worse']}"} for o in got[key]]
        blocks.append(Note(f"{how}: " + "; ".join(ordering_sentences(named, GAIN_WORDS)),
                           "" if all(o["resolved"] for o in got[key]) else "warn"))
    blocks.append(Note("both designs share their materials, pairs, calibration and law, so those cancel in the "
                       "difference (docs/optimisation.md, 'How sure is an optimum')"))
    return blocks


def constraint_table(res: dict, kinds: dict) -> Table:
    """The most binding row of each constraint family, in the row's unit; the multiplier is the objective's
    change per unit of the bound (e.g. °/mm)."""
    obj_unit = objective(res["objective_kind"]).unit
    c = Table("constraints (most binding row of each; multiplier = objective change per unit of bound)",
              ["constraint", "where", "value", "bound", "slack", "multiplier", "active"])
    for r in res["constraints"]:
        if r["unit"] == "SI":        # a design variable's bound, in the variable's own kind
            kind, to_si = kinds[r["name"][len("bound "):]][0], 1.0
        else:
            kind, to_si = UNIT_KIND[r["unit"]]
        unit, factor = ENGINEERING[kind]
        per = to_si * factor         # from the row's units to the shown unit
        mult = f"{number(r['multiplier'] / per, 3)} {obj_unit}" + (f"/{unit}" if unit else "")
        c.add(r["name"], r["where"], *(engineering(r[key] * to_si, kind, 5) for key in ("value", "bound")),
              engineering(r["slack"] * to_si, kind, 3), mult, "yes" if r["active"] else "",
              style="bold" if r["active"] else "")
    return c
