"""The physical inputs a tolerance study samples beside the toleranced dimensions (issue 33): every uncertain
input of core.inputs (the calibration with the σ of its fit, the preload, each material's modulus, each pair's
friction, the contact law's own error on the spin moment, fitted effect parameters), with compare's
distributions (core.uncertainty.draw: normal, uniform for friction and the law's error).

Where they enter the model. The physical inputs' relative deviations are the design vector's columns after
the dimensions' (core.inputs.deviated applied to the machine as built, so a preload toleranced and deviated
is P·(1 + x_dimension)(1 + x_input)); the calibration's and effects' are added to the model's θ entries, as
compare's sampling does (core.uncertainty.sampled_figures). So one compiled model, mapped over samples ×
points, evaluates both in one call, and its exact derivatives in both rank them side by side.

Inputs of one key are one quantity (two roles on one calibration): one sampled input, one draw, every column
it moves. The variant's own preload (its `preload_std`, the spread of every preload as built) is the same
quantity as a preload tolerance on every roller: where the tolerances file tolerances each roller's preload,
that file states it, and the variant's is left out (`left_out`, with why).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cvtdesign.core.effects import parameter_vector
from cvtdesign.core.inputs import Input, physical_inputs, theta_inputs
from cvtdesign.core.layout import Layout
from cvtdesign.core.uncertainty import draw as draw_inputs

UNIFORM = ("friction", "spin")      # the kinds core.uncertainty.draw draws uniformly (±σ√3); the others normal


@dataclass(frozen=True)
class Sampled:
    """One physical input of a tolerance study: its `key`, `label`, `kind` (core.inputs.Input), relative σ
    `std` [-], `assumed` where no file states it, and the core.inputs entries it moves (one key: one draw)."""
    key: str
    label: str
    kind: str
    std: float
    assumed: bool
    entries: tuple[Input, ...]

    @property
    def distribution(self) -> str:
        return "uniform" if self.kind in UNIFORM else "normal"

    @property
    def size(self) -> float:
        """σ of a normal distribution, the half-width of a uniform one [-] (as a Dimension's `size`)."""
        return self.std * math.sqrt(3.0) if self.distribution == "uniform" else self.std


def sampled_inputs(layout: Layout, dims) -> tuple[tuple[Sampled, ...], dict]:
    """(the physical inputs of `layout` to sample, θ ones first, then the design ones in core.inputs'
    order; {label: why} of those left out: the variant's own preload where `dims` tolerance every roller's
    preload)."""
    names = parameter_vector(layout.effects, layout.effect_parameters)[0]
    toleranced = {name for d in dims if d.kind == "preload" for name in d.rollers}
    every_preload = {r.name for r in layout.rollers} <= toleranced
    out, left_out = {}, {}
    for i in theta_inputs(layout, names) + physical_inputs(layout):
        if i.kind == "preload" and every_preload:
            left_out[i.label] = "the tolerances file tolerances every roller's preload: its spread is that file's"
            continue
        if i.key in out:
            out[i.key] = out[i.key] + (i,)
        else:
            out[i.key] = (i,)
    return tuple(Sampled(e[0].key, e[0].label, e[0].kind, e[0].std, e[0].assumed, e) for e in out.values()), left_out


def design_inputs(inputs) -> list[Input]:
    """The core.inputs entries of the design vector's columns after the dimensions', in order."""
    return [e for s in inputs for e in s.entries if not e.in_theta]


def stream_seed(seed: int, stream: int) -> int:
    """The seed of the inputs' draws of stream `stream` (a chunk, or the first order's own draws) of a study
    seeded `seed`: one integer from the seed sequence (seed, stream, 1), apart from the dimensions' (seed, stream)."""
    return int(np.random.SeedSequence([seed, stream, 1]).generate_state(1)[0])


def draw(inputs, n: int, seed: int, stream: int) -> np.ndarray:
    """n samples of the inputs' relative deviations, (n, len(inputs)), as core.uncertainty.draw draws them."""
    return draw_inputs([s.entries[0] for s in inputs], n, stream_seed(seed, stream))


def model_arguments(model, n_dims: int, inputs, xs: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """(design vectors (n, design size), θ vectors (n, θ size) or None where no θ input is sampled) of the
    samples `xs` (n, dimensions + inputs): the dimensions' deviations, then each design input's (its key's
    draw); θ the model's own plus each θ input's."""
    xs = np.atleast_2d(xs)
    columns = [n_dims + k for k, s in enumerate(inputs) for e in s.entries if not e.in_theta]
    design = np.column_stack([xs[:, :n_dims], xs[:, columns]]) if columns else xs[:, :n_dims]
    thetas = [(model.param_names.index(e.target), n_dims + k) for k, s in enumerate(inputs) for e in s.entries
              if e.in_theta]
    if not thetas:
        return design, None
    theta = np.tile(np.asarray(model.param_values, float).ravel(), (len(xs), 1))
    for p, k in thetas:
        theta[:, p] += xs[:, k]
    return design, theta


def columns(model, n_dims: int, inputs) -> tuple[list[int], np.ndarray]:
    """(the θ entries of the sampled θ inputs, in order; the matrix (θ entries + design size, dimensions +
    inputs) that carries the model's derivatives in those θ entries and its design vector to the derivatives
    in each dimension and input: a key moves every column of its entries)."""
    theta_idx = [model.param_names.index(e.target) for s in inputs for e in s.entries if e.in_theta]
    n_design = model.design.numel()
    E = np.zeros((len(theta_idx) + n_design, n_dims + len(inputs)))
    E[len(theta_idx) + np.arange(n_dims), np.arange(n_dims)] = 1.0
    t, d = 0, n_dims
    for k, s in enumerate(inputs):
        for e in s.entries:
            if e.in_theta:
                E[t, n_dims + k], t = 1.0, t + 1
            else:
                E[len(theta_idx) + d, n_dims + k], d = 1.0, d + 1
    return theta_idx, E
