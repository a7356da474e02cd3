"""A duty cycle in SI: operating points in the order they run and how long each lasts (io.duty_file reads it)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class DutyCycle:
    """One cycle of a machine's use, repeated: point k runs for seconds[k] at (gamma[k], load[k], speed[k])."""
    name: str
    description: str
    gamma: np.ndarray        # commanded γ [rad]
    load: np.ndarray         # lateral load τ⊥ [N m]
    speed: np.ndarray        # motor speed ω1 [rad/s]
    seconds: np.ndarray      # duration of each point within the cycle [s]
    ambient: float           # temperature of the air and frame [K]
    wear_limit: float | None  # radius a roller may lose [m]; None: WEAR_LIMIT_RATIO of its radius
    hub_ratio: float         # hub radius / roller radius [-]
    file: str = ""

    @property
    def period(self) -> float:
        """One cycle's length [s]."""
        return float(np.sum(self.seconds))

    @property
    def shares(self) -> np.ndarray:
        """Each point's share of the time [-]."""
        return self.seconds / self.period


WEAR_LIMIT_RATIO = 0.01   # default wear limit: 1 % of the roller's radius, a 1 % error in its shaft's speed ratio
