"""The resolved layout: what the model compiler reads, in SI (built from a variant file by io.variant).

Numeric fields are floats, or CasADi expressions of design parameters when the optimiser builds a layout
with symbolic parameters.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np


@dataclass(frozen=True)
class Material:
    E: object          # Young's modulus [Pa]
    nu: object         # Poisson's ratio [-]
    p_allow: object    # allowable Hertz peak pressure [Pa] (None: not checked)
    name: str = ""     # its name in the variant or the materials library
    E_std: float = 0.25         # relative 1σ of E [-]
    E_std_assumed: bool = True  # True: no σ stated (that of a modulus read from a Shore A hardness)


@dataclass(frozen=True)
class Friction:
    """The friction coefficient of a contact's pair of materials (friction belongs to the pair, not to one
    material): nominal μ, its range and where it comes from (io.materials.pair_friction)."""
    mu: object                    # nominal friction coefficient [-]
    low: float                    # the range's ends [-]
    high: float
    source: str                   # in words, with its provenance


@dataclass(frozen=True)
class CreepSource:
    """Where a contact's creep compliance comes from (io.materials decides it from the variant and the library)."""
    kind: str                     # 'library', 'transferred' (a library calibration of a material of the same
                                  # family), 'fitted' (kim's creep constants), 'factor' (kalker's), 'theory'
    source: str                   # in words, with its provenance
    std: float | None = None      # relative 1σ of the compliance (None: not stated)
    creep_modulus: object = None  # the roller's Young's modulus in tangential creep [Pa], for kind 'library'
    materials: tuple = ()         # (roller material, sphere material) by name
    preload: float | None = None  # the normal force [N] on the measured machine the calibration was fitted at

    @property
    def uncalibrated(self) -> bool:
        return self.kind == "theory"


@dataclass(frozen=True)
class Roller:
    """One roller in SI; numeric fields are floats or CasADi expressions of design parameters."""
    name: str
    role: str                      # 'drive' | 'follower' | 'steering'
    shaft: int | None              # 1 or 2 for drive/follower rollers
    ratio: object                  # roller speed / shaft speed [-]
    normal: object                 # unit contact normal at φ = 0 (3-vector)
    axle: object                   # unit positive spin axis at φ = 0 (3-vector, ⊥ normal)
    radius: object                 # rolling radius [m]
    crown_radius: object           # crown radius [m]
    width: object                  # [m]
    material: Material
    preload: object                # normal force with the sphere centred [N]
    stiffness: object              # mount + contact normal stiffness [N/m]
    fork_axis: object = None       # steering fork axis through the sphere centre (unit), None if fixed
    fork_ratio: float = 0.0        # the fork turns by fork_ratio·φ about fork_axis (its gear ratio); 0 if fixed
    fork: int | None = None        # index of its fork in the variant's steering.forks, None if fixed
    creep: CreepSource = CreepSource("theory", "theory only")   # where its creep compliance comes from
    friction: Friction = Friction(0.8, 0.8, 0.8, "not stated")  # of the roller's material on the sphere's


@dataclass(frozen=True)
class Frame:
    """The mounting plate, drawn by `cvtdesign export` only: perpendicular to `side`, its near face `distance`
    from the sphere centre."""
    side: object                   # unit vector from the sphere centre towards the plate (3-vector)
    distance: object               # [m]
    thickness: object              # [m]


@dataclass(frozen=True)
class Layout:
    """A resolved variant: what the compiler needs, in SI."""
    name: str
    file: str
    sphere_radius: object
    sphere_material: Material
    rollers: tuple[Roller, ...]
    creep_drive: object            # ε_D at the preload [1/N] or None (Hertz + Kalker)
    creep_steering: object         # ε_S at the preload [1/N] or None
    creep_reference_force: object  # normal force [N] at which ε_D, ε_S hold; None: each roller's preload
    effects: tuple[str, ...]
    effect_parameters: dict        # effect -> {param: SI value}
    gamma_grid: np.ndarray         # [rad]
    load_grid: np.ndarray          # [N m]
    motor_speed: float             # [rad/s]
    contact_law: str               # a core.contact.laws.LAWS name (the laws are chosen there)
    parameters: dict = field(default_factory=dict)
    calibration: dict = field(default_factory=lambda: {"drive": 1.0, "steering": 1.0})   # kalker compliance factors
    effect_uncertainty: dict = field(default_factory=dict)   # effect -> {param: SI 1σ} of fitted parameters
    forks: tuple[tuple[str, ...], ...] = ()   # each steering fork's rollers by name, in the file's order
                                              # (fork k + 1 is forks[k]; its axis and ratio: Roller.fork_*)
    frame: Frame | None = None     # the mounting plate, if the variant has one
    kim_vectors: tuple[str, ...] = ()     # Kim's frame vectors (core.geometry.KIM_FRAME) its file names ('d1')
    calibration_machine: bool = False  # the machine its calibration was measured on (core.inputs)
    preload_std: float = 0.20      # relative 1σ of every preload as built [-]
    preload_std_assumed: bool = True   # True: no σ stated (no paper states Kim et al.'s preload)
    spin_factor: object = 1.0      # factor on the spin moment a law computes (its own error: core.uncertainty)

    def with_effects(self, effects, parameters=None) -> "Layout":
        params = {k: dict(v) for k, v in self.effect_parameters.items()}
        for k, v in (parameters or {}).items():
            params.setdefault(k, {}).update(v)
        return replace(self, effects=tuple(effects), effect_parameters=params)
