"""The model evaluated at a dataset's operating points: predictions, residuals and z-scores.

Every operating point is (γ_cmd, ω1 and the lateral load τ⊥ = −τ1 sin γ + τ2 cos γ from the measured torques,
Kim et al., "Causes of microslip in a continuously variable transmission", eq 17: the load the rig
controls). The model with a set of effects predicts the slip angle α, the parallel torque τ∥ = τ1 cos γ +
τ2 sin γ (ω1 τ∥ / cos γ is the power loss, so it carries the efficiency) and the axis angle γ_axis.
Residuals = measured − predicted, in ° and N·m.
"""
from __future__ import annotations

import functools
import time

import numpy as np

from cvtdesign.core.effects import SWITCH, parameter_vector
from cvtdesign.core.layout import Layout
from cvtdesign.core.metrics import efficiency
from cvtdesign.core.model import call_mapped, compile_model
from cvtdesign.core.native import Tiered, compiler, policy
from cvtdesign.core.sensitivity import at_points, derivative_function
from cvtdesign.core.status import Status
from cvtdesign.diagnosis.measured import Measured

CHANNELS = ("alpha", "tau_par", "axis")        # [deg], [N m], [deg]
UNITS = {"alpha": "deg", "tau_par": "N*m", "axis": "deg"}
OUTPUTS = ["alpha", "tau_1", "tau_2", "gamma_axis", "omega_2", "status"]   # the model's outputs they are made of
DERIVED = ["alpha", "tau_1", "tau_2", "gamma_axis", "omega_2"]             # those differentiated in θ


class Switched:
    """One model for every effect set the diagnosis tries: the model of `effects` with each effect switchable
    (core.model.compile_model, switched), built once; a set of them is its θ with the others' switches at 0,
    the same numbers as that set's own model. Its rows' function (the predictions and the roots) is evaluated
    compiled (core.native.Tiered) once `expect` says enough evaluations are coming to pay for compiling it,
    or once its interpreted evaluations have taken long enough; the compiled library stays in the cache, so a
    later diagnosis of the same variant and effects loads it. Where nothing is compiled (no C compiler,
    CVTDESIGN_COMPILE=never) each effect set gets a model of its own (`view`): interpreted, the model of every
    effect costs 1.75× a set's own."""

    def __init__(self, layout: Layout, effects):
        self.layout, self.effects = layout, tuple(effects)
        self.model = compile_model(layout, self.effects, switched=True)
        self._alone = {}
        params = [n for n in self.model.param_names if not n.endswith(SWITCH)]
        derivatives = derivative_function(self.model, DERIVED, list(range(len(params))), [])
        self.tiers = {"rows": Tiered(self.model.point_function(OUTPUTS + ["root"]),
                                     lambda: self.model.point_function(OUTPUTS + ["root"], written_out=True)),
                      "derivatives": Tiered(derivatives, lambda: derivatives)}
        self._maps = {}

    def view(self, effects) -> Switched:
        """The model a Predictor of `effects` evaluates: this one where models are compiled, else a model of
        those effects alone (built once)."""
        if set(effects) == set(self.effects) or (policy() != "never" and compiler() is not None):
            return self
        if tuple(effects) not in self._alone:
            self._alone[tuple(effects)] = Switched(self.layout, effects)
        return self._alone[tuple(effects)]

    def expect(self, calls: int, points: int) -> None:
        """Announce `calls` evaluations of `points` rows (core.native.Tiered): the rows' function is then
        compiled at its first evaluation, waited for, while the derivative function compiles in another
        process (beside it, on a machine with a second core) and is used once it is there."""
        self.tiers["rows"].expect(calls * points)
        self.tiers["derivatives"].start()

    def theta(self, effects) -> tuple[list, np.ndarray]:
        """(indices in θ of the parameters of `effects`, in their own model's order; θ with their switches on,
        the others' off)."""
        names, values = self.model.param_names, np.array(self.model.param_values, float)
        for e in self.effects:
            values[names.index(f"{e}{SWITCH}")] = float(e in effects)
        return [names.index(n) for n in parameter_vector(effects)[0]], values

    def rows(self, n: int, args: list) -> list[np.ndarray]:
        """The rows' solutions and predictions at `args` (n rows), compiled once that is there."""
        return self._call("rows", n, lambda mapped: call_mapped(mapped, args))

    def derivatives(self, n: int, roots: np.ndarray) -> list[np.ndarray]:
        """d(DERIVED)/d(every parameter) at the n rows' `roots` (core.sensitivity.at_points)."""
        nx = self.model.residual.size1_in(0)
        return self._call("derivatives", n, lambda mapped: at_points(mapped, roots[:nx], roots[nx:],
                                                                      [1] * len(DERIVED)))

    def _call(self, kind: str, n: int, run):
        """`run` of the tier's function mapped over n rows: compiled on one thread (a call takes 1–2 ms, and two
        threads cost more CPU and, on a loaded machine, more wall time too: each call waits for both), else on
        two."""
        tier = self.tiers[kind]
        fn = tier.function(n)
        if (id(fn), n) not in self._maps:
            self._maps[id(fn), n] = fn.map(n) if fn is tier.native else fn.map(n, "thread", 2)
        t = time.perf_counter()
        out = run(self._maps[id(fn), n])
        tier.record(fn, n, time.perf_counter() - t)
        return out


class Predictor:
    """The model with `effects` evaluated at a dataset's rows: θ → predictions and their Jacobian.

    A prediction solves the rows (the point function of the Switched model, mapped over them) and keeps their
    solutions; its Jacobian at the same θ is then the implicit function theorem's at those solutions
    (core.sensitivity), with no second solve."""

    def __init__(self, layout: Layout, effects, data: Measured, shared: Switched | None = None):
        self.effects = tuple(effects)
        self.shared = (shared or Switched(layout, self.effects)).view(self.effects)
        self.model = self.shared.model          # its θ is the Switched one's: evaluate through `evaluate`
        self._index, self._theta = self.shared.theta(self.effects)
        self.names = [self.model.param_names[i] for i in self._index]
        self.defaults = self._theta[self._index].copy()
        r = data.rows
        g = np.radians(r["gamma_cmd_deg"].to_numpy())
        n = len(r)
        phi0, _ = self.model.steering_guess(g)
        self._rows = [g, r["omega_1"].to_numpy(), r["tau_perp"].to_numpy(), np.zeros(n), phi0]
        self.n, self.gamma = n, g
        self._last = None        # (θ, its outputs)
        self._pinned = None      # (θ, its outputs or None until evaluated): see `pin`

    def full(self, theta) -> np.ndarray:
        """The Switched model's θ of this effect set's parameters `theta`."""
        out = self._theta.copy()
        out[self._index] = theta
        return out

    def evaluate(self, gammas, loads, speeds, theta) -> dict:
        """The model with these effects at `theta`, evaluated at any points (CompiledModel.evaluate)."""
        return self.model.evaluate(gammas, loads, speeds=speeds, theta=self.full(theta))

    def pin(self, theta) -> None:
        """Keep the solutions (and Jacobian) at `theta` besides the last θ's, until another θ is pinned: a fit
        pins its start, and the cross-validation's folds all start from the full fit's θ (16 % of a diagnosis's
        solves were at a θ solved before)."""
        theta = np.asarray(theta, float)
        if self._pinned is None or not np.array_equal(self._pinned[0], theta):
            kept = self._last[1] if self._last is not None and np.array_equal(self._last[0], theta) else None
            self._pinned = (theta.copy(), kept)

    def _outputs(self, theta: np.ndarray) -> dict:
        """The rows' outputs at θ: the last θ's or the pinned θ's when it is one of them, else solved."""
        for slot in (self._last, self._pinned):
            if slot is not None and slot[1] is not None and np.array_equal(slot[0], theta):
                self._last = slot
                return slot[1]
        out = dict(zip(OUTPUTS + ["root"], self.shared.rows(self.n, [*self._rows, self.full(theta), np.zeros(0)])))
        self._last = (theta.copy(), out)
        if self._pinned is not None and self._pinned[1] is None and np.array_equal(self._pinned[0], theta):
            self._pinned = self._last
        return out

    def __call__(self, theta, jacobian=False):
        """Predictions {alpha [deg], tau_par [N m], axis [deg], omega_2 [rad/s], tau_1, tau_2 [N m]}, converged
        mask: the points where the model's physics holds (and dY/dθ, shape (6, n, p), with `jacobian`)."""
        out = self._outputs(np.asarray(theta, float))
        ok = out["status"][0] == Status.OK      # the model's status: converged, in contact, no gross slip
        _, tau_par = self.model.frame.load_split(self.gamma, out["tau_1"][0], out["tau_2"][0])
        pred = {"alpha": np.degrees(out["alpha"][0]), "tau_par": tau_par, "axis": np.degrees(out["gamma_axis"][0]),
                "omega_2": out["omega_2"][0], "tau_1": out["tau_1"][0], "tau_2": out["tau_2"][0]}
        if not jacobian:
            return pred, ok
        if "derivatives" not in out:
            out["derivatives"] = self.shared.derivatives(self.n, out["root"])
        d = dict(zip(DERIVED, (v[0][:, self._index] for v in out["derivatives"])))
        _, d_par = self.model.frame.load_split(self.gamma[:, None], d["tau_1"], d["tau_2"])    # linear in τ1, τ2
        J = np.array([np.degrees(d["alpha"]), d_par, np.degrees(d["gamma_axis"]), d["omega_2"], d["tau_1"],
                      d["tau_2"]])
        return pred, ok, J


def _wrap_deg(x):
    return (x + 90.0) % 180.0 - 90.0


def observed(data: Measured) -> dict:
    """The measured channels as arrays (the axis only when measured): α [deg], τ∥ [N m], γ_axis [deg]."""
    r = data.rows
    cols = {"alpha": "alpha_deg", "tau_par": "tau_par"} | ({"axis": "gamma_axis_deg"} if data.has_axis else {})
    return {c: r[k].to_numpy() for c, k in cols.items()}


def residuals(data: Measured, pred: dict, measured: dict | None = None) -> dict:
    """Measured − predicted per channel (the axis only when measured); `measured`: `observed(data)`, when a
    caller that asks many times has it."""
    m = observed(data) if measured is None else measured
    out = {"alpha": _wrap_deg(m["alpha"] - pred["alpha"]), "tau_par": m["tau_par"] - pred["tau_par"]}
    if "axis" in m:
        out["axis"] = _wrap_deg(m["axis"] - pred["axis"])
    return out


def zscores(resid: dict, noise: dict) -> np.ndarray:
    """(channels, rows) residuals in units of their noise."""
    return np.array([resid[c] / noise[c] for c in resid])


def channels(data: Measured):
    return [c for c in CHANNELS if c != "axis" or data.has_axis]


def rms(x, mask=None):
    x = np.asarray(x, float)
    if mask is not None:
        x = x[mask]
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x ** 2))) if x.size else float("nan")


def efficiency_mask(data: Measured):
    r = data.rows
    big = np.abs(r["tau_perp"].to_numpy()) >= 0.25 * np.abs(r["tau_perp"]).max()
    return big & (np.abs(r["gamma_cmd_deg"].to_numpy()) >= 5)


def model_efficiency(data: Measured, pred: dict):
    r = data.rows
    return efficiency(pred["tau_1"] * r["omega_1"].to_numpy(), pred["tau_2"] * pred["omega_2"])


class Models:
    """Predictors of one dataset for any set of `effects` (the base model's and the candidates'), all views of
    one Switched model."""

    def __init__(self, layout, data, effects, shared: Switched | None = None):
        self.layout, self.data = layout, data
        self.shared = shared or Switched(layout, effects)

    @functools.lru_cache(maxsize=None)
    def get(self, effects: tuple) -> Predictor:
        return Predictor(self.layout, effects, self.data, self.shared)
