"""Command-line arguments that several commands share."""
from __future__ import annotations

from cvtdesign.core.effects import check_names
from cvtdesign.errors import InputError

MAX_SAMPLES = 10_000   # samples of the uncertain inputs that check the first-order intervals (compare, capacity)


def effects_arg(text, default, where):
    """'a,b' → effect names (checked, near names suggested); 'none' → no effects; None → default."""
    if text is None:
        return tuple(default)
    if text.strip().lower() in ("", "none"):
        return ()
    return check_names([e.strip() for e in text.split(",") if e.strip()], where)


def check_samples(given: int) -> int:
    """--samples of the uncertain inputs: 0 (first order only) or 20 to MAX_SAMPLES (fewer cannot place a 95 %
    interval's ends)."""
    if not 0 <= given <= MAX_SAMPLES or 0 < given < 20:
        raise InputError(f"--samples: {given}; expected 0 (first order only) or 20 to {MAX_SAMPLES:,} samples")
    return given
