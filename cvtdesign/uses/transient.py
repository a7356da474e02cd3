"""Transient steering dynamics of variants, as `cvtdesign transient` computes them (core.dynamics,
docs/dynamics.md): a step of the commanded γ at a load and its lag, rise, settling and overshoot; the fastest
ratio change the steering drives and what limits it; the small-signal bandwidth of γ_axis/γ_cmd and of the ratio
at chosen operating points; the ratio error while a cobot renders a sinusoidal constraint. Each figure where the
physics stopped holding (no steady state, gross slip, an unstable linearisation) is null with its reason. The
command (cli/transient.py) prints and writes what transient_run returns."""
from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np

from cvtdesign.core import basis
from cvtdesign.core.dynamics.linear import linear_at
from cvtdesign.core.dynamics.model import compile_dynamics
from cvtdesign.core.dynamics.parameters import FIELDS
from cvtdesign.core.dynamics.render import render
from cvtdesign.core.dynamics.response import RATE_RANGE, Step, fastest_change, start, step_response
from cvtdesign.errors import InputError, shorten
from cvtdesign.io import plots
from cvtdesign.io.dynamics import KIND, dynamic_parameters
from cvtdesign.io.output import make_folder, named_after
from cvtdesign.io.units import check_range, to_si
from cvtdesign.uses.comparison import as_layout
from cvtdesign.uses.result import Result, table_row

GAMMA_FROM, GAMMA_TO = "10 deg", "40 deg"       # the step's defaults
BANDWIDTH_AT = "10 deg,25 deg,40 deg"            # the bandwidth's operating points by default
LOAD_SHARE = 0.5            # the default load: this share of the envelope's largest |τ⊥|
RENDER_HZ = 1.0             # [Hz] the rendered profile's frequency by default
BODE_HZ = np.logspace(-1, 3, 161)      # [Hz] where the Bode plot is drawn
UNITS = {"inertia": "kg·m²", "torque": "N·m", "speed": "rad/s", "frequency": "Hz", "dimensionless": ""}
QUICK = "not computed (--quick)"


@dataclasses.dataclass(frozen=True)
class Settings:
    """What the command asks (SI): the step's γ from and to [rad], the load τ⊥ [N m] (None: each variant's
    default, LOAD_SHARE of its envelope's largest |τ⊥|), the bandwidth's γ [rad], the rendering's frequency
    [Hz], and `quick` (no fastest-change search and no rendering: their figures null with QUICK)."""
    gamma_from: float
    gamma_to: float
    load: float | None
    bandwidth_at: tuple
    render_hz: float
    quick: bool = False


def _angle(text, where: str) -> float:
    value = to_si(text, "angle", where)
    return check_range(value, text, where, "commanded angle γ", "angle", lo=-math.pi / 2, hi=math.pi / 2,
                       lo_open=True, hi_open=True, guess="deg")


def settings(gamma_from=GAMMA_FROM, gamma_to=GAMMA_TO, load=None, bandwidth_at=BANDWIDTH_AT, render_hz=RENDER_HZ,
             quick=False) -> Settings:
    """The command's options checked and in SI (each bad one a one-line InputError naming it): angles with their
    unit ('10 deg'; a plain number is in rad, as everywhere), the load a torque ('0.5 N*m'), the bandwidth's
    angles comma-separated, the rendering's frequency [Hz] finite and positive."""
    g0, g1 = _angle(gamma_from, "--gamma-from"), _angle(gamma_to, "--gamma-to")
    if g0 == g1:
        raise InputError(f"--gamma-to: {gamma_to} is --gamma-from's angle; expected another γ to step to")
    tau = None if load is None else to_si(load, "torque", "--load")
    text = ",".join(bandwidth_at) if isinstance(bandwidth_at, (list, tuple)) else str(bandwidth_at)
    at = tuple(_angle(v, "--bandwidth-at") for v in text.split(","))
    try:
        hz = float(render_hz)
    except (TypeError, ValueError):
        raise InputError(f"--render-hz: expected a frequency in Hz like 1, got '{shorten(str(render_hz))}'") from None
    if not (math.isfinite(hz) and hz > 0):
        raise InputError(f"--render-hz: expected a finite positive frequency in Hz like 1, got {render_hz}")
    return Settings(g0, g1, tau, at, hz, bool(quick))


def check_envelope(layout, s: Settings) -> float:
    """The settings inside the variant's envelope (where its model is validated): each γ within its γ range and
    the load within its load range; returns the load [N m] (the default where none is given)."""
    glo, ghi = float(np.min(layout.gamma_grid)), float(np.max(layout.gamma_grid))
    lo, hi = float(np.min(layout.load_grid)), float(np.max(layout.load_grid))
    for option, values in (("--gamma-from", [s.gamma_from]), ("--gamma-to", [s.gamma_to]),
                           ("--bandwidth-at", s.bandwidth_at)):
        for g in values:
            if not glo - 1e-12 <= g <= ghi + 1e-12:
                raise InputError(f"{option}: γ {math.degrees(g):g}° is outside the envelope's γ range "
                                 f"{math.degrees(glo):g}..{math.degrees(ghi):g}° of {layout.file}; expected a γ in "
                                 "that range")
    load = LOAD_SHARE * max(abs(lo), abs(hi)) if s.load is None else s.load
    if not lo - 1e-12 <= load <= hi + 1e-12:
        raise InputError(f"--load: τ⊥ = {load:g} N·m is outside the envelope's load range {lo:g}..{hi:g} N·m of "
                         f"{layout.file}; expected a load in that range")
    return float(load)


def parameters_record(p) -> dict:
    """The dynamic parameters as JSON: each field's value in SI with its unit and source, and the list of the
    assumed ones (defaults, not the variant's own)."""
    out = {}
    for k in FIELDS:
        v = getattr(p, k)
        out[k] = {"value": list(v) if isinstance(v, tuple) else v, "unit": UNITS[KIND[k]], "source": p.sources[k]}
    return {"values": out, "assumed": p.assumed()}


def step_record(st, gamma_from, gamma_to, load, tau_2=None) -> dict:
    """The step's JSON (the interface's keys, then shaft 2's torque τ2 [N m] held from the start at the load
    τ⊥, ok and reason): None where the run left the physics, or a time not reached within the run."""
    rec = {"gamma_from_deg": math.degrees(gamma_from), "gamma_to_deg": math.degrees(gamma_to), "load_Nm": load,
           "rise_s": st.rise_s, "settle_s": st.settle_s, "overshoot_pct": st.overshoot_pct, "lag_s": st.lag_s,
           "tau_2_Nm": tau_2, "ok": st.ok, "reason": st.reason or None}
    if st.ok and (st.settle_s is None or st.rise_s is None or st.lag_s is None):
        rec["reason"] = "not settled within the run" if st.lag_s is not None else "the step not reached within the run"
    return rec


def rate_record(fc) -> dict:
    """The fastest ratio change's JSON: max_rate_deg_s [°/s] and max_rate_limit; where no rate is a figure (no
    steady state, a contact slipping grossly already at the slowest rate searched, no limit met up to the
    fastest) the rate is None and max_rate_reason says why."""
    if fc is None:
        return {"max_rate_deg_s": None, "max_rate_limit": None, "max_rate_reason": QUICK}
    lo, hi = RATE_RANGE
    if fc.limit == "none":
        return {"max_rate_deg_s": None, "max_rate_limit": "none",
                "max_rate_reason": f"no limit met up to {hi:g} °/s, the fastest rate searched"}
    if fc.rate_deg_s <= 0:
        why = (fc.limit if fc.limit.startswith("no steady state") else
               f"{fc.limit} already at {lo:g} °/s, the slowest rate searched")
        return {"max_rate_deg_s": None, "max_rate_limit": fc.limit, "max_rate_reason": why}
    return {"max_rate_deg_s": fc.rate_deg_s, "max_rate_limit": fc.limit, "max_rate_reason": None}


def bandwidth_record(lin, gamma, load) -> dict:
    """One operating point's bandwidth JSON: f3dB_Hz of γ_axis/γ_cmd and ratio_f3dB_Hz of the ratio [Hz], None
    with the reason where there is no steady state, the linearisation is unstable or no −3 dB is reached."""
    rec = {"gamma_deg": math.degrees(gamma), "load_Nm": load, "f3dB_Hz": None, "ratio_f3dB_Hz": None, "reason": None}
    if lin is None:
        return rec | {"reason": "no steady state"}
    if not lin.stable:
        return rec | {"reason": "unstable: a pole of the linearised model in the right half-plane"}
    rec["f3dB_Hz"], rec["ratio_f3dB_Hz"] = lin.bandwidth("gamma_axis"), lin.bandwidth("ratio")
    if rec["f3dB_Hz"] is None or rec["ratio_f3dB_Hz"] is None:
        rec["reason"] = "the response stays above −3 dB up to 10 kHz"
    return rec


def rendering_record(r, s: Settings, load) -> dict:
    """The rendering's JSON: the RMS and largest ratio errors [-] (ω2/ω1) of the dynamic and of the quasi-static
    model over the last period, None with the reason where it left the physics."""
    rec = {"frequency_Hz": s.render_hz, "gamma_from_deg": math.degrees(s.gamma_from),
           "gamma_to_deg": math.degrees(s.gamma_to), "load_Nm": load}
    keys = ("rms_error_dynamic", "max_error_dynamic", "rms_error_quasi_static", "max_error_quasi_static")
    if r is None or not r.ok:
        return rec | dict.fromkeys(keys) | {"reason": QUICK if r is None else r.reason}
    return rec | dict(zip(keys, (r.rms_dynamic, r.max_dynamic, r.rms_quasi_static, r.max_quasi_static))) | \
        {"reason": None}


def curves(st, lins, r, s: Settings) -> dict:
    """The figures' data of one variant: the step's time response (t [ms], γ_cmd, γ_axis and α [°], ratio), the
    Bode curves at each bandwidth point (|H|/|H(0)| [dB], phase [°]) and the rendered ratios over time."""
    out = {"step": None, "bode": [], "render": None}
    if st.trajectory is not None:
        tr = st.trajectory
        out["step"] = {"t_ms": tr.t * 1e3, "gamma_cmd_deg": np.where(tr.t > 0, math.degrees(s.gamma_to),
                                                                      math.degrees(s.gamma_from)),
                       "gamma_axis_deg": np.degrees(tr.out["gamma_axis"]), "ratio": tr.out["ratio"],
                       "alpha_deg": np.degrees(tr.out["alpha"])}
    for g, lin in zip(s.bandwidth_at, lins):
        if lin is None or not lin.stable:
            continue
        row = {"gamma_deg": math.degrees(g), "f_Hz": BODE_HZ}
        for sig in ("gamma_axis", "ratio"):
            h = lin.response(sig, BODE_HZ) / lin.response(sig, [0.0])[0]
            row[f"{sig}_dB"], row[f"{sig}_phase_deg"] = 20 * np.log10(np.abs(h)), np.degrees(np.unwrap(np.angle(h)))
        out["bode"].append(row)
    if r is not None and r.ok:
        out["render"] = {"t_s": r.t, "commanded": r.commanded, "dynamic": r.dynamic, "quasi_static": r.quasi_static,
                         "frequency_Hz": s.render_hz}
    return out


def variant_run(layout, name: str, s: Settings, progress) -> tuple[dict, dict]:
    """One variant's JSON record and its figures' data (curves); progress(text) told before each part."""
    load = check_envelope(layout, s)
    params = dynamic_parameters(layout)
    progress("compiling the dynamic model")
    model = compile_dynamics(layout, params)
    progress("step response")
    st, failed = integrated(step_response, model, s.gamma_from, s.gamma_to, load)
    st = st or Step(None, None, None, None, None, False, failed)
    progress("bandwidth")
    lins = [linear_at(model, g, load) for g in s.bandwidth_at]
    r = fc = None
    rate = render_failed = None
    if not s.quick:
        progress("rendering")
        r, render_failed = integrated(render, model, s.gamma_from, s.gamma_to, load, s.render_hz)
        progress("fastest ratio change")
        fc, failed = integrated(fastest_change, model, s.gamma_from, s.gamma_to, load)
        rate = {"max_rate_deg_s": None, "max_rate_limit": None, "max_rate_reason": failed} if failed else None
    rendering = rendering_record(r, s, load) | ({"reason": render_failed} if render_failed else {})
    x0, tau2 = start(model, s.gamma_from, load)        # the torque on shaft 2 the transients hold
    step = step_record(st, s.gamma_from, s.gamma_to, load, None if x0 is None else tau2)
    record = {"name": name, "file": str(layout.file), "step": step,
              **(rate or rate_record(fc)),
              "bandwidth_Hz": [bandwidth_record(lin, g, load) for g, lin in zip(s.bandwidth_at, lins)],
              "rendering": rendering, "parameters": parameters_record(params)}
    return record, curves(st, lins, r, s)


def integrated(part, *args):
    """(part(*args), None), or (None, the reason) where the integrator could not go on: CVODES stops where the
    model's rates stop being finite (the physics no longer holds there) or its steps became too small."""
    try:
        return part(*args), None
    except RuntimeError as e:
        code = re.search(r'CVode returned "(\w+)"', str(e))
        if code is None:
            raise
        why = "the model's rates were no longer finite" if "RHSFUNC" in code.group(1) else "CVODES could not go on"
        return None, f"the integration stopped: {why} (CVODES {code.group(1)})"


PARTS = 3           # progress steps of a quick run per variant (compile, step, bandwidth); a full one adds 2


def transient_run(variants, s: Settings, progress=None) -> "Transient":
    """Every variant's transient figures under settings `s`; `progress(done, total, text)` told before each
    part (cli.printing.progress_bar). Each variant's options are checked against its envelope first."""
    progress = progress or (lambda done, total, item: None)
    layouts = [as_layout(v) for v in variants]
    for L in layouts:
        check_envelope(L, s)
        dynamic_parameters(L)        # a bad dynamics: value refused before any work
    names = basis.distinct_names(layouts)
    per = PARTS + (0 if s.quick else 2)
    done = [0]

    def told(name):
        def tell(text):
            progress(done[0], per * len(layouts), f"{name}: {text}")
            done[0] += 1
        return tell
    rows, data = [], []
    for L, n in zip(layouts, names):
        record, figure = variant_run(L, n, s, told(n))
        rows.append(record)
        data.append(figure)
    progress(done[0], per * len(layouts), "done")
    return Transient(rows, s, data, [Path(L.file) for L in layouts])


def transient_figures(rows, data, files, folder: Path) -> list[Path]:
    """The step, Bode and (where rendered) rendering figures in `folder`, named after the files; their paths."""
    paths = [folder / named_after(files, "_step.png"), folder / named_after(files, "_bode.png")]
    plots.step_figure(rows, data, paths[0])
    plots.bode_figure(rows, data, paths[1])
    if any(d["render"] is not None for d in data):
        paths.append(folder / named_after(files, "_render.png"))
        plots.render_figure(rows, data, paths[2])
    return paths


@dataclasses.dataclass(eq=False)
class Transient(Result):
    """The result of `transient`.

    Attributes
    ----------
    rows : list of dict
        Per variant the ``transient --json`` record (docs/dynamics.md): ``step`` (``gamma_from_deg``,
        ``gamma_to_deg`` [°], ``load_Nm`` [N·m], ``rise_s``, ``settle_s``, ``lag_s`` [s], ``overshoot_pct``
        [%]), ``max_rate_deg_s`` [°/s] with ``max_rate_limit``, ``bandwidth_Hz`` (per operating point
        ``gamma_deg`` [°], ``load_Nm`` [N·m], ``f3dB_Hz`` of γ_axis/γ_cmd and ``ratio_f3dB_Hz`` of the ratio
        [Hz]), ``rendering`` (ratio errors [-]) and ``parameters`` (each value in SI with its source, and
        which are assumed). A figure where the physics stopped holding is None, with a ``reason``.
    settings : Settings
        What was asked, in SI.
    curves : list of dict
        Each variant's figures' data (the step's time response, the Bode curves, the rendered ratios).
    """

    rows: list[dict]
    settings: Settings
    curves: list = dataclasses.field(repr=False)
    files: list = dataclasses.field(default_factory=list, repr=False)

    def content(self) -> dict:
        """The ``transient --json`` document: {"variants": rows}."""
        return {"variants": self.rows}

    def table_rows(self) -> list[dict]:
        """One row per variant and bandwidth point: ``variant``, the step's figures (``step_`` prefix), the
        fastest ratio change [°/s] and its limit, then the point's γ [°], load [N·m] and bandwidths [Hz]."""
        out = []
        for r in self.rows:
            head = {"variant": r["name"]} | table_row(r["step"], "step_") | \
                {k: r[k] for k in ("max_rate_deg_s", "max_rate_limit")}
            out += [head | table_row(b) for b in r["bandwidth_Hz"]]
        return out

    def plot(self, path=None) -> Path:
        """The step, Bode and rendering figures (`cvtdesign transient --plots`') in the folder `path` (default
        out/transient, made if missing): <stems>_step.png (γ_axis [°], ratio and slip α [°] against time [ms]),
        <stems>_bode.png (magnitude [dB] and phase [°] against frequency [Hz]) and, where rendered,
        <stems>_render.png (commanded, dynamic and quasi-static ratio against time [s]); returns the folder."""
        folder = make_folder(path if path is not None else "out/transient", kind="plot folder")
        transient_figures(self.rows, self.curves, self.files, folder)
        return folder


def transient(*variants, gamma_from=10.0, gamma_to=40.0, load_Nm=None, bandwidth_at_deg=(10.0, 25.0, 40.0),
              render_hz=RENDER_HZ, quick=False) -> Transient:
    """Transient steering dynamics of each variant, as ``cvtdesign transient`` gives them.

    Parameters
    ----------
    *variants : str, Path or Layout
        Variant files, or layouts from `load_variant` (their ``dynamics:`` section is read from the file).
    gamma_from : float
        The commanded γ [°] before the step (``--gamma-from``), inside each envelope; the ramp and the rendered
        profile start there.
    gamma_to : float
        The commanded γ [°] after the step (``--gamma-to``).
    load_Nm : float, optional
        The load τ⊥ [N·m] (``--load``); default half the envelope's largest |τ⊥|.
    bandwidth_at_deg : sequence of float
        The γ [°] of the bandwidth's operating points (``--bandwidth-at``), at that load.
    render_hz : float
        The rendered ratio profile's frequency [Hz] (``--render-hz``).
    quick : bool
        Leave out the fastest-ratio-change search and the rendering, the long parts (``--quick``).

    Returns
    -------
    Transient
        `.rows` (the ``--json`` records), `.table` (pandas.DataFrame, a row per variant and bandwidth point),
        `.to_json()`, `.plot(folder)`.

    Raises
    ------
    cvtdesign.errors.InputError
        A file or field that is not valid (a bad ``dynamics:`` value), or an option outside the envelope (one
        line naming it).
    """
    if not variants:
        raise InputError("transient: no variant given; expected one or more variant files")
    deg = [f"{float(v)!r} deg" for v in (gamma_from, gamma_to)]
    load = None if load_Nm is None else f"{float(load_Nm)!r} N*m"
    at = ",".join(f"{float(v)!r} deg" for v in np.atleast_1d(bandwidth_at_deg))
    return transient_run(variants, settings(*deg, load, at, render_hz, quick))
