"""What became of an operating point: its status, one code per point in the model's `status` output.

Every operating point the model (core.model) evaluates gets one Status, and only an OK point carries numbers:
 * OK: the solve converged to a forward root where every contact holds;
 * NOT_CONVERGED: the Newton solve did not reach its tolerance (or gave no number at all);
 * LOST_CONTACT: some normal force N ≤ 0;
 * GROSS_SLIP: some contact's tangential force exceeds μN, or a saturating law is at its limit;
 * REVERSED: a root with the sphere turning against the commanded axis (the output shaft runs backwards);
 * MULTIPLE_ROOTS: the equations hold two roots there (the state depends on how the load came).
The code is the integer the compiled model computes (an IntEnum, so arrays of codes compare with it), and
STATUS its names in order (what tables and JSON print).
"""
from __future__ import annotations

from enum import IntEnum


class Status(IntEnum):
    """An operating point's status (module docstring); `label` is its name as printed."""
    OK = 0
    NOT_CONVERGED = 1
    LOST_CONTACT = 2
    GROSS_SLIP = 3
    REVERSED = 4
    MULTIPLE_ROOTS = 5

    @property
    def label(self) -> str:
        return self.name.lower()


STATUS = tuple(s.label for s in Status)     # the names, in code order
