"""The temperature of a roller: a lumped thermal model with its heat capacity, convection from its surfaces
and conduction through its tread to the hub, steady and over a duty cycle, and the flash temperature of the
contact on top; units SI (temperatures in K).

 * Lumped model: C dT/dt = Q − G (T − T_amb), G = h·A + G_hub. The tread (urethane between the hub radius
   r_h and the roller's r, width w) holds the heat: C = ρ c π (r² − r_h²) w. The hub and shaft are taken at
   the ambient temperature (a metal hub in the frame). Conduction from the tread to the hub through the
   annulus: G_hub = 2π k w / ln(r/r_h). The urethane's Biot number h(r − r_h)/k is near 1, so the lumped
   model is a first estimate, to be checked by a heat-build-up test (docs/life.md).
 * Convection from a cylinder turning in still air (Incropera and DeWitt, "Fundamentals of heat and mass
   transfer", rotating cylinder): Nu_D = 0.133 Re_D^(2/3) Pr^(1/3), Re_D = ω D²/ν, for Re_D < 4.3e5; never
   below free convection, H_FREE.
 * Over a cycle the heat Q_k and conductance G_k of each step are constant, so each step is exact:
   T_{k+1} − T_ss,k = (T_k − T_ss,k) exp(−G_k Δt_k / C). Repeated, the cycle settles to a periodic state,
   found in closed form (the map over one cycle is linear in the starting temperature).
 * Flash temperature (Blok; Jaeger's moving heat source), as Tian and Kennedy fit it for a uniform circular
   source of radius a at any Péclet number Pe = V a / (2κ): ΔT_max = 2 q a / (k √(π (1.273 + Pe))), q the
   heat flux into the body. An elliptical patch is taken as the circle of the same area, a = √(a b).
 * Frictional heat divides between the two bodies in proportion to their thermal effusivities √(kρc)
   (Blok's partition for fast sliding).
"""
from __future__ import annotations

import math

import numpy as np

AIR_CONDUCTIVITY = 0.026     # [W/(m K)] air at 25 °C
AIR_VISCOSITY = 1.6e-5       # [m²/s] kinematic, air at 25 °C
AIR_PRANDTL = 0.71
H_FREE = 5.0                 # [W/(m² K)] free convection from a small body in still air (the floor of h)


def convection_coefficient(omega, r):
    """h [W/(m² K)] of a roller of radius r [m] turning at ω [rad/s] in still air (module docstring)."""
    D = 2.0 * r
    re = np.abs(np.asarray(omega, float)) * D * D / AIR_VISCOSITY
    h = 0.133 * re ** (2.0 / 3.0) * AIR_PRANDTL ** (1.0 / 3.0) * AIR_CONDUCTIVITY / D
    return np.maximum(h, H_FREE)


def surface_area(r, w, hub_ratio):
    """The roller's surface that convects [m²]: its tread's rim 2πrw and both faces of the tread annulus."""
    return 2.0 * math.pi * r * w + 2.0 * math.pi * r * r * (1.0 - hub_ratio ** 2)


def hub_conductance(k, w, hub_ratio):
    """Conduction through the tread annulus to the hub [W/K]: 2π k w / ln(r/r_h)."""
    return 2.0 * math.pi * k * w / math.log(1.0 / hub_ratio)


def heat_capacity(rho, c, r, w, hub_ratio):
    """The tread's heat capacity [J/K]: ρ c π (r² − r_h²) w."""
    return rho * c * math.pi * r * r * (1.0 - hub_ratio ** 2) * w


def steady_temperature(Q, G, T_ambient):
    """The steady temperature [K] at heat Q [W] and conductance G [W/K] to the ambient."""
    return T_ambient + np.asarray(Q, float) / np.asarray(G, float)


def cycle_temperatures(Q, G, seconds, C, T_ambient):
    """The periodic temperatures over a repeated cycle of steps (Q_k [W], G_k [W/K], Δt_k [s]; module
    docstring): (T at the start of each step, the mean over each step, the cycle's mean) [K]."""
    Q, G, dt = (np.asarray(x, float) for x in (Q, G, seconds))
    ss = Q / G
    decay = np.exp(-G * dt / C)

    def run(theta0):
        starts, th = np.empty(len(Q)), theta0
        for k in range(len(Q)):
            starts[k] = th
            th = ss[k] + (th - ss[k]) * decay[k]
        return starts, th

    _, B = run(0.0)
    A = float(np.prod(decay))
    starts, _ = run(B / (1.0 - A) if A < 1 else 0.0)
    x = G * dt / C
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(x > 1e-12, (1 - decay) / np.where(x > 1e-12, x, 1), 1.0)
    means = ss + (starts - ss) * frac
    return T_ambient + starts, T_ambient + means, T_ambient + float(np.sum(means * dt) / np.sum(dt))


def warm_up_time(T_limit, T_steady, T_ambient, C, G):
    """The time [s] a body starting at the ambient takes to reach T_limit on its way to T_steady (time
    constant C/G): 0 when it starts over it, inf when it never reaches it."""
    if T_limit <= T_ambient:
        return 0.0
    if T_steady <= T_limit:
        return math.inf
    return -C / G * math.log(1.0 - (T_limit - T_ambient) / (T_steady - T_ambient))


def effusivity(k, rho, c):
    """Thermal effusivity √(kρc) [W s^½/(m² K)]."""
    return math.sqrt(k * rho * c)


def heat_share(e_body, e_other):
    """The share of frictional heat that goes into a body (Blok's partition by effusivity) [-]."""
    return e_body / (e_body + e_other)


def flash_temperature(Q, a, b, V, k, rho, c, seconds=math.inf):
    """The flash temperature rise ΔT_max [K] of a body taking heat Q [W] over an elliptical patch of
    semi-axes a, b [m] moving over it at V [m/s] (module docstring: Tian and Kennedy's fit of Jaeger), for a
    source that acts `seconds` [s]: at most the rise of a uniform flux q switched on for that time over a
    half-space, 2q√(κt/π)/k (Jaeger; Carslaw and Jaeger, "Conduction of heat in solids", sec. 2.9), which
    bounds a slow patch (small Pe) that does not last long enough to reach its steady rise."""
    a_e = np.sqrt(np.asarray(a, float) * np.asarray(b, float))
    q = np.asarray(Q, float) / (math.pi * a_e * a_e)
    kappa = k / (rho * c)
    pe = np.abs(np.asarray(V, float)) * a_e / (2.0 * kappa)
    steady = 2.0 * q * a_e / (k * np.sqrt(math.pi * (1.273 + pe)))
    return np.minimum(steady, 2.0 * q * np.sqrt(kappa * np.asarray(seconds, float) / math.pi) / k)


def cycle_curve(starts, Q, G, seconds, C, T_ambient, samples: int = 12):
    """The temperature over one periodic cycle, `samples` times a step (cycle_temperatures' exact
    exponentials): (times [s] from the cycle's start, temperatures [K])."""
    t, T, t0 = [], [], 0.0
    for T0, q, g, dt in zip(starts, Q, G, seconds):
        s = np.linspace(0.0, dt, samples)
        ss = T_ambient + q / g
        t.append(t0 + s)
        T.append(ss + (T0 - ss) * np.exp(-g * s / C))
        t0 += dt
    return np.concatenate(t), np.concatenate(T)


def warm_up_curve(T_steady, T_ambient, C, G, spans: float = 5.0, samples: int = 60):
    """A body's temperature from the ambient towards T_steady (time constant C/G) over `spans` time
    constants: (times [s], temperatures [K])."""
    t = np.linspace(0.0, spans * C / G, samples)
    return t, T_ambient + (T_steady - T_ambient) * (1.0 - np.exp(-G * t / C))
