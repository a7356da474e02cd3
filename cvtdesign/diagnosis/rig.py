"""Virtual test rig: measured-like data (the measured-data CSV format) from the full model with chosen effects and noise.

Kim's protocol (sec. 4.2) by default: commanded γ −80°..80° in 10° steps, lateral load τ⊥ −1..1 N·m in
0.2 N·m steps (17 × 11 = 187 operating points), shaft 1 held at the variant's motor speed, shaft 2 loaded.
A random protocol draws its points (γ, τ⊥) uniformly over the same ranges instead, in the order drawn, so
that neither the grid nor the row order lines up with anything. The model is solved at each point once;
each replicate then adds independent Gaussian noise to what a rig measures: both shaft speeds, both torques
and (if recorded) the axis angle. Rows are written in the order a rig would measure them.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
import pandas as pd
from pydantic import BeforeValidator

from cvtdesign.core.effects import EFFECTS, check_names
from cvtdesign.core.layout import Layout
from cvtdesign.core.model import compile_model, status_counts
from cvtdesign.errors import InputError, suggest
from cvtdesign.io.limits import check_loads, check_points
from cvtdesign.io.schema import MAX_COUNT, Num, RangeSpec, Strict, no_bool
from cvtdesign.io.units import to_si
from cvtdesign.io.variant import effect_value, grid, quantity
from cvtdesign.io.yaml_file import read_spec

Quantity = Num       # a plain number (SI) or a quantity; true/false are not numbers


class ProtocolSpec(Strict):
    """A test protocol file: the operating points a rig runs."""
    gamma: RangeSpec | list[Quantity] = RangeSpec(start="-80 deg", stop="80 deg", step="10 deg")
    load: RangeSpec | list[Quantity] = RangeSpec(start="-1 N*m", stop="1 N*m", step="0.2 N*m")
    load_kind: Literal["tau_perp", "tau_2"] = "tau_perp"
    motor_speed: Quantity | list[Quantity] | None = None     # default: the variant's
    replicates: Annotated[int, BeforeValidator(no_bool)] = 1
    random: Annotated[int, BeforeValidator(no_bool)] | None = None   # this many points drawn over the ranges
    seed: Annotated[int, BeforeValidator(no_bool)] = 0               # of the random draw


@dataclass(frozen=True)
class Protocol:
    """The operating points a rig runs: every γ with every load (a grid), or, with `points`, those (γ, load)
    pairs in their order; each at every motor speed, `replicates` times over."""
    gammas: np.ndarray      # [rad]
    loads: np.ndarray       # [N m]
    speeds: np.ndarray      # [rad/s]
    load_kind: str = "tau_perp"
    replicates: int = 1
    points: np.ndarray | None = None    # (n, 2): γ [rad], load [N m], instead of the grid

    def pairs(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(ω1, γ, load) of every operating point in the order the rig runs them (speed, then γ, then load)."""
        if self.points is None:
            W, G, T = np.meshgrid(self.speeds, self.gammas, self.loads, indexing="ij")
            return W.ravel(), G.ravel(), T.ravel()
        n = len(self.points)
        return np.repeat(self.speeds, n), np.tile(self.points[:, 0], len(self.speeds)), \
            np.tile(self.points[:, 1], len(self.speeds))


@dataclass(frozen=True)
class Noise:
    """Standard deviations of the rig's measurements: shaft speeds [rad/s], torques [N m], axis angle [rad]."""
    speed: float = 0.01
    torque: float = 0.005
    axis: float = np.radians(0.05)

    def scaled(self, k: float) -> "Noise":
        return Noise(self.speed * k, self.torque * k, self.axis * k)


NOISE_KINDS = {"speed": "speed", "torque": "torque", "axis": "angle"}


def kim_protocol(layout: Layout, replicates: int = 1) -> Protocol:
    """Kim sec. 4.2: γ −80°..80° step 10°, τ⊥ −1..1 N·m step 0.2, the variant's motor speed."""
    return Protocol(np.radians(np.arange(-80, 81, 10.0)), np.round(np.arange(-1, 1.0001, 0.2), 12),
                    np.array([layout.motor_speed]), "tau_perp", replicates)


def random_protocol(protocol: Protocol, n: int, seed: int = 0) -> Protocol:
    """`n` points (γ, load) drawn uniformly over the ranges of `protocol`'s γ and loads, in the order drawn."""
    if not 1 <= n <= MAX_COUNT:
        raise InputError(f"random: expected from 1 to {MAX_COUNT} points, got {n}")
    rng = np.random.default_rng(seed)
    g = rng.uniform(protocol.gammas.min(), protocol.gammas.max(), n)
    t = rng.uniform(protocol.loads.min(), protocol.loads.max(), n)
    return Protocol(protocol.gammas, protocol.loads, protocol.speeds, protocol.load_kind, protocol.replicates,
                    np.column_stack([g, t]))


def read_protocol(path, layout: Layout, seed: int = 0) -> Protocol:
    """A protocol file, or 'random': Kim's ranges drawn at random (as many points as his grid, seeded by
    `seed`)."""
    if str(path) == "random":
        kim = kim_protocol(layout)
        return random_protocol(kim, len(kim.gammas) * len(kim.loads), seed)
    spec = read_spec(path, ProtocolSpec, "gamma, load, load_kind, motor_speed, replicates, random, seed")
    where = str(path)

    def values(v, kind, field):
        if isinstance(v, RangeSpec):
            return grid(v, kind, f"{where}: {field}")
        key = {"angle": "gamma", "torque": "load"}.get(kind)
        return np.array([quantity(x, key, f"{where}: {field}[{i}]") if key else to_si(x, kind, f"{where}: {field}[{i}]")
                         for i, x in enumerate(v)])

    speeds = np.array([layout.motor_speed]) if spec.motor_speed is None else values(
        spec.motor_speed if isinstance(spec.motor_speed, list) else [spec.motor_speed], "speed", "motor_speed")
    if np.any(speeds == 0) or np.any(np.abs(speeds) > 1e4):
        raise InputError(f"{where}: motor_speed: expected non-zero speeds of at most 1e4 rad/s")
    if not 1 <= spec.replicates <= MAX_COUNT:
        raise InputError(f"{where}: replicates: expected from 1 to {MAX_COUNT}, got {spec.replicates}")
    gammas, loads = values(spec.gamma, "angle", "gamma"), values(spec.load, "torque", "load")
    ranged = isinstance(spec.load, RangeSpec)
    check_loads([(f"{where}: load.start", loads[0]), (f"{where}: load.stop", loads[-1])] if ranged
                else [(f"{where}: load[{i}]", v) for i, v in enumerate(loads)], layout)
    n = spec.random if spec.random is not None else gammas.size * loads.size
    check_points(speeds.size * n, len(layout.rollers), where,
                 f"operating points ({speeds.size} speeds × {n} (γ, load) pairs)")
    protocol = Protocol(gammas, loads, speeds, spec.load_kind, spec.replicates)
    return protocol if spec.random is None else random_protocol(protocol, spec.random, spec.seed)


def parse_noise(text: str | None, where="--noise") -> Noise:
    """'speed=0.02 rad/s,torque=0.01 N*m,axis=0.1 deg' (any subset; plain numbers are SI): finite, >= 0."""
    if not text:
        return Noise()
    vals = {}
    for item in text.split(","):
        key, _, val = item.partition("=")
        key = key.strip()
        if key not in NOISE_KINDS or not val.strip():
            raise InputError(f"{where}: expected name=value with names {', '.join(NOISE_KINDS)}, got "
                             f"'{item.strip()}'{suggest(key, NOISE_KINDS)}")
        vals[key] = to_si(val.strip(), NOISE_KINDS[key], f"{where}: {key}")
        if not vals[key] >= 0:
            raise InputError(f"{where}: {key}: expected a standard deviation >= 0, got '{val.strip()}'")
    return Noise(**vals)


def parse_settings(items, effects, where="--set") -> dict:
    """['EFFECT.scale=1.3', 'EFFECT.offset=0.2 mm'] → {effect: {param: SI}}: each
    finite and within the parameter's physical range (variant.effect_value, as in a variant file)."""
    out: dict = {}
    for item in items or []:
        name, _, val = item.partition("=")
        effect, _, param = name.strip().partition(".")
        check_names([effect], where)
        if param not in EFFECTS[effect].params:
            raise InputError(f"{where}: effect {effect} has no parameter '{param}' "
                             f"(it has: {', '.join(EFFECTS[effect].params)})")
        if effect not in effects:
            raise InputError(f"{where}: {effect}.{param} is set but {effect} is not among the effects")
        if not val.strip():
            raise InputError(f"{where}: expected {effect}.{param}=value")
        out.setdefault(effect, {})[param] = effect_value(effect, param, val.strip(), f"{where}: {effect}.{param}")
    return out


def simulate(layout: Layout, effects, parameters: dict | None = None, protocol: Protocol | None = None,
             noise: Noise = Noise(), seed: int = 0, axis: bool = True) -> tuple[pd.DataFrame, int]:
    """Run the protocol on the model with `effects` (parameters {effect: {param: SI value}}) and return
    (rows in the measured-data format, the points not measured: model.status_counts of the points where the
    physics stops holding (lost contact, gross slip) or the solve did not converge; a rig cannot measure a
    steady state there)."""
    protocol = protocol or kim_protocol(layout)
    if not (isinstance(protocol.replicates, (int, np.integer)) and 1 <= protocol.replicates <= MAX_COUNT):
        raise InputError(f"replicates: expected from 1 to {MAX_COUNT} replicates of each operating point, got "
                         f"{protocol.replicates}")
    if not (isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0):
        raise InputError(f"seed: expected an integer >= 0 for the noise generator, got {seed}")
    points = protocol.pairs()[0].size
    check_points(points * protocol.replicates, len(layout.rollers), "replicates",
                 f"rows ({points} operating points × {protocol.replicates} replicates)")
    model = compile_model(layout.with_effects(effects, parameters))
    W, G, T = protocol.pairs()
    res = model.evaluate(G, T, speeds=W, load_kind=protocol.load_kind)
    ok = res["ok"].ravel()
    truth = {k: res[k].ravel()[ok] for k in ("omega_1", "omega_2", "tau_1", "tau_2", "gamma_axis")}
    gam = G[ok]
    rng = np.random.default_rng(seed)
    blocks = []
    for _ in range(protocol.replicates):
        n = gam.size
        b = {"gamma_cmd_deg": np.degrees(gam),
             "omega_1": truth["omega_1"] + noise.speed * rng.standard_normal(n),
             "omega_2": truth["omega_2"] + noise.speed * rng.standard_normal(n),
             "tau_1": truth["tau_1"] + noise.torque * rng.standard_normal(n),
             "tau_2": truth["tau_2"] + noise.torque * rng.standard_normal(n)}
        if axis:
            b["gamma_axis_deg"] = np.degrees(truth["gamma_axis"] + noise.axis * rng.standard_normal(n))
        blocks.append(pd.DataFrame(b))
    left_out = {k: v for k, v in status_counts(res, model.roller_names).items() if k != "ok" and v}
    return pd.concat(blocks, ignore_index=True), left_out


def to_csv_text(rows: pd.DataFrame) -> str:
    return rows.to_csv(index=False, float_format="%.9g")
