"""A material's ageing constants in SI (io.ageing reads them from the materials library and the variant):
each with its relative standard deviation and its source, and how a property follows the temperature."""
from __future__ import annotations

from dataclasses import dataclass, field

T_REF = 298.15      # [K] 25 °C, where the temperature factors are 1


@dataclass(frozen=True)
class Ageing:
    """Constants of one material (io.schema.AGEING names them): name → SI value, relative 1σ, source."""
    material: str
    values: dict = field(default_factory=dict)
    std: dict = field(default_factory=dict)
    source: dict = field(default_factory=dict)

    def __getitem__(self, key: str) -> float:
        return self.values[key]

    def has(self, *keys: str) -> bool:
        return all(k in self.values for k in keys)

    def scaled(self, key: str, factor: float) -> "Ageing":
        """A copy with one constant times `factor` (the intervals' perturbations)."""
        return Ageing(self.material, {**self.values, key: self.values[key] * factor}, self.std, self.source)


def temperature_factor(factor_hot: float, T_hot: float, T):
    """A property's value at temperature T [K] over its value at 25 °C, exponential in T through 1 at 25 °C
    and `factor_hot` at T_hot [K] (urethane's modulus: about 0.5 at 93 °C). Exponential, so that it stays
    positive beyond T_hot; an assumed form between two measured points (docs/life.md)."""
    return factor_hot ** ((T - T_REF) / (T_hot - T_REF))


def modulus_factor(m: Ageing, T):
    """E(T)/E(25 °C) of material m (1 where it gives no modulus_factor)."""
    if not m.has("modulus_factor", "hot_temperature"):
        return 1.0 + 0.0 * T
    return temperature_factor(m["modulus_factor"], m["hot_temperature"], T)


def friction_factor(m: Ageing, T):
    """μ(T)/μ(25 °C) of material m (1 where it gives no friction_factor)."""
    if not m.has("friction_factor", "hot_temperature"):
        return 1.0 + 0.0 * T
    return temperature_factor(m["friction_factor"], m["hot_temperature"], T)
