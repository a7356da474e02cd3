"""What the dynamic model adds to a layout: the inertias and the steering motor, each with its source.

A variant may state each (its `dynamics:` section, io.variant); what it leaves out gets the default below, and
the source says which it is wherever the figure is shown. The defaults (docs/dynamics.md):

* **sphere**: a uniform solid sphere of the sphere material's density, J = (2/5) m R² (a bowling ball's core is
  denser than its shell, so the real J is up to about 10 % smaller);
* **rollers**: each a solid disc of its material's density, its radius and tread width, J = (1/2) m r² about its
  axle (a skate wheel's hub is lighter than urethane, so this is an upper bound);
* **output shaft (shaft 2)**: its rollers, J_2 = Σ ρ_i² J_i, and no load inertia: the cobot's own (its joint or
  wheel and what the operator moves) is the user's to add as `output_inertia`;
* **steering** (one degree of freedom φ: the forks are geared together, fork i turning by ρ_i φ): each fork's
  rollers as point masses at their centres plus their own inertia about an axis across the axle, the fork's own
  frame taken as heavy as its rollers (assumed), reflected to φ by ρ_i², plus the motor's rotor reflected
  through its gear;
* **steering motor**, seen at φ: a position servo (PID, its three closed-loop poles at −2π f_s on the steering
  inertia) limited by a linear torque-speed curve, τ ≤ τ_max (1 − |φ̇|/φ̇_max). Default τ_max 4 N·m (the motor
  of the shipped steering-effort study, studies/box_steering_effort.yaml), φ̇_max 2π rad/s (60 rpm at the
  forks), rotor 1e-3 kg·m² reflected (1e-6 kg·m² through a 30:1 gear), f_s 20 Hz: assumed, not a catalogue
  motor's; give your own;
* **relaxation length** σ = k_σ a, a the patch's semi-axis along the rolling direction, k_σ = 1: a brush
  contact's force builds over a rolled distance 2a, at an initial rate F_ss/a (Pacejka, *Tire and Vehicle
  Dynamics*, the relaxation length of a rolling contact; docs/dynamics.md derives it).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from cvtdesign.core.layout import Layout

MOTOR_DEFAULTS = {      # the steering motor at φ when the variant gives none (module docstring)
    "motor_torque": (4.0, "assumed: the 4 N·m motor of studies/box_steering_effort.yaml"),
    "motor_speed": (2 * np.pi, "assumed: 60 rpm at the forks"),
    "motor_inertia": (1e-3, "assumed: a 1e-6 kg·m² rotor through a 30:1 gear"),
    "servo_bandwidth": (20.0, "assumed: a 20 Hz position loop"),
    "relaxation_factor": (1.0, "σ = a, the brush contact's initial rate (Pacejka)"),
}
SERVO_3DB = 1.642467686020378   # x at which |(3jx + 1)/(1 + jx)³| = 1/√2: the servo's bandwidth / ω_p
FIELDS = ("sphere_inertia", "roller_inertia", "output_inertia", "steering_inertia", *MOTOR_DEFAULTS)


@dataclass(frozen=True)
class DynamicParameters:
    """The dynamic model's inputs in SI, and where each comes from (`sources`, FIELDS → words)."""
    sphere_inertia: float          # [kg m²] about any axis
    roller_inertia: tuple          # [kg m²] each roller's about its axle, in the layout's order
    output_inertia: float          # [kg m²] shaft 2 with its rollers
    steering_inertia: float        # [kg m²] the forks, their rollers and the motor's rotor, at φ
    motor_torque: float            # [N m] the steering motor's largest torque at φ
    motor_speed: float             # [rad/s] its no-load speed at φ
    motor_inertia: float           # [kg m²] its rotor at φ (included in steering_inertia)
    servo_bandwidth: float         # [Hz] the position servo's closed-loop poles, −2π f_s (triple)
    relaxation_factor: float       # [-] σ / a
    sources: dict

    def servo_gains(self) -> tuple[float, float, float]:
        """(K_p [N m/rad], K_i [N m/(rad s)], K_d [N m s/rad]) of the position servo u = K_p e + K_i ∫e − K_d φ̇
        on the steering inertia J alone: its three poles at −ω_p, J s³ + K_d s² + K_p s + K_i = J (s + ω_p)³,
        so that φ/φ_cmd = (K_p s + K_i)/(J (s + ω_p)³) falls to −3 dB at f_s: ω_p = 2π f_s / SERVO_3DB."""
        w, J = 2 * np.pi * self.servo_bandwidth / SERVO_3DB, self.steering_inertia
        return 3 * J * w ** 2, J * w ** 3, 3 * J * w

    def assumed(self) -> list[str]:
        """The fields that are defaults rather than the variant's own."""
        return [k for k in FIELDS if not self.sources[k].startswith("variant")]


def default_parameters(layout: Layout, densities: dict, given: dict | None = None) -> DynamicParameters:
    """The layout's DynamicParameters: `given` (FIELDS → SI value, from the variant's dynamics section) where
    stated, else the defaults of the module docstring from `densities` (material name → kg/m³)."""
    given = dict(given or {})
    R = float(layout.sphere_radius)
    sources = {}

    def pick(key, default, source):
        sources[key] = "variant: dynamics." + key if key in given else source
        return float(given.get(key, default))

    rho_s = densities[layout.sphere_material.name]
    sphere = pick("sphere_inertia", 0.4 * rho_s * 4 / 3 * np.pi * R ** 5,
                  f"default: a uniform solid sphere of {rho_s:g} kg/m³")
    discs = [_disc(r, densities[r.material.name]) for r in layout.rollers]
    rollers = tuple(float(given["roller_inertia"]) if "roller_inertia" in given else m * float(r.radius) ** 2 / 2
                    for r, m in zip(layout.rollers, discs))
    sources["roller_inertia"] = ("variant: dynamics.roller_inertia" if "roller_inertia" in given else
                                 "default: solid discs of their material's density, radius and width")
    own = sum(float(r.ratio) ** 2 * j for r, j in zip(layout.rollers, rollers) if r.role != "steering" and r.shaft == 2)
    output = pick("output_inertia", own, "default: shaft 2's rollers only, no load inertia")
    motor = {k: pick(k, *MOTOR_DEFAULTS[k]) for k in MOTOR_DEFAULTS}
    forks = sum(float(r.fork_ratio) ** 2 * 2 * _about_fork(r, m, R) for r, m in zip(layout.rollers, discs)
                if r.fork_axis is not None)
    steering = pick("steering_inertia", forks + motor["motor_inertia"],
                    "default: the forks (their rollers, and a frame as heavy) and the motor's rotor")
    return DynamicParameters(sphere, rollers, output, steering, sources=sources, **motor)


def _disc(roller, density: float) -> float:
    """Mass [kg] of a solid disc of the roller's radius and tread width."""
    return density * np.pi * float(roller.radius) ** 2 * float(roller.width)


def _about_fork(roller, mass: float, R: float) -> float:
    """A roller's inertia [kg m²] about its fork's axis (through the sphere centre): its centre, at (R + r) n,
    as a point mass, plus a disc's inertia about a diameter, m (r²/4 + w²/12)."""
    n, k = (np.array(ca.DM(v), float).ravel() for v in (roller.normal, roller.fork_axis))
    centre = (R + float(roller.radius)) * n
    arm = centre - (centre @ k) * k
    r, w = float(roller.radius), float(roller.width)
    return mass * (arm @ arm) + mass * (r ** 2 / 4 + w ** 2 / 12)
