"""The basis a layout's figures rest on: its contact law, where each contact's creep compliance comes from
(a calibration, the variant's own constants, or the theory alone) and its operating envelope, in words and as
JSON; and one basis for several layouts (`compare`).

A figure that rests on an assumption the user did not make (an uncalibrated law, another envelope) says so
where it is shown: `compare` prints these lines in its table and writes them in its JSON.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from cvtdesign.core.layout import Layout

ROLES = ("drive", "steering")      # drive and follower contacts; steering contacts
WORDS = {"library": "materials library", "fitted": "the variant's fitted creep constants",
         "transferred": "a calibration TRANSFERRED from materials of the same family (a best estimate)",
         "factor": "the variant's calibration factors"}


def role_of(roller) -> str:
    return "steering" if roller.role == "steering" else "drive"


def calibration(layout: Layout) -> dict:
    """{source, uncalibrated, std: {drive, steering}, kind (fitted, library, transferred, factor or theory; joined
    by ' + ' where contacts differ), pair (each 'roller material on sphere material'), same_source, contacts:
    {roller: {kind, source, std}}}:
    `uncalibrated` when some contact has only the theory; `std` the relative 1σ of each role's compliance (the
    largest of its contacts'; None where one is not stated); `same_source` when both roles rest on one
    calibration (their uncertainties then move together)."""
    contacts = {r.name: {"kind": r.creep.kind, "source": r.creep.source, "std": r.creep.std} for r in layout.rollers}
    std, sources = {}, {}
    for role in ROLES:
        mine = [r.creep for r in layout.rollers if role_of(r) == role]
        stds = [c.std for c in mine]
        std[role] = None if not mine or any(s is None for s in stds) else max(stds)
        sources[role] = {c.source for c in mine}
    uncalibrated = any(r.creep.uncalibrated for r in layout.rollers)
    distinct = sorted({c["source"] for c in contacts.values()})
    kinds = sorted({r.creep.kind for r in layout.rollers})
    return {"source": "; ".join(distinct), "uncalibrated": uncalibrated, "std": std,
            "kind": " + ".join(kinds), "pair": sorted({" on ".join(r.creep.materials) for r in layout.rollers}),
            "same_source": sources["drive"] == sources["steering"] and len(sources["drive"]) == 1,
            "contacts": contacts}


def calibration_text(layout: Layout) -> str:
    """One line: where the layout's creep compliances come from, and how sure they are."""
    cal = calibration(layout)
    kinds = {r.creep.kind for r in layout.rollers}
    if cal["uncalibrated"]:
        theory = [r.name for r in layout.rollers if r.creep.uncalibrated]
        return f"THEORY ONLY at {', '.join(theory)}: uncalibrated (Hertz + Kalker alone is 3.1–3.6× stiffer " \
               "than Kim et al.'s CVT measured)"
    std = ", ".join(f"{role} ±{s:.1%}" if s is not None else f"{role} ± not stated" for role, s in cal["std"].items())
    return f"{' + '.join(WORDS[k] for k in sorted(kinds))} ({std}, 1σ)"


def calibration_cell(layout: Layout) -> str:
    """A table cell: the kinds of calibration the layout's contacts rest on, 'THEORY ONLY' if any has none."""
    cal = calibration(layout)
    if cal["uncalibrated"]:
        return "THEORY ONLY"
    short = {"library": "materials library", "fitted": "own ε (fitted)", "factor": "own factors",
             "transferred": "TRANSFERRED"}
    text = " + ".join(short[k] for k in sorted({r.creep.kind for r in layout.rollers}))
    return text + (" (σ not stated)" if None in cal["std"].values() else "")


def envelope_text(layout: Layout) -> str:
    g, t = np.degrees(layout.gamma_grid), layout.load_grid
    step = lambda v: f" step {np.round(v[1] - v[0], 6):g}" if v.size > 1 else ""
    return (f"γ {g[0]:g}..{g[-1]:g}°{step(g)}, τ⊥ {t[0]:g}..{t[-1]:g} N·m{step(t)}, "
            f"ω1 {layout.motor_speed:g} rad/s")


def on_envelope(layout: Layout, of: Layout) -> Layout:
    """`layout` evaluated on the envelope of `of` (γ and load grids, motor speed)."""
    return dataclasses.replace(layout, gamma_grid=of.gamma_grid, load_grid=of.load_grid, motor_speed=of.motor_speed)


def same_envelope(a: Layout, b: Layout) -> bool:
    return (a.gamma_grid.shape == b.gamma_grid.shape and np.allclose(a.gamma_grid, b.gamma_grid)
            and a.load_grid.shape == b.load_grid.shape and np.allclose(a.load_grid, b.load_grid)
            and np.isclose(a.motor_speed, b.motor_speed))


def distinct_names(layouts: list[Layout]) -> list[str]:
    """The layouts' names, with the file's name added where two layouts share one ('existing (v2.yaml)')."""
    names = [L.name for L in layouts]
    out = [n if names.count(n) == 1 else f"{n} ({L.file.rsplit('/', 1)[-1]})" for n, L in zip(names, layouts)]
    return [n if out.count(n) == 1 else f"{L.name} ({L.file})" for n, L in zip(out, layouts)]


def fields(layout: Layout) -> dict:
    """The JSON fields of a layout's basis: contact_law, calibration (`calibration`, with its one-line text),
    envelope (in words)."""
    return {"contact_law": layout.contact_law,
            "calibration": calibration(layout) | {"text": calibration_text(layout), "cell": calibration_cell(layout)},
            "envelope": envelope_text(layout)}
