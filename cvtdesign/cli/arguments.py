"""Command-line arguments that several commands share."""
from __future__ import annotations

from cvtdesign.core.effects import check_names


def effects_arg(text, default, where):
    """'a,b' → effect names (checked, near names suggested); 'none' → no effects; None → default."""
    if text is None:
        return tuple(default)
    if text.strip().lower() in ("", "none"):
        return ()
    return check_names([e.strip() for e in text.split(",") if e.strip()], where)

