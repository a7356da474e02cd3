"""`cvtdesign tolerance`: the machine as built (core.tolerances), its exact derivatives in the deviations, the
Monte Carlo on Dask in a resumable store, the first order against the samples, kim's rigid directions
refused, and bad tolerances files refused in one line. Small envelopes (3 × 3 points) and few samples; the
full box study that issue 27 asks for is measured in docs/tolerances.md."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

from conftest import ROOT, shipped_layout, variant_data, write_yaml
from cvtdesign.cli import main
from cvtdesign.core.layout import Layout
from cvtdesign.core.metrics import efficiency, envelope, envelopes, metrics
from cvtdesign.core.model import compile_model, library_model
from cvtdesign.core.tolerances import Dimension, as_built
from cvtdesign.core.uncertainty import sensitivities
from cvtdesign.design import cluster, tolerance
from cvtdesign.design.store import read_store
from cvtdesign.design.tolerance import COLUMNS, FIGURES, built_model, check_directions, tolerance_content
from cvtdesign.io import plots
from figure_checks import captured, text_problems

AXLES = ROOT / "tests" / "data" / "box_axle_tolerances.yaml"
KEYS = {"nominal", "mean", "std", "p05", "p95", "first_order_mean", "first_order_std"}


def one_line(err: str, *needles):
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in err, err


def small(tmp_path, name="box"):
    """The variant on 3 × 3 points: γ −40°, 0°, 40° and τ⊥ −1, 0, 1 N·m."""
    d = variant_data(name)
    d["envelope"]["gamma"] = {"start": "-40 deg", "stop": "40 deg", "step": "40 deg"}
    d["envelope"]["load"] = {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}
    return write_yaml(tmp_path / f"{name}_small.yaml", d)


def tolerances(tmp_path, entries, name="t", seed=0):
    return write_yaml(tmp_path / f"{name}.yaml", {"name": name, "seed": seed, "tolerances": entries})


@pytest.fixture(scope="module")
def shared():
    """One LocalCluster worker for the runs (its process keeps the compiled model between them)."""
    c = cluster.local_cluster(1)
    yield c.scheduler_address
    c.close()


@pytest.fixture(scope="module")
def kalker(tmp_path_factory):
    return small(tmp_path_factory.mktemp("kalker"))


@pytest.fixture(scope="module")
def content(kalker):
    """The dimensions alone (the physical inputs sampled beside them: test_tolerance_inputs.py)."""
    return tolerance_content(kalker, AXLES, dimensions_only=True)


@pytest.fixture(scope="module")
def finished(tmp_path_factory, kalker, shared):
    """(folder, the --json of a 30-sample study of the 8 axles at σ 0.1°, dimensions only, the figures drawn)."""
    folder = tmp_path_factory.mktemp("finished")
    with pytest.MonkeyPatch.context() as mp:
        drawn = captured(mp, plots)
        assert main(["tolerance", str(kalker), "--tolerances", str(AXLES), "--dimensions-only", "--samples", "30", "--json",
                     str(folder / "t.json"), "--plots", str(folder / "plots"), "--store", str(folder / "store"),
                     "--scheduler", shared]) == 0
    return folder, json.loads((folder / "t.json").read_text()), drawn


def test_as_built_moves_each_roller_as_its_dimension_says():
    """An axle turns about its contact normal by x and stays a unit vector ⊥ n; a contact moved along
    rolling goes x along t = n × a (the pose turned about the sphere centre by x/R); a fork offset turns every
    roller of the fork about the fork's axis; radius and preload change by x and by P·x."""
    L: Layout = shipped_layout("box_kim")
    by = {r.name: r for r in L.rollers}
    x = math.radians(0.5)
    dims = (Dimension("axle of A", "axle", ("A",), "normal", 1.0, 0), Dimension("c", "contact", ("B",), "normal", 1.0, 1,
                                                                                  "rolling"),
            Dimension("r", "radius", ("A_",), "normal", 1.0, 2), Dimension("p", "preload", ("B_",), "normal", 1.0, 3),
            Dimension("f", "fork", ("N1", "N2"), "normal", 1.0, 4))
    built = {r.name: r for r in as_built(L, dims, [x, 1e-3, 1e-4, 0.1, x]).rollers}
    v = lambda r, f: np.ravel(np.asarray(getattr(r, f), float))        # noqa: E731
    a0, a1, n = v(by["A"], "axle"), v(built["A"], "axle"), v(by["A"], "normal")
    assert np.linalg.norm(a1) == pytest.approx(1) and a1 @ n == pytest.approx(0, abs=1e-15)
    assert math.acos(a0 @ a1) == pytest.approx(x) and np.allclose(v(built["A"], "normal"), n)
    R, nB, tB = float(L.sphere_radius), v(by["B"], "normal"), np.cross(v(by["B"], "normal"), v(by["B"], "axle"))
    moved = v(built["B"], "normal") - nB
    assert R * math.acos(v(built["B"], "normal") @ nB) == pytest.approx(1e-3)       # the arc over the sphere
    assert moved @ tB / np.linalg.norm(moved) == pytest.approx(1, abs=1e-4)       # along t (to x/2R)
    assert built["A_"].radius == pytest.approx(by["A_"].radius + 1e-4)
    assert built["B_"].preload == pytest.approx(1.1 * by["B_"].preload)
    for name in ("N1", "N2"):
        k = v(by[name], "fork_axis")
        turned = math.acos(np.clip(v(by[name], "axle") @ v(built[name], "axle"), -1, 1))
        assert turned == pytest.approx(x) and np.allclose(v(built[name], "normal") @ k, v(by[name], "normal") @ k)
    assert all(built[r] == by[r] for r in ("S1", "S2"))


@pytest.mark.slow
def test_the_drawing_is_compares_machine(content):
    """At zero deviation the as-built model gives compare's figures of the variant to 1e-9."""
    model, nominal = built_model(content)
    plain = compile_model(content.layout)
    want, got = metrics(plain, envelope(plain)), metrics(model, nominal)
    for k in FIGURES:
        assert got[k] == pytest.approx(want[k], rel=1e-9), k


@pytest.mark.slow
def test_derivatives_in_the_deviations_are_exact(content):
    """d(α, F/(μN))/dx at x = 0 (the implicit function theorem through the solve) against central
    differences of the envelope, h = 1e-9 rad: error below 1e-5 of the largest (measured: 4e-6). At γ = 0,
    τ⊥ = 0, where no force acts, α is linear in an axle's turn only over ~1e-8 rad: there the differences at
    h = 1e-7 differ from the derivative by 0.4 % and at 0.1° the slope is 8 % lower (docs/tolerances.md)."""
    model, nominal = built_model(content)
    ok = np.flatnonzero(np.ravel(nominal["ok"]))
    n = len(content.dims)
    exact = sensitivities(model, nominal, ok, list(range(n)), ("alpha", "utilisation"), wrt="design")
    h = 1e-9
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        up, down = envelope(model, design=e), envelope(model, design=-e)
        fd = (np.ravel(up["alpha"]) - np.ravel(down["alpha"]))[ok] / (2 * h)
        assert np.allclose(exact["alpha"][:, j], fd, rtol=0, atol=1e-5 * np.max(np.abs(exact["alpha"])))
        fu = (up["utilisation"].reshape(8, -1) - down["utilisation"].reshape(8, -1))[:, ok] / (2 * h)
        assert np.allclose(exact["utilisation"][:, :, j], fu.T, rtol=0, atol=1e-5 * np.max(np.abs(exact["utilisation"])))


@pytest.mark.slow
def test_a_chunk_is_one_call_over_its_samples_with_each_samples_numbers(content, monkeypatch):
    """A worker's chunk: one evaluation of the model mapped over its samples × points, in a model loaded from
    the compiled source the study carries (no model built in the worker). Every output of every sample is
    the sample's own envelope (one call a sample, the built model, as every sample was evaluated before) to
    1e-9 of its scale, and each row's figures are those of that envelope: the same samples, not the same
    distribution within sampling error."""
    model, nominal = built_model(content)
    shipped = tolerance.with_code(content)
    assert shipped.code and shipped.digest == content.digest
    loaded = library_model(content.layout, shipped.code, len(content.dims))
    assert loaded is not None and loaded.residual is None          # evaluation only: nothing was built
    x = tolerance.chunk_draws(content, 0)
    calls = []
    evaluate = type(loaded).evaluate
    monkeypatch.setattr(type(loaded), "evaluate", lambda self, *a, **k: (calls.append(1), evaluate(self, *a, **k))[1])
    chunk = envelopes(loaded, x)
    assert len(calls) == 1 and len(chunk) == tolerance.CHUNK
    monkeypatch.undo()
    for i, res in enumerate(chunk):
        one = envelope(model, design=x[i])
        assert np.array_equal(res["status"], one["status"])
        for k, v in one.items():
            if np.issubdtype(np.asarray(v).dtype, np.floating) and np.isfinite(v).any():
                scale = np.nanmax(np.abs(v)) or 1.0
                np.testing.assert_allclose(res[k], v, rtol=0, atol=1e-9 * scale, err_msg=k)
        row, want = tolerance.sample_row(loaded, nominal, content.dims, x[i], res), tolerance.figures(model, one)
        assert row["status"] == "ok"
        for k in FIGURES:
            assert row[k] == pytest.approx(want[k], rel=1e-9, abs=1e-12), k
    rows = tolerance.run_chunk(shipped, {"id": "chunk00000", "chunk": 0}, "")["rows"]
    assert [r["sample"] for r in rows] == list(range(tolerance.CHUNK))
    assert all(r[k] == pytest.approx(tolerance.figures(model, envelope(model, design=x[i]))[k], rel=1e-9, abs=1e-12)
               for i, r in enumerate(rows) for k in FIGURES)


@pytest.mark.slow
def test_the_json_interface_and_the_first_order_against_the_samples(finished):
    """The --json keys outside tools rely on; every sample held; the first order taken at the samples' own
    deviations gives their mean shift and σ of max |α| to 2 % (measured: 0.1 %), and each least-squares
    slope × σ to 2 % of the largest effect: the exact derivatives are the samples' own."""
    _, out, _ = finished
    assert out["samples"] == 30 and out["samples_held"] == 30 and out["samples_left_out"] == {}
    assert set(out["figures"]) == set(FIGURES)
    for key, f in out["figures"].items():
        assert set(f) == KEYS, key
    f, at = out["figures"]["max_abs_alpha_deg"], out["first_order_at_samples"]["max_abs_alpha_deg"]
    assert f["mean"] > f["nominal"] and f["p05"] < f["mean"] < f["p95"]
    assert at["mean"] - f["nominal"] == pytest.approx(f["mean"] - f["nominal"], rel=0.02)
    assert at["std"] == pytest.approx(f["std"], rel=0.02)
    effects = out["effects"]["max_abs_alpha_deg"]
    largest = effects[0]["effect"]
    assert [e["effect"] for e in effects] == sorted((e["effect"] for e in effects), reverse=True)
    assert {e["dimension"] for e in effects[:4]} == {f"axle of {n}" for n in ("N1", "N2", "S1", "S2")}
    for e in effects:
        assert e["slope_sampled"] == pytest.approx(e["slope_first_order"], abs=0.02 * largest), e


def test_the_ranked_figure_names_each_tolerance_with_its_unit(finished):
    folder, _, drawn = finished
    assert (folder / "plots" / "box_small_box_axle_tolerances_tolerance.png").stat().st_size > 10_000
    fig = drawn[-1]
    ranked = fig.axes[1]
    assert "axle of N1, σ 0.1°" in [t.get_text() for t in ranked.get_yticklabels()]
    assert "[°]" in ranked.get_xlabel() and "[°]" in fig.axes[0].get_xlabel()
    assert text_problems(fig) == []


@pytest.mark.slow
def test_a_second_run_resumes_and_more_samples_add_to_the_same_draws(finished, kalker, shared, capsys):
    """Run again with 40 samples: the store's 30 are kept (not drawn again) and the first 30 rows are the
    same samples; a changed tolerances file is another study, refused on that store."""
    folder, first, _ = finished
    capsys.readouterr()
    assert main(["tolerance", str(kalker), "--tolerances", str(AXLES), "--dimensions-only", "--samples", "40", "--json",
                 str(folder / "t40.json"), "--store", str(folder / "store"), "--scheduler", shared]) == 0
    assert "(30 samples were there, the rest drawn now)" in capsys.readouterr().out
    table = read_store(folder / "store", COLUMNS).sort_values("sample")
    assert list(table["sample"]) == list(range(40))
    assert json.loads((folder / "t40.json").read_text())["samples"] == 40
    edited = yaml.safe_load(AXLES.read_text()) | {"seed": 2}
    other = write_yaml(folder / "box_axle_tolerances.yaml", edited)
    assert main(["tolerance", str(kalker), "--tolerances", str(other), "--samples", "10", "--store",
                 str(folder / "store"), "--scheduler", shared]) == 2
    one_line(capsys.readouterr().err, f"{other}: the results folder", "holds another version", "use --store")


def test_kim_refuses_a_drive_roller_direction_in_one_line_saying_why(tmp_path, capsys):
    """box_kim.yaml (law kim): 1e-5° of drive roller A's axle makes its contacts fight with 131 N against the
    100 N preload; steering axles (laterally compliant under steering_lateral_creep), radii and preloads are
    meaningful there and are not refused."""
    variant = small(tmp_path, "box_kim")
    bad = tolerances(tmp_path, [{"dimension": "preload", "rollers": "all", "uniform": "10 %"},
                                {"dimension": "axle", "rollers": "all", "normal": "0.1 deg"}], "kim")
    assert main(["tolerance", str(variant), "--tolerances", str(bad), "--store", str(tmp_path / "s")]) == 2
    one_line(capsys.readouterr().err, f"{bad}: tolerances.1: the axle of A is not a meaningful tolerance under contact "
             "law kim: turned by only 1e-5°, it already makes the contacts fight with 131 N", "1.3 × the 100 N preload",
             "law kim holds drive rollers rigid across their rolling direction", "expected contact.law: kalker")
    assert not (tmp_path / "s").exists()
    fine = tolerances(tmp_path, [{"dimension": "axle", "rollers": "steering", "normal": "0.1 deg"},
                                 {"dimension": "radius", "rollers": ["A"], "uniform": "0.1 mm"}], "fine")
    c = tolerance_content(variant, fine)
    check_directions(built_model(c)[0], c.dims, str(fine))


BAD = [
    ({"dimension": "axel", "rollers": "all", "normal": "0.1 deg"}, "tolerances.0.dimension: input should be 'axle'"),
    ({"dimension": "axle", "rollers": "all", "normal": "0.1 mm"},
     "tolerances.0.normal: expected an angle like '10 deg', got '0.1 mm' (a length is not an angle)"),
    ({"dimension": "radius", "rollers": "all", "uniform": "10 %"}, "tolerances.0.uniform: expected a length"),
    ({"dimension": "preload", "rollers": "all", "uniform": "10 deg"}, "tolerances.0.uniform: expected a plain number"),
    ({"dimension": "axle", "rollers": ["A", "Q"], "normal": "0.1 deg"}, "tolerances.0.rollers: unknown roller 'Q'"),
    ({"dimension": "contact", "rollers": "all", "normal": "0.2 mm"}, "tolerances.0.along: missing"),
    ({"dimension": "fork", "rollers": ["A"], "normal": "0.1 deg"}, "tolerances.0.rollers: A is a drive roller, on no fork"),
    ({"dimension": "axle", "rollers": "all"}, "tolerances.0: expected exactly one distribution"),
    ({"dimension": "radius", "rollers": "all", "normal": 2}, "tolerances.0.normal: 2 m is not a plausible length "
                                                             "tolerance (expected at most 5 mm); did you mean '2 mm'?"),
    ({"dimension": "axle", "rollers": "all", "normal": "-0.1 deg"}, "tolerances.0.normal: expected a positive angle"),
]


@pytest.mark.parametrize("entry, message", BAD, ids=[m.split(":")[0] + " " + m.split(":")[1][:20] for _, m in BAD])
def test_a_bad_tolerances_file_is_one_line_naming_file_and_field(kalker, tmp_path, capsys, entry, message):
    path = tolerances(tmp_path, [entry])
    assert main(["tolerance", str(kalker), "--tolerances", str(path), "--store", str(tmp_path / "s")]) == 2
    one_line(capsys.readouterr().err, f"{path}: {message}")
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize("which", ["variant", "tolerances"])
def test_a_missing_file_is_one_line_naming_it(kalker, tmp_path, capsys, which):
    missing = tmp_path / "nowhere.yaml"
    variant, tol = (missing, AXLES) if which == "variant" else (kalker, missing)
    assert main(["tolerance", str(variant), "--tolerances", str(tol), "--store", str(tmp_path / "s")]) == 2
    one_line(capsys.readouterr().err, f"{missing}: cannot read file")


@pytest.mark.parametrize("samples", ["0", "100001"])
def test_a_number_of_samples_out_of_range_is_refused_before_anything_runs(kalker, tmp_path, capsys, samples):
    assert main(["tolerance", str(kalker), "--tolerances", str(AXLES), "--samples", samples, "--store",
                 str(tmp_path / "s")]) == 2
    one_line(capsys.readouterr().err, f"--samples: expected a number of samples from 1 to 100000, got {samples}")


@pytest.mark.parametrize("name", ["existing_kim", "box"])
def test_linearised_figures_taken_at_once_are_each_envelopes_metrics(name):
    """The linearised envelopes' figures, taken BATCH rows at once (core.metrics.batch_figures), against
    `metrics` of each linearised envelope built one at a time: the same to round-off, for every figure,
    including one a law cannot produce (Kim's: the rolling steering torque, NaN), across the batches' seam and
    for a row moved far off."""
    from cvtdesign.core.uncertainty import OUTPUTS
    from cvtdesign.design.tolerance_stats import BATCH, linearised_figures
    model = compile_model(shipped_layout(name))
    nominal = envelope(model)
    ok = np.flatnonzero(np.ravel(nominal["ok"]))
    rng = np.random.default_rng(5)
    names = [k for k in OUTPUTS if k in nominal] + ["steering_torque_standstill"]
    slopes = {k: rng.normal(0, np.nanstd(nominal[k]) + 1e-3, (ok.size, *np.shape(nominal[k])[:-2], 3))
              for k in names}
    xs = rng.normal(0, 0.3, (BATCH + 7, 3))
    xs[3] = [40, -40, 40]                           # far off: moves whole figures out of their points
    got = linearised_figures(model, nominal, ok, slopes, xs)
    for i in (0, 1, 3, BATCH - 1, BATCH, BATCH + 6):
        res = {k: np.array(v, float) if k in slopes else v for k, v in nominal.items()}
        for k, d in slopes.items():
            flat = res[k].reshape(-1, res[k].shape[-2] * res[k].shape[-1]) if d.ndim == 3 else res[k].reshape(1, -1)
            flat[:, ok] += (d @ xs[i]).T if d.ndim == 3 else (d @ xs[i])[None, :]
        res["efficiency"] = efficiency(res["tau_1"] * res["omega_1"], res["tau_2"] * res["omega_2"])
        m = metrics(model, res)
        want = [np.nan if m[k] is None else m[k] for k in FIGURES]
        np.testing.assert_allclose(got[i], want, rtol=1e-12, atol=1e-12, err_msg=f"row {i}")
    assert np.isfinite(got).sum() > 0.8 * got.size
    if name == "existing_kim":
        assert np.isnan(got[:, FIGURES.index("max_steering_torque_Nm")]).all()
