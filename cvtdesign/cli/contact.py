"""`cvtdesign contact`: every roller's contact patch with the sphere at its preload, by Hertz and Kalker.

For each roller: the Hertz ellipse (a along the rolling direction, b across), its peak pressure, Kalker's
coefficients C11, C22, C23, C33, μ, linear theory's creep constants, and the creep–force curves of the
creep-force surface (core.contact.surface: Kalker's simplified theory FASTSIM with the Hertz traction bound) for
longitudinal, lateral and spin creepage, with the pure-spin moment curve. The patch, the coefficients and the
ε columns are the contact physics the layout's radii, crowns, materials and preloads give by the theory alone;
next to them, the compliance the variant's law actually uses (its calibration: the materials library's, a
transferred one, its own constants or factors, or none) and where it comes from. The curves are drawn as the
model runs them: with the calibrated compliance (`used_patch`), and the theory's beside them in the JSON.
"""
from __future__ import annotations

from pathlib import Path

from rich.console import Console

from cvtdesign.cli.printing import show
from cvtdesign.io.strict_json import json_text
from cvtdesign.core.contact.patch import calibrated_compliance, curves, patch, theory_patch
from cvtdesign.io import plots
from cvtdesign.io.output import make_folder, write_file
from cvtdesign.io.report import Note, Table
from cvtdesign.io.units import engineering, number
from cvtdesign.io.variant import load_variant


CURVE_KINDS = ("longitudinal", "lateral", "spin", "spin_moment")


def used_patch(layout, roller) -> dict:
    """The roller's patch (numeric) as the variant's law runs it: Hertz at the nominal moduli, the creep at the
    calibration's creep modulus (core.contact.patch.patch), and G (with the creep and spin coefficients) divided
    by k = ε used / ε of that patch in the roller's own direction, so that its linear slope is the calibrated
    compliance the model runs (calibrated_compliance). Under a law on the theory's compliances k is the variant's
    calibration factor, which divides G at every creepage; under a law with fitted linear creep constants the
    curves give FASTSIM's shape at the fitted slope. With the theory alone k = 1."""
    p = {k: float(v) for k, v in patch(layout, roller).items()}
    used = calibrated_compliance(layout, roller)
    k = used / (p["eps_long"] if roller.role != "steering" else p["eps_lat"])
    p["G"] /= k
    for key in ("spin_coefficient", "spin_moment_coefficient"):
        p[key] /= k
    p["eps_long"], p["eps_lat"] = p["eps_long"] * k, p["eps_lat"] * k
    return p


def curve_basis(roller) -> str:
    """What the drawn curves rest on, for the legend: 'calibrated (library)', 'calibrated (transferred)',
    'calibrated (fitted)', 'calibrated (factor)' or 'theory only'."""
    return "theory only" if roller.creep.uncalibrated else f"calibrated ({roller.creep.kind})"


def roller_record(layout, roller) -> dict:
    """The JSON record of a roller's contact at its preload (SI unless the key names a unit): the theory's
    patch and constants; the compliance the variant's law uses (`eps_calibrated_per_N`, in the roller's own
    direction) with its `calibration` in words; the creep–force curves as the law runs them, calibrated
    (`curve_<kind>`, on `curve_basis`), and by the theory alone at the nominal moduli (`curve_<kind>_theory`)."""
    p = {k: float(v) for k, v in theory_patch(layout, roller).items()}
    c, theory = curves(used_patch(layout, roller)), curves(p)
    return {"role": roller.role, "N": p["N"], "a_mm": p["a"] * 1e3, "b_mm": p["b"] * 1e3,
            "p0_MPa": p["p0"] * 1e-6, "G_MPa": p["G"] * 1e-6, "nu": p["nu"], "C11": p["C11"], "C22": p["C22"],
            "C23": p["C23"], "C33": p["C33"], "mu": p["mu"], "eps_long_per_N": p["eps_long"],
            "eps_lat_per_N": p["eps_lat"], "spin_coefficient_Nm": p["spin_coefficient"],
            "spin_moment_coefficient_Nm2": p["spin_moment_coefficient"], "pivot_lever_mm": p["pivot_lever"] * 1e3,
            **{f"curve_{k}": c[k] for k in CURVE_KINDS}, **{f"curve_{k}_theory": theory[k] for k in CURVE_KINDS},
            "curve_basis": curve_basis(roller), "eps_calibrated_per_N": calibrated_compliance(layout, roller),
            "calibration": roller.creep.source, "uncalibrated": roller.creep.uncalibrated}


def patch_table(name: str, records: dict) -> Table:
    t = Table(f"{name}: contact patches at the preload (Hertz; Kalker's linear theory)",
              ["roller", "role", "N", "a", "b", "p0", "C11", "C22", "C23", "C33", "μ", "ε_long [1/N]",
               "ε_lat [1/N]", "spin coeff. [N·m]", "μNℓ [N·mm]", "ε used [1/N]"])
    for n, r in records.items():
        t.add(n, r["role"], engineering(r["N"], "force"), engineering(r["a_mm"] / 1e3, "length"),
              engineering(r["b_mm"] / 1e3, "length"), engineering(r["p0_MPa"] * 1e6, "pressure"),
              *(number(r[k], 3) for k in ("C11", "C22", "C23", "C33", "mu", "eps_long_per_N", "eps_lat_per_N",
                                          "spin_coefficient_Nm")),
              number(r["mu"] * r["N"] * r["pivot_lever_mm"], 3),
              number(r["eps_calibrated_per_N"], 3) + (" (theory)" if r["uncalibrated"] else ""))
    return t


def calibration_notes(records: dict) -> list:
    """One line per distinct calibration: the rollers it applies to and where it comes from."""
    by_source = {}
    for n, r in records.items():
        by_source.setdefault((r["calibration"], r["uncalibrated"]), []).append(n)
    return [Note(f"ε used at {', '.join(names)}: {source}", "bad" if bad else "")
            for (source, bad), names in by_source.items()]


def run(args):
    layout = load_variant(args.variant)
    records = {r.name: roller_record(layout, r) for r in layout.rollers}
    console = Console()      # the terminal's width (COLUMNS, else 80 when not a terminal); show never cuts a number
    written = []          # the files first, then the terminal (a reader closing stdout early loses no file)
    if args.plots:
        folder = make_folder(args.plots, kind="--plots")
        written += [f"plot: {f}" for f in plots.contact_figures(layout.name, records, folder, Path(args.variant).stem)]
    if args.json:
        write_file(args.json, json_text({"variant": layout.name, "rollers": records}), kind="--json")
        written.append(f"contacts written to {args.json}")
    show(console, [patch_table(layout.name, records), *calibration_notes(records),
                   Note("creep constants: ε_long = 1/(G a b C11), ε_lat = 1/(G a b C22); spin coeff. G (ab)^1.5 C23 "
                        "(lateral force per unit spin creepage [1/m]), all by the theory at the nominal moduli; ε used: "
                        "the compliance the variant's law uses, along the rolling direction at drive and follower "
                        "rollers, across it at steering rollers; a patch that pivots (spins without rolling) "
                        "carries the moment μNℓ, ℓ the Hertz pressure's mean lever; the curves (--json, --plots) are "
                        "drawn at ε used (calibrated, as the model runs them; the theory's in the JSON's "
                        "curve_<kind>_theory): creepage saturates at μN, while pure spin's lateral force peaks "
                        "and then falls as the traction comes to circulate")])
    for line in written:
        console.print(line)
    return 0
