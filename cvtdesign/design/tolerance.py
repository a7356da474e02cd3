"""Tolerance studies (`cvtdesign tolerance`): Monte Carlo over a variant's toleranced dimensions and its
uncertain physical inputs on Dask, and what the model's exact derivatives predict of it to first order.

The physical inputs (design.tolerance_inputs: compare's, with compare's distributions) are sampled with the
dimensions unless the study is `dimensions_only`; what is said of the dimensions below holds for them too,
their relative deviations following the dimensions' in the model's design vector (or θ, for the calibration).

The model. The variant is compiled once with the deviations x of its toleranced dimensions (io.tolerance_file,
core.tolerances) as symbols: its rollers are as built (core.tolerances.as_built), while the ideal law, γ, α
and the linkage's inverse kinematics stay the drawing's (core.model.compile_model's `as_built`: the machine
is commanded, and judged, by its drawing). A sample is one evaluation of the envelope at its x, and every
output's derivatives in x at x = 0 are exact (core.uncertainty.sensitivities: the implicit function theorem
through the Newton solve).

Sampling. The samples are drawn chunk by chunk (CHUNK samples; chunk c from the seed sequence (seed, c)), so
sample i is the same however many samples are asked for and however many workers draw them. Each chunk is a
case of the study runner (design.study: Dask with progress, one Parquet file a chunk in the store under its
lock): a re-run on the same store continues where it stopped, and asking for more samples adds chunks. A
chunk is one call of the compiled model, mapped over its samples × the envelope's points, with the samples' x
as inputs (core.metrics.envelopes). The model is built once, by this process: the workers get the C source of
its compiled point function with the study (`with_code`) and load its library from the cache (compiled once,
in the background, while the cluster starts), so no worker builds the model. A
sample's figures are compare's (core.metrics). A sample in which a point that holds at the drawing stops
holding (lost contact, gross slip, no convergence) gets no figures: it is counted, with why, and left out.

First order. Every output at every point of the envelope is taken to first order in x (its value at x = 0
plus its exact derivative times x), and each figure, a maximum, minimum or RMS over the points, is taken on
that linearised envelope. Where the extreme lies at one point, clear of the others, this gives mean = nominal
and σ² = Σ_j (∂f/∂x_j σ_j)². Where several points come close (the box's four symmetric worst corners), the
largest of their linearised values shifts the mean at first order in the tolerances, which the linearised
envelope predicts; no second-order term is used. Its mean and spread over LINEAR_DRAWS draws of its own are
`first_order_mean` and `first_order_std`. The same linearised envelope at each sample's own x gives that
sample's first-order value (the check on the same draws, free of sampling noise). A dimension's effect on a
figure is the figure's spread on the linearised envelope when that dimension alone deviates, in the figure's
unit (with one extreme point: |∂f/∂x_j| σ_j): the ranking of which tolerance matters most. The sensitivities
are checked against the sampling by the least-squares slope of each figure on each x_j (times σ_j), fitted to
the samples and to the first-order values at the same x (design.tolerance_stats.slopes).

Rigid directions. A direction tolerance (axle, contact, fork) means something only where the contacts are
compliant across it. Each is probed before anything is sampled: turned by PROBE (its contact moved by PROBE·R)
at the envelope point nearest γ = 0, τ⊥ = 0. Where the contacts then fight with more than RIGID_FORCE × the
smallest preload, or the point stops holding, the study is refused in one line. Under Kim's law the drive
rollers are rigid across their rolling direction: 1e-5° of box_kim.yaml's axle A makes its contacts fight with
131 N against a 100 N preload (existing_kim.yaml's: 87 N).
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, replace
from importlib import metadata
from pathlib import Path

import casadi as ca
import numpy as np
import pandas as pd

from cvtdesign.core import native
from cvtdesign.core.contact.laws import contact_law
from cvtdesign.core.inputs import deviated
from cvtdesign.core.layout import Layout
from cvtdesign.core.metrics import envelope, envelopes, metrics
from cvtdesign.core.model import CompiledModel, compile_model, library_model
from cvtdesign.core.status import STATUS
from cvtdesign.core.tolerances import DIRECTIONS, as_built, draw
from cvtdesign.design import cluster
from cvtdesign.design.store import done_cases, prepare_store, read_store, store_lock
from cvtdesign.design.study import Interrupted, run_cases
from cvtdesign.design.tolerance_inputs import design_inputs, model_arguments, sampled_inputs
from cvtdesign.design.tolerance_inputs import draw as draw_inputs
from cvtdesign.io.output import remove_stale_temps
from cvtdesign.errors import InputError
from cvtdesign.io.tolerance_file import load_tolerances
from cvtdesign.io.variant import load_variant

CHUNK = 10                 # samples a case of the store
LINEAR_DRAWS = 2000        # draws of the linearised envelope (its mean to ~2 % of its spread)
LINEAR_STREAM = 2 ** 32 - 1    # the seed sequence's second key of those draws (chunks count from 0)
PROBE = math.radians(1e-5)     # [rad] turn of a direction tolerance's probe
RIGID_FORCE = 0.01         # × the smallest preload: the contact force beyond which a probed direction is rigid
MAX_SAMPLES = 100_000
COLUMNS = ("case_id", "sample", "status")    # every chunk file has these (then the figures and x.<dimension>)
FIGURES = ("max_abs_alpha_deg", "rms_alpha_deg", "max_abs_alpha_steering_deg", "max_abs_alpha_drive_deg",
           "ratio_error_pct_at_max_load", "min_efficiency", "max_loss_no_output_W", "max_traction_utilisation",
           "max_hertz_pressure_MPa", "max_steering_torque_Nm", "max_standstill_steering_torque_Nm")   # compare's (core.metrics)


@dataclass(frozen=True)
class ToleranceContent:
    """A tolerance study as it travels to the workers: the resolved layout and dimensions (no worker reads a
    file), the seed, its name and `digest` (of the variant and tolerances files: an edited file is a new
    study), the tolerances file as this process names it (messages only) and, for the workers, the C source
    of the compiled model (`code`), so that none builds the model again."""
    path: str
    name: str
    digest: str
    layout: Layout
    dims: tuple
    seed: int
    code: str | None = None     # the C source of the model's point function (run_samples): workers load it
    inputs: tuple = ()          # the physical inputs sampled beside the dimensions (design.tolerance_inputs)
    left_out: tuple = ()        # ((label, why), …) of the physical inputs not sampled

    @property
    def sources(self) -> tuple:
        """What each sample draws, in its columns' order: the dimensions, then the physical inputs."""
        return tuple(self.dims) + tuple(self.inputs)

    @property
    def design_size(self) -> int:
        return len(self.dims) + len(design_inputs(self.inputs))


def tolerance_content(variant, tolerances, dimensions_only: bool = False) -> ToleranceContent:
    """Read and check the variant and the tolerances file (one InputError line for a bad one); with the
    variant's physical inputs to sample beside the dimensions unless `dimensions_only`."""
    layout = load_variant(variant)
    spec, dims = load_tolerances(tolerances, layout)
    inputs, left_out = ((), {}) if dimensions_only else sampled_inputs(layout, dims)
    h = hashlib.sha256(Path(variant).read_bytes())
    h.update(Path(tolerances).read_bytes())
    h.update(f"chunk {CHUNK}, figures {', '.join(FIGURES)}".encode())    # what a store's files hold
    if inputs:
        h.update(("inputs " + "; ".join(f"{s.key} {s.std!r} {s.distribution}" for s in inputs)).encode())
    return ToleranceContent(str(tolerances), spec.name, h.hexdigest()[:16], layout, dims, spec.seed, None, inputs,
                            tuple(left_out.items()))


def tolerance_model(layout: Layout, dims, inputs=()) -> CompiledModel:
    """The layout compiled with its dimensions' deviations, then its sampled physical inputs' (design
    inputs only: design.tolerance_inputs), as the design symbols (module docstring)."""
    phys = design_inputs(inputs)
    x = ca.SX.sym("x", len(dims) + len(phys))
    built = as_built(layout, dims, [x[j] for j in range(len(dims))])
    if phys:
        built = deviated(built, phys, [x[len(dims) + j] for j in range(len(phys))])
    return compile_model(layout, design=x, as_built=built)


_MODELS: dict = {}      # process-local: the content's model and its envelope at the drawing, by digest


def built_model(content: ToleranceContent) -> tuple[CompiledModel, dict]:
    """(the content's model, its envelope at x = 0), once per process: built, or, given the compiled model's
    source (`code`: a worker), loaded from it (evaluation only; built where there is no C compiler)."""
    if content.digest not in _MODELS:
        _MODELS.clear()
        model = content.code and library_model(content.layout, content.code, content.design_size)
        model = model or tolerance_model(content.layout, content.dims, content.inputs)
        _MODELS[content.digest] = model, envelope(model, design=np.zeros(content.design_size))
    return _MODELS[content.digest]


def with_code(content: ToleranceContent) -> ToleranceContent:
    """The content with its model's compiled source (`code`) for the workers, its library compiled meanwhile in
    the background (core.native: the workers wait for it, in the cache, rather than each build the model)."""
    if content.code is not None:
        return content
    code = built_model(content)[0].point_source()
    if (command := native.compiler()) is not None and not native.verified(native.library_path(code, command)):
        native.build_detached(code, command)
    return replace(content, code=code)


def check_directions(model: CompiledModel, dims, where: str) -> None:
    """Each direction tolerance probed (module docstring); one InputError line for the first that is rigid."""
    L = model.layout
    g, t = L.gamma_grid[np.argmin(np.abs(L.gamma_grid))], L.load_grid[np.argmin(np.abs(L.load_grid))]
    pf = model.point_function(["status", "F_t", "F_a"])
    phi0 = model.steering_guess([g])[0][0]
    preload = min(float(r.preload) for r in L.rollers)

    def forces(x):
        status, ft, fa = (np.asarray(v, float).ravel() for v in pf(g, L.motor_speed, t, 0.0, phi0, model.param_values, x))
        return status[0], np.column_stack([ft, fa])

    _, drawn = forces(np.zeros(model.design.numel()))
    for j, d in enumerate(dims):
        if d.kind not in DIRECTIONS:
            continue
        x = np.zeros(model.design.numel())
        x[j] = PROBE * (float(L.sphere_radius) if d.kind == "contact" else 1.0)
        status, built = forces(x)
        force = float(np.max(np.linalg.norm(built - drawn, axis=1)))
        if status == 0 and force <= RIGID_FORCE * preload:
            continue
        moved = f"moved by only {x[j] * 1e3:.2g} mm" if d.kind == "contact" else "turned by only 1e-5°"
        held = "" if status == 0 else f", where they {STATUS[int(status)].replace('_', ' ')}"
        roles = sorted({r.role for r in L.rollers if r.name in d.rollers})
        why = (f"law {L.contact_law} holds {' and '.join(roles)} rollers rigid across their rolling direction (no effect "
               "makes it compliant), so their directions would have to be exact to about 1e-9 rad"
               if contact_law(L.contact_law).rigid_unless_effects else f"law {L.contact_law} holds that direction rigid")
        raise InputError(f"{where}: tolerances.{d.entry}: the {d.label} is not a meaningful tolerance under contact law "
                         f"{L.contact_law}: {moved}, it already makes the contacts fight with {force:.3g} N more "
                         f"({force / preload:.2g} × the {preload:g} N preload) at γ = {math.degrees(g):g}°, "
                         f"τ⊥ = {t:g} N·m{held}; {why}; expected contact.law: kalker, under which every direction is "
                         "compliant, or direction tolerances on the compliant rollers only")


def chunk_draws(content: ToleranceContent, chunk: int) -> np.ndarray:
    """The deviations of chunk `chunk`'s CHUNK samples, (CHUNK, dimensions + inputs) [SI]."""
    return stream_draws(content, chunk, CHUNK)


def stream_draws(content: ToleranceContent, stream: int, n: int) -> np.ndarray:
    """n samples of stream `stream` (a chunk, or the first order's LINEAR_STREAM), (n, dimensions + inputs):
    the dimensions' deviations [SI] from the seed sequence (seed, stream), then the physical inputs' relative
    ones from a stream of their own (design.tolerance_inputs.draw)."""
    dims = draw(content.dims, np.random.default_rng([content.seed, stream]), n)
    if not content.inputs:
        return dims
    return np.column_stack([dims, draw_inputs(content.inputs, n, content.seed, stream)])


def figures(model: CompiledModel, res: dict) -> dict:
    """compare's figures (FIGURES) of an envelope result, NaN where one has no point to be taken over."""
    m = metrics(model, res)
    return {k: np.nan if m[k] is None else float(m[k]) for k in FIGURES}


def sample_row(model: CompiledModel, nominal: dict, dims, x: np.ndarray, res: dict) -> dict:
    """One sample of deviations x [SI] and its envelope `res`: its status ('ok', or how many of the drawing's
    ok points stopped holding, by status), its figures (NaN unless ok) and its deviations x.<label> (`dims`:
    the content's sources, dimensions and inputs)."""
    lost = np.ravel(nominal["ok"] & ~res["ok"])
    codes = np.ravel(res["status"])[lost]
    status = "ok" if not lost.any() else ", ".join(f"{STATUS[c]} ×{int(np.sum(codes == c))}" for c in np.unique(codes))
    figs = figures(model, res) if status == "ok" else dict.fromkeys(FIGURES, np.nan)
    return {"status": status, "points_lost": int(lost.sum()), **figs} | {f"x.{d.label}": float(v) for d, v in zip(dims, x)}


def run_chunk(content: ToleranceContent, case: dict, out_dir: str) -> dict:
    """One chunk of samples in a worker, from `content` alone: {"rows", "files"} as design.study.run_case. The
    chunk's envelopes are one call of the compiled model over its samples × points (core.metrics.envelopes)."""
    model, nominal = built_model(content)
    x = chunk_draws(content, case["chunk"])
    design, theta = model_arguments(model, len(content.dims), content.inputs, x)
    rows = [{"case_id": case["id"], "sample": case["chunk"] * CHUNK + i} | sample_row(model, nominal, content.sources,
                                                                                      x[i], res)
            for i, res in enumerate(envelopes(model, design, theta))]
    return {"rows": rows, "files": {}}


def failure_rows(case: dict, status: str) -> list[dict]:
    """The row of a chunk that raised (its status says why; the next run runs it again)."""
    return [{"case_id": case["id"], "sample": -1, "status": status}]


def check_run(n, workers: int | None, scheduler: str | None = None) -> None:
    """One InputError line for a number of samples or of workers that cannot be run."""
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_SAMPLES:
        raise InputError(f"--samples: expected a number of samples from 1 to {MAX_SAMPLES}, got {n}")
    cluster.check_workers(workers, scheduler)


def run_samples(content: ToleranceContent, n: int, out_dir, where: tuple = (None, None), progress=None,
                notice=None) -> tuple[pd.DataFrame, list[str]]:
    """The first n samples, drawn on Dask (where: (scheduler, workers), as design.study's) into the store
    `out_dir` where it does not hold them yet (module docstring); `progress(done, n, row)` follows them.
    Returns (one row a sample, in order; the statuses of the chunks that failed to run, whose samples are
    missing: the next run runs them again)."""
    check_run(n, where[1], where[0])
    content = with_code(content)
    out_dir = Path(out_dir)
    cases = [{"id": f"chunk{c:05d}", "chunk": c} for c in range(math.ceil(n / CHUNK))]
    versions = {p: metadata.version(p) for p in ("cvtdesign", "casadi", "numpy", "dask", "pyarrow")}
    man = {"tolerance_study": content.name, "tolerances_file": content.path, "variant_file": content.layout.file,
           "study_hash": content.digest, "seed": content.seed, "samples_per_chunk": CHUNK, "versions": versions}
    with store_lock(out_dir):
        prepare_store(content.path, None, content.digest, out_dir, man=man, option="--store")
        for folder in (out_dir, out_dir / "cases"):
            if folder.is_dir():
                remove_stale_temps(folder)
        finished = done_cases(out_dir, cases, notice=notice, columns=COLUMNS, rows=lambda c: {CHUNK})
        todo = [c for c in cases if c["id"] not in finished]
        written: list[str] = []

        def step(row):
            if progress:
                progress(min(n, CHUNK * (len(finished) + len(written))), n, row)

        step(None)
        if todo:
            try:
                run_cases(content, todo, out_dir, where, written, step, task=run_chunk,
                          failure=failure_rows, assign=lambda todo_, names: [(c, None, 0) for c in todo_])
            except KeyboardInterrupt:
                kept = len(done_cases(out_dir, cases, columns=COLUMNS, rows=lambda c: {CHUNK}))
                raise Interrupted(f"interrupted: {min(n, kept * CHUNK)} of {n} samples finished and kept in "
                                  f"{out_dir}; run again to resume") from None
        table = read_store(out_dir, COLUMNS)
    failed = table[(table["sample"] < 0) & table["case_id"].isin([c["id"] for c in cases])]
    table = table[table["sample"].between(0, n - 1)].sort_values("sample", ignore_index=True)
    return table, list(failed["status"])
