"""What the commands print and write: strict JSON, counts of left-out points, progress bars."""
from __future__ import annotations

import contextlib
import json

import numpy as np
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn


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


def left_out_text(counts: dict) -> str:
    """'gross slip at 12 points (D1 ×8, S1 ×4); lost contact at 3 points (S2 ×3)' from model.status_counts."""
    parts = []
    for key in ("lost_contact", "gross_slip", "not_converged"):
        if counts.get(key):
            at = counts.get(f"{key}_at") or {}
            where = f" ({', '.join(f'{k} ×{v}' for k, v in at.items())})" if at else ""
            parts.append(f"{key.replace('_', ' ')} at {counts[key]} points{where}")
    return "; ".join(parts)


@contextlib.contextmanager
def progress_bar(console, label: str, describe, transient: bool = False):
    """A rich progress bar (label, bar, done/total, elapsed time, the last item) as the callback
    progress(done, total, item) that long computations take; `describe(item)` says what the item was
    (item None: nothing finished yet)."""
    with Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("{task.description}"), console=console, transient=transient) as bar:
        task = bar.add_task("", total=None)
        yield lambda done, total, item: bar.update(task, total=total, completed=done,
                                                   description="" if item is None else describe(item))
