"""What a solve returns: the Solution of one IPOPT run, and its check on the whole envelope.

After IPOPT, the optimum is checked on the whole envelope by the model at the optimum (`Problem.check`:
every envelope point evaluated as `CompiledModel.evaluate` evaluates the numeric model of the optimum, see
`Problem.envelope`; counted by `check_envelope`): a point that did not converge, that has a contact at
N ≤ 0 or a contact at |F| > μN fails it, and the solve is then reported as failed (status 'Failed_Envelope_Check' with the counts;
`success` False), so no variant file is written for it (`report.write_variant` refuses to).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from cvtdesign.core.status import STATUS


@dataclass
class Solution:
    """One solve from one start: IPOPT's status (or the envelope check's), the objective, the design
    (z normalised to [0, 1], `design` the SI values by name), every row g of the whole formulation with its
    multipliers lam_g, and the bound multipliers lam_x of z."""
    status: str
    success: bool
    objective: float
    z: np.ndarray
    design: dict
    g: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray
    iterations: int
    start: int
    rounds: int = 1          # working-set rounds (IPOPT solves)
    points: int = 0          # envelope points in the final working set
    check: EnvelopeCheck | None = None   # the optimum on the whole envelope (None: IPOPT did not succeed)
    ipopt_status: str = ""   # IPOPT's return status (`status` says Failed_Envelope_Check when the check fails)
    history: list = field(default_factory=list)   # per IPOPT iteration: (working-set round, objective, primal infeasibility)


@dataclass
class EnvelopeCheck:
    """A design on the whole envelope by the model at that design: how many points did not converge, lost
    contact (N ≤ 0 at some contact), slip grossly (N > 0 but |F| > μN at some contact) or solved to a root
    with the sphere turning backwards (`reversed`), or has two roots, so that its state depends on the load's
    history (`multiple_roots`)."""
    points: int
    not_converged: int
    lost_contact: int
    gross_slip: int
    reversed: int
    multiple_roots: int
    min_normal_force: float    # [N] smallest N over the points that pass (NaN: none passes)
    max_utilisation: float     # largest |F|/(μN) over the points that pass
    worst: str = ""            # a failing point of the most serious kind, why, and at which contact
    max_abs_alpha_deg: float = float("nan")   # [deg] worst |α| over the points that pass

    @property
    def failed(self) -> int:
        return self.not_converged + self.lost_contact + self.gross_slip + self.reversed + self.multiple_roots

    @property
    def ok(self) -> bool:
        return self.failed == 0

    def summary(self) -> str:
        return (f"{self.failed} of {self.points} envelope points: {self.lost_contact} lost contact (N ≤ 0), "
                f"{self.gross_slip} gross slip (|F| > μN), {self.not_converged} not converged"
                + (f", {self.reversed} reversed (sphere turning backwards)" if self.reversed else "")
                + (f", {self.multiple_roots} with two roots (state depends on the load's history)"
                   if self.multiple_roots else ""))

    def as_dict(self) -> dict:
        return {"points": self.points, "failed": self.failed, "not_converged": self.not_converged,
                "lost_contact": self.lost_contact, "gross_slip": self.gross_slip, "reversed": self.reversed,
                "multiple_roots": self.multiple_roots,
                "min_normal_force_N": self.min_normal_force, "max_utilisation": self.max_utilisation,
                "max_abs_alpha_deg": self.max_abs_alpha_deg, "worst": self.worst}


def check_envelope(res: dict, roller_names) -> EnvelopeCheck:
    """Count the operating points of `res` (CompiledModel.evaluate's result, or Problem.envelope's) that
    are outside the model's physics by the model's own `status` (not converged, lost contact: N ≤ 0, gross
    slip: |F| > μN, reversed, multiple roots), naming the first failure of the most serious kind and the contact behind it."""
    st, contact = res["status"].ravel(), res["failed_contact"].ravel()
    n = st.size
    N, U = np.reshape(res["N"], (-1, n)), np.reshape(res["utilisation"], (-1, n))
    ok = st == STATUS.index("ok")
    g, l = (np.broadcast_to(a, res["status"].shape).ravel() for a in (res["gamma_cmd"], res["load"]))
    worst = ""
    for code, what in ((2, "lost contact (N ≤ 0)"), (3, "gross slip (|F| > μN)"), (4, "reversed (the sphere turns "
                       "against the commanded axis)"), (5, "two roots (the state depends on the load's history)"),
                       (1, "not converged")):
        if (st == code).any():
            k = int(np.flatnonzero(st == code)[0])
            who = f" at {roller_names[contact[k]]}" if contact[k] >= 0 else ""
            worst = f"γ={np.degrees(g[k]):+.0f}° τ⊥={l[k]:+.3g}: {what}{who}"
            break
    return EnvelopeCheck(n, *(int((st == code).sum()) for code in (1, 2, 3, 4, 5)),
                         float(np.min(N[:, ok])) if ok.any() else float("nan"),
                         float(np.max(U[:, ok])) if ok.any() else float("nan"), worst,
                         float(np.degrees(np.max(np.abs(np.ravel(res["alpha"])[ok])))) if ok.any() else float("nan"))
