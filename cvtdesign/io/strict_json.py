"""Strict JSON, as every command and the Python API (cvtdesign.api) write it: NaN and ±inf become null."""
from __future__ import annotations

import json

import numpy as np


def finite(obj):
    """obj with numpy scalars and arrays as Python numbers and lists, and NaN or ±inf as None."""
    if isinstance(obj, dict):
        return {str(k): finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, np.ndarray)):
        return [finite(v) for v in obj]
    if isinstance(obj, (np.integer, np.bool_)):
        return obj.item()
    if isinstance(obj, (float, np.floating)):
        return float(obj) if np.isfinite(obj) else None
    return obj


def json_text(obj) -> str:
    """Strict JSON (RFC 8259: no NaN or Infinity; a number that does not exist is null), indented."""
    return json.dumps(finite(obj), indent=2, allow_nan=False, default=str) + "\n"
