"""Fitted effect parameters from a diagnosis (`cvtdesign diagnose --json`), for a design study to carry.

Under a contact law without fitted creep constants the scales of the creep effects (core.effects.CALIBRATION)
are the calibration of its theory's compliances, so a diagnosis of the rig's data calibrates the studies that follow
(`optimise --calibration FILE.json` or a study's `calibration: FILE.json`). The file's `final_fit` maps
'effect.parameter' to {value, std, identifiable}; every value must be a finite SI number within the
parameter's physical range (io.variant.effect_value), one InputError line otherwise.
"""
from __future__ import annotations

import json
import math

from cvtdesign.core.effects import EFFECTS
from cvtdesign.errors import InputError
from cvtdesign.io.variant import effect_value

MAX_BYTES = 50 * 2 ** 20        # a diagnosis report is well below a megabyte


def read_fitted(path) -> dict:
    """{effect: {parameter: SI value}} of a diagnosis report's final fit."""
    where = str(path)
    try:
        with open(path, "rb") as f:
            raw = f.read(MAX_BYTES + 1)
        report = json.loads(raw.decode("utf-8"))
    except OSError as e:
        raise InputError(f"{where}: cannot read file ({e.strerror or type(e).__name__})") from None
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as e:
        raise InputError(f"{where}: not a JSON file ({' '.join(str(e).split())}); expected the report of "
                         "cvtdesign diagnose --json") from None
    fit = report.get("final_fit") if isinstance(report, dict) else None
    if not isinstance(fit, dict) or not fit:
        raise InputError(f"{where}: final_fit: missing; expected the report of cvtdesign diagnose --json")
    out: dict = {}
    for key, entry in fit.items():
        effect, _, param = str(key).partition(".")
        if effect not in EFFECTS or param not in EFFECTS[effect].params:
            raise InputError(f"{where}: final_fit.{key}: not a parameter of the effect vocabulary")
        value = entry.get("value") if isinstance(entry, dict) else None
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            raise InputError(f"{where}: final_fit.{key}.value: expected a finite number, got {value!r}")
        out.setdefault(effect, {})[param] = effect_value(effect, param, float(value), f"{where}: final_fit.{key}")
    return out
