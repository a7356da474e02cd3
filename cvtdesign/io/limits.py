"""What one evaluation may ask of the machine and of a variant's contacts: the points of an envelope axis
(MAX_GRID_POINTS, checked by io.variant.grid), the operating points of one run (check_points: MAX_POINTS, and
what half the free memory holds) and the loads the preloads can carry (load_capacity, check_loads). Each
refusal is one InputError line that names the field and gives the limit.
"""
from __future__ import annotations

from cvtdesign.core.effects import friction_factor
from cvtdesign.core.layout import Layout
from cvtdesign.errors import InputError
from cvtdesign.io import machine

MAX_SAMPLES = 10_000   # samples of the uncertain inputs that check the first-order intervals (compare, capacity)
MAX_GRID_POINTS = 100_000      # per envelope axis (γ, load): a 1e-9° step would otherwise allocate terabytes
# operating points of one evaluation (γ × load × speed): about a minute of the compiled model; fewer where half
# the machine's free memory holds fewer, at BYTES_PER_POINT for each of (4 + the rollers) (2.1 kB measured
# for the box CVT's 8 rollers). 94,119 γ × 95,239 loads would ask numpy for 67 GB.
MAX_POINTS = 1_000_000
BYTES_PER_POINT = 256
# a load may be at most LOAD_MARGIN × all the traction the preloads allow (load_capacity): beyond it no contact
# could carry it (the shipped variants keep no point ok beyond a quarter of it); the margin is for normal
# forces that grow under load. The range of io.variant.PLAUSIBLE["load"] holds for any variant; this one is
# the variant's.
LOAD_MARGIN = 2.0


def check_points(n: int, n_rollers: int, where: str, what: str = "operating points") -> None:
    """At most MAX_POINTS operating points in one evaluation, and no more than half this machine's free
    memory holds (BYTES_PER_POINT); else one InputError line giving the limit."""
    free = machine.free_memory()
    limit = MAX_POINTS if free is None else min(MAX_POINTS, free // (2 * BYTES_PER_POINT * (4 + n_rollers)))
    if n > limit:
        memory = "" if free is None else f", and what half of this machine's {free / 2**30:.1f} GB of free memory holds"
        raise InputError(f"{where}: {n:.4g} {what}; expected at most {limit} (at most {MAX_POINTS} in one run"
                         f"{memory}); a larger step")


def load_capacity(layout: Layout) -> float | None:
    """The largest load [N·m] a variant's envelope, protocol or duty cycle may ask for: LOAD_MARGIN × Σ μ_i
    P_i max(R, r_i |ratio_i|) over the contacts, with μ_i the friction coefficient of the roller's material on
    the sphere's (its pair's, io.materials.pair_friction; times the effects' friction factor, core.effects.friction_factor, if above 1), P_i
    the preload, R the sphere's radius and r_i the roller's: all the traction the preloads allow, at the longer
    of the arms it acts on (a shaft's torque is F·r). None when a value is symbolic (an optimiser's design parameter)."""
    scale = friction_factor(layout.effects, layout.effect_parameters)
    terms = [(r.friction.mu, r.preload, r.radius, r.ratio) for r in layout.rollers]
    if not all(isinstance(v, (int, float)) for v in [layout.sphere_radius, scale, *(v for t in terms for v in t)]):
        return None
    R = layout.sphere_radius
    return LOAD_MARGIN * max(1.0, scale) * sum(m * P * max(R, r * abs(k)) for m, P, r, k in terms)


def check_loads(fields, layout: Layout) -> None:
    """Each (where, load [N·m]) of `fields` within ±load_capacity(layout), else one InputError line naming
    the field (and N·mm, when the values look meant in it: '-1000..1000' read as N·m leaves 340 of 357
    points failed)."""
    cap = load_capacity(layout)
    for where, value in fields:
        if cap is not None and isinstance(value, (int, float)) and abs(value) > cap:
            hint = "; were the loads meant in N·mm? (plain numbers are N·m)" if abs(value) / 1000 <= cap else ""
            raise InputError(f"{where}: |τ| = {abs(value):.4g} N·m is more than this variant's contacts can carry; "
                             f"expected at most {cap:.3g} N·m ({LOAD_MARGIN:g} × Σ μ·P·max(R, r) over its "
                             f"contacts: all the traction its preloads allow){hint}")


def check_envelope_limits(layout: Layout, where: str) -> None:
    """The layout's envelope (or another of its γ and load grids, e.g. a study's) within what the machine
    can evaluate (check_points) and the loads within what its contacts can carry (check_loads)."""
    g, tau = layout.gamma_grid, layout.load_grid
    check_points(g.size * tau.size, len(layout.rollers), where,
                 f"operating points ({g.size} γ × {tau.size} loads)")
    check_loads([(f"{where}.load.start", float(tau[0])), (f"{where}.load.stop", float(tau[-1]))], layout)


def check_samples(given: int) -> int:
    """--samples of the uncertain inputs: 0 (first order only) or 20 to MAX_SAMPLES (fewer cannot place a 95 %
    interval's ends)."""
    if not 0 <= given <= MAX_SAMPLES or 0 < given < 20:
        raise InputError(f"--samples: {given}; expected 0 (first order only) or 20 to {MAX_SAMPLES:,} samples")
    return given
