"""The diagnosis in a reduced self-check: withheld effects are named, null data gives `none`, a gap no
candidate removes is `unexplained`; the historical replays of the README; resteering."""
import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

from conftest import ROOT

from cvtdesign.diagnosis import diagnose
from cvtdesign.diagnosis import measured
from cvtdesign.diagnosis.diagnose.run import prepare
from cvtdesign.diagnosis import resteer
from cvtdesign.diagnosis import rig
from cvtdesign.cli import main
from cvtdesign.cli.diagnose import report_blocks
from cvtdesign.core import native
from cvtdesign.core.kinematics import shaft_frame
from cvtdesign.core.model import compile_model
from cvtdesign.io.variant import load_variant

EXISTING = ROOT / "variants" / "existing_kim.yaml"
KIM = ("drive_longitudinal_creep", "steering_lateral_creep")


@pytest.fixture(scope="module")
def layout():
    return load_variant(EXISTING)


def dataset(layout, tmp_path, effects, params=None, seed=0, protocol=None, noise=rig.Noise()):
    rows, failed = rig.simulate(layout, effects, params, protocol, noise, seed)
    assert failed == {}
    path = tmp_path / f"data{seed}.csv"
    path.write_text(rig.to_csv_text(rows))
    return path


@pytest.mark.slow
def test_replay_kim_steering_creep_is_named(tmp_path):
    """README replay 1 (Kim): a drive-creep-only model on rig data with steering lateral creep at Kim's
    ε_S names steering_lateral_creep, says where the gap lies, and removes most of it (held out)."""
    data = tmp_path / "kim.csv"
    assert main(["rig", str(EXISTING), "--out", str(data), "--seed", "11"]) == 0
    js, plots = tmp_path / "d.json", tmp_path / "plots"
    assert main(["diagnose", str(data), "--variant", str(EXISTING), "--base", "drive_longitudinal_creep",
                 "--json", str(js), "--plots", str(plots)]) == 0
    rep = json.loads(js.read_text())
    assert rep["verdict"] == "steering_lateral_creep" and rep["base"] == ["drive_longitudinal_creep"]
    assert {"rms_alpha_deg", "regions"} <= set(rep["gap"]) and rep["gap"]["regions"]
    assert {"gamma_deg", "load_Nm", "mean_residual_deg"} <= set(rep["gap"]["regions"][0])
    top = rep["ranking"][0]
    assert top["effect"] == "steering_lateral_creep" and top["accepted"]
    assert {"heldout_rms_before", "heldout_rms_after", "share", "params"} <= set(top)
    assert top["share"] > 0.8 and rep["how_far"]["shrink"] == pytest.approx(top["share"])
    # the fitted ε_S multiplier recovers Kim's value (truth 1.0) within 3σ of its own standard error
    p = top["params"]["steering_lateral_creep.scale"]
    print(f"[measured] ε_S scale {p['value']:.5f} ± {p['std']:.5f}")
    assert p["identifiable"] and abs(p["value"] - 1.0) < 3 * p["std"] and p["std"] < 0.005   # measured 1.0028 ± 0.00097 (2.9σ)
    # the gap is the steering part: once explained, no structure is left
    assert rep["gap"]["structured"] and not rep["gap"]["structured_after"]
    assert (plots / "residual_map.png").stat().st_size > 10_000 and (plots / "fit.png").exists()
    # the noise estimate (no replicates) is the propagated rig noise: σ_α ≈ σ_ω cos γ / ω1 ... within 2×
    assert 0.02 < rep["noise"]["alpha"]["rms"] < 0.12


@pytest.mark.slow
def test_replay_rolling_resistance_from_efficiency(layout, tmp_path):
    """README replay 2 (Brokowski sec. 4.4.2): a creep-only model on data with rolling resistance names
    rolling_resistance, and the efficiency gap shrinks."""
    path = dataset(layout, tmp_path, KIM + ("rolling_resistance",), {"rolling_resistance": {"offset": 1e-4}}, seed=12)
    rep = diagnose.diagnose(layout, measured.load_measured(path, layout), KIM)
    assert rep.verdict == "rolling_resistance"
    h = rep.how_far
    assert h["shrink"] > 0.8 and h["heldout_rms_efficiency"][1] < 0.5 * h["heldout_rms_efficiency"][0]
    off = rep.final_fit["rolling_resistance.offset"]
    print(f"[measured] offset {off['value']:.4e} ± {off['std']:.2e} m")
    assert abs(off["value"] - 1e-4) < 3 * off["std"] and off["std"] < 3e-6   # measured 1.0068e-4 ± 6.2e-7 m


@pytest.mark.slow
def test_null_data_with_replicates_gives_none(layout, tmp_path):
    """Nothing withheld: the verdict is `none`, and the noise comes from the replicates."""
    proto = rig.Protocol(np.radians(np.arange(-80, 81, 20.0)), np.array([-1, -0.5, 0, 0.5, 1.0]),
                         np.array([10.0]), "tau_perp", 3)
    path = dataset(layout, tmp_path, KIM, seed=13, protocol=proto)
    data = measured.load_measured(path, layout)
    assert data.replicated and data.rows["point"].nunique() == 45
    rep = diagnose.diagnose(layout, data, KIM)
    assert rep.verdict == "none" and rep.accepted == []
    assert rep.noise["source"] == "replicates"
    assert not any(r["accepted"] for r in rep.ranking)


@pytest.mark.slow
def test_gap_no_candidate_removes_is_unexplained(layout, tmp_path):
    """A 1° steering offset diagnosed with candidates that cannot produce it: `unexplained`, not a name."""
    path = dataset(layout, tmp_path, KIM + ("steering_offset",), {"steering_offset": {"offset": np.radians(1.0)}}, seed=14)
    rep = diagnose.diagnose(layout, measured.load_measured(path, layout), KIM,
                            candidates=["rolling_resistance", "traction_saturation"])
    assert rep.verdict == "unexplained" and rep.gap["structured"] and rep.gap["regions"]


def test_resteer_fitted_model_and_lookup_beat_the_ideal(layout, tmp_path):
    """Brokowski sec. 5 on rig data with Gillespie-type spin creep the model lacks: the fitted model and the
    data lookup follow the requested ratio far better than the ideal and nominal commands (Fig. 17)."""
    truth = KIM + ("drive_spin_creep",)
    params = {"drive_spin_creep": {"scale": 4.0}}
    path = dataset(layout, tmp_path, truth, params, seed=15)
    data = measured.load_measured(path, layout)
    cmds = resteer.commands(layout, KIM, 1.0, resteer.RATIOS, data)
    table = resteer.achieved(compile_model(layout.with_effects(truth, params)), cmds)
    err = {m: t["mean_abs_error_pct"] for m, t in table.items()}
    assert err["ideal"] > 30 and err["nominal"] > 8
    assert err["fitted"] < 0.5 * err["nominal"] and err["lookup"] < 0.5 * err["nominal"]


def test_resteer_inverts_the_model_exactly(layout):
    """The model command achieves the requested ratio on the same model (zero-noise consistency)."""
    m = compile_model(layout, KIM)
    for q in (0.4, 1.0, 2.5):
        g = resteer.model_command(m, q, 0.8)
        assert abs(resteer.ratio(m, g, 0.8)[0] / q - 1) < 1e-8
    assert abs(resteer.ideal_command(layout, 1.0) - np.pi / 4) < 1e-15


@pytest.mark.slow
def test_selfcheck_cli_on_a_dask_cluster(tmp_path, monkeypatch):
    """`cvtdesign selfcheck` on a real local Dask cluster, reduced to a withheld steering offset and a null set
    of the rig matrix, and an effect outside the vocabulary from the independent simulator (right answer:
    unexplained, with where the remaining gap lies). Run from another working directory (tmp_path), so it
    relies on no path relative to the repository."""
    monkeypatch.chdir(tmp_path)
    js = tmp_path / "sc.json"
    assert main(["selfcheck", "--quick", "--only", "single-steering_offset,null-noise1-seed0,viscous_loss-clear",
                 "--workers", "2", "--json", str(js)]) == 0
    rep = json.loads(js.read_text())
    ids = [d["id"] for d in rep["datasets"]]
    assert ids == [ids[0], "null-noise1-seed0", "independent-viscous_loss-clear"]
    single, null, oov = rep["datasets"]
    assert single["verdict"] == "steering_offset" and single["shrink"] > 0.8 and single["signal_chi"] > 10
    assert null["verdict"] == "none"
    assert oov["kind"] == "out_of_vocabulary" and oov["verdict"] == "unexplained" and oov["lies_along"]
    s = rep["summary"]
    assert s["rig"]["top1_single"] == 1.0 and s["rig"]["false_positive_null"] == 0.0
    assert s["rig"]["per_effect"]["steering_offset"]["cases"] == 1
    assert s["independent"]["named_out_of_vocabulary"] == 0


@pytest.mark.slow
def test_confounded_pair_is_reported_and_the_suggested_points_separate_it(layout):
    """A narrow γ range (30°..50°) without the axis channel: a steering offset and a radius mismatch both
    shift α by a near-constant angle there, so their fitted signatures are parallel. The report says so and
    suggests where to measure; rig data added at the suggested γ separate them (the offset's held-out fit
    is far better and the pair is no longer confounded)."""
    truth, params = KIM + ("steering_offset",), {"steering_offset": {"offset": np.radians(0.5)}}
    loads = np.round(np.arange(-1, 1.01, 0.2), 10)
    narrow = rig.Protocol(np.radians([30.0, 40.0, 50.0]), loads, np.array([10.0]), "tau_perp", 3)
    rows, _ = rig.simulate(layout, truth, params, narrow, seed=5, axis=False)

    def run(rows):
        return diagnose.diagnose(layout, measured.from_rows(rows, shaft_frame(layout)), KIM)

    rep = run(rows)
    pair = [c for c in rep.confounded if set(c["effects"]) == {"steering_offset", "drive_radius_mismatch"}]
    assert pair and pair[0]["cosine"] > 0.99
    pts = pair[0]["suggested_points"]
    assert len(pts) >= 3 and all(not 30 <= p["gamma_deg"] <= 50 for p in pts[:3])
    assert "axis angle" in pair[0]["separate_by"] and "γ = " in pair[0]["separate_by"]
    extra = rig.Protocol(np.radians([p["gamma_deg"] for p in pts[:3]]), loads, np.array([10.0]), "tau_perp", 3)
    more, _ = rig.simulate(layout, truth, params, extra, seed=6, axis=False)
    rep2 = run(pd.concat([rows, more], ignore_index=True))
    assert rep2.verdict == "steering_offset" and rep2.confounded == []
    msz = {r["effect"]: r["heldout_msz_after"] for r in rep2.ranking}
    assert msz["drive_radius_mismatch"] > 20 * msz["steering_offset"]


@pytest.mark.slow
def test_replicates_are_merged_into_operating_points(layout, tmp_path):
    """Kim's protocol × 27 replicates (5049 rows) is fitted at its 187 operating points; the noise of a point
    is that of a row over √27, and the verdict and the fitted ε_S match."""
    path = dataset(layout, tmp_path, KIM, seed=3, protocol=rig.kim_protocol(layout, replicates=27))
    data = measured.load_measured(path, layout)
    assert len(data.rows) == 5049
    points = measured.merge_points(data)
    assert len(points.rows) == 187 and (points.rows["count"] == 27).all()
    s = prepare(layout, shaft_frame(layout), data, ("drive_longitudinal_creep",))
    assert s.models.get(("drive_longitudinal_creep",)).n == 187
    noise = s.noise
    row_sigma = rig.Noise().speed / 10.0           # α noise of a row from the speed noise at ω1 = 10 rad/s
    assert 0.3 < np.median(noise["alpha"]) * np.sqrt(27) / np.degrees(row_sigma) < 3
    rep = diagnose.diagnose(layout, data, ("drive_longitudinal_creep",))
    assert rep.verdict == "steering_lateral_creep" and rep.rows == 5049 and rep.operating_points == 187
    p = rep.final_fit["steering_lateral_creep.scale"]
    print(f"[measured] ε_S scale (27 replicates) {p['value']:.5f} ± {p['std']:.5f}")
    assert abs(p["value"] - 1.0) < 3 * p["std"] and p["std"] < 0.001   # measured 1.00029 ± 0.00020


@pytest.mark.slow
def test_a_failing_model_counts_as_failing_not_as_a_misfit(layout, tmp_path):
    """Where a candidate has no physical solution (here traction saturation with μ too small for the high
    loads: gross slip), its points have no prediction: they are counted in `failed`, left out of its
    held-out RMS and of the per-point comparison, instead of entering as huge (or garbage) residuals."""
    s = prepare(layout, shaft_frame(layout), measured.load_measured(dataset(layout, tmp_path, KIM, seed=21), layout), KIM)
    data, noise = s.points, s.noise
    slippery = dataclasses.replace(layout, rollers=tuple(dataclasses.replace(
        r, friction=dataclasses.replace(r.friction, mu=0.05)) for r in layout.rollers))
    P = diagnose.Predictor(slippery, KIM + ("traction_saturation",), data)   # μN ≤ 5 × 5 N even at the bound
    sc = diagnose.score(P, data, noise, diagnose.folds(data))
    assert 0 < sc.failed < 0.9 and np.isnan(sc.per_point[~sc.ok]).all() and np.isfinite(sc.per_point[sc.ok]).all()
    res = diagnose.residuals(data, sc.pred)["alpha"]
    assert sc.rms_alpha == pytest.approx(np.sqrt(np.mean(res[sc.ok] ** 2)), rel=1e-12)
    base = diagnose.score(diagnose.Predictor(layout, KIM, data), data, noise, diagnose.folds(data))
    c = diagnose.compare(base, sc, 3, s.nb)
    assert c.points == int((base.ok & sc.ok).sum()) < len(data.rows)


@pytest.mark.slow
def test_independent_simulators_moderate_spin_creep_is_named(layout):
    """Data from the independent simulator (its own spin law: a sliding line contact with an elliptical
    pressure, in series with elastic creep) at a moderate strength: the vocabulary's drive_spin_creep is
    named, its held-out share of the structured gap at least 0.8, and nothing structured remains."""
    from cvtdesign.verification import independent_rig
    from cvtdesign.verification import selfcheck

    case = next(c for c in selfcheck.make_cases(matrices=("independent",)) if c["id"].endswith("spin_creep-moderate"))
    rows, left_out = independent_rig.simulate(case["effects"], seed=case["seed"])
    rep = diagnose.diagnose(layout, measured.from_rows(rows, shaft_frame(layout)), case["base"])
    assert left_out == {} and rep.verdict == "drive_spin_creep" and [x["effect"] for x in rep.shares] == ["drive_spin_creep"]
    assert rep.how_far["shrink"] >= diagnose.SHRINK_MIN and not rep.gap["structured_after"]


@pytest.mark.slow
def test_one_typo_row_leaves_the_verdict(layout, tmp_path):
    """Replay 1 with one typo row added (τ1 = 30 N·m instead of ~1): that row used to set the load-level
    tolerance and merge the 187 operating points into 18, so the noise estimate became ~6° and the verdict
    `none`. The row is now an operating point of its own (at gross slip in the model, so left out of the fits)
    and steering_lateral_creep is still named."""
    path = dataset(layout, tmp_path, KIM, seed=11)
    lines = path.read_text().splitlines()
    typo = lines[1].split(",")
    typo[3] = "30"
    path.write_text("\n".join(lines + [",".join(typo)]) + "\n")
    data = measured.load_measured(path, layout)
    assert data.rows["point"].nunique() == 188
    rep = diagnose.diagnose(layout, data, ("drive_longitudinal_creep",), ("steering_lateral_creep", "steering_offset"))
    assert rep.verdict == "steering_lateral_creep"


@pytest.mark.slow
def test_where_the_base_model_fails_it_is_counted_and_left_out_of_the_gap(layout, tmp_path):
    """Rig data plus two rows measured in gross slip (γ 50°, τ⊥ −2.5 N·m and γ 60°, +2 N·m), where the base
    model has no physical solution. They were silent: no count anywhere, regions of 14.1° and −4.5° drawn
    from the unconverged solve's last iterate, and the base fit's ±1σ 100× too wide (their FAIL_Z penalty
    entered χ²). Now they are counted and named, and left out of the gap, its regions and σ."""
    path = dataset(layout, tmp_path, KIM, seed=1)
    extra = ["50,10.0,5.773503,1.915111,-1.606969,36.0000", "60,10.0,114.300523,-1.732051,1.000000,77.5000"]
    path.write_text(path.read_text() + "\n".join(extra) + "\n")
    data = measured.load_measured(path, layout)
    rep = diagnose.diagnose(layout, data, KIM, ("steering_offset",))
    failed = rep.base_failed
    assert failed["points"] == 2 and failed["gross_slip"] == 2 and set(failed["gross_slip_at"]) <= {"S1", "S2"}
    assert sorted((p["gamma_cmd_deg"], round(p["tau_perp_Nm"], 1)) for p in failed["at"]) == [(50.0, -2.5), (60.0, 2.0)]
    assert rep.gap["regions"] == [] and rep.verdict == "none"
    assert all(p["std"] < 0.01 for p in rep.base_fit.values())      # 0.27 and 0.11 with the penalty in χ²
    text = "\n".join(str(getattr(b, "text", "")) for b in report_blocks(rep))
    assert "the base model has no physical solution at 2 of 189 operating points (gross slip 2" in text


@pytest.mark.slow
def test_a_candidate_that_fits_one_channel_by_spoiling_another_is_not_accepted(layout, tmp_path):
    """A 1° offset of the axis encoder alone (outside the vocabulary): steering_offset fitted 0.5° and was
    'accepted' on the axis channel while the held-out RMS α went from 0.055° to 0.55°. A gain in one channel
    bought with another is no explanation: not accepted, and the verdict is `unexplained`."""
    path = dataset(layout, tmp_path, KIM, seed=4)
    rows = pd.read_csv(path)
    rows["gamma_axis_deg"] += 1.0
    rows.to_csv(path, index=False)
    rep = diagnose.diagnose(layout, measured.load_measured(path, layout), KIM, ("steering_offset",))
    offset = next(r for r in rep.ranking if r["effect"] == "steering_offset")
    assert rep.accepted == [] and rep.verdict == "unexplained"
    assert offset["heldout_rms_after"] > 5 * offset["heldout_rms_before"]      # what accepting it would cost


@pytest.mark.slow
def test_the_noise_source_is_named_as_it_was_estimated(layout, tmp_path):
    """Every row at its own γ (as a simulator sampling γ at random writes it): no replicates and no load
    sweep. It was labelled "second differences along load", then estimated as the residuals' own scatter (an
    upper bound, 10× the truth on a gap); it now comes from local fits over the neighbours in (γ, τ⊥)."""
    rng = np.random.default_rng(8)
    frames = [rig.simulate(layout, KIM, protocol=rig.Protocol(np.radians([g]), np.array([t]), np.array([10.0]),
                                                              "tau_perp", 1), seed=k)[0]
              for k, (g, t) in enumerate(zip(rng.uniform(-75, 75, 40), rng.uniform(-1, 1, 40)))]
    path = tmp_path / "random.csv"
    path.write_text(rig.to_csv_text(pd.concat(frames, ignore_index=True)))
    rep = diagnose.diagnose(layout, measured.load_measured(path, layout), KIM, ("steering_offset",))
    assert rep.noise["source"].startswith("neighbours in (γ, τ⊥): local fits")


@pytest.mark.slow
def test_noisy_replicates_keep_their_load_levels_and_the_verdict(layout, tmp_path):
    """Two replicates a point with 6× the default torque noise (0.03 N·m): the first compact-level rule split
    replicate pairs wider than a third of the next gap, broke the load grid into 126 levels, read the gap as
    noise (structure z = 1.1) and said `unexplained` where the old rule said steering_lateral_creep. The
    shared load levels follow the protocol's 11 again (a level's single rows can sit 3σ = 0.09 N·m off it, so
    one may split in two), the gap is structured and the verdict is right."""
    p = rig.Protocol(np.radians(np.arange(-80.0, 81.0, 10.0)), np.round(np.arange(-1.0, 1.01, 0.2), 10),
                     np.array([10.0]), "tau_perp", 2)
    path = dataset(layout, tmp_path, KIM, seed=4, protocol=p, noise=rig.parse_noise("torque=0.03 N*m"))
    data = measured.load_measured(path, layout)
    assert len(data.load_levels) in (11, 12) and data.replicated
    rep = diagnose.diagnose(layout, data, ("drive_longitudinal_creep",), ("steering_lateral_creep", "steering_offset"))
    assert rep.verdict == "steering_lateral_creep" and rep.gap["structured"]


@pytest.mark.slow
def test_a_diagnosis_builds_one_model_for_the_base_and_every_candidate(layout, tmp_path, monkeypatch):
    """The candidates' fits share one model: the base's and every candidate's effects, each switchable
    (core.model.compile_model, switched), built once for the whole diagnosis, not once per effect set; and
    the verdict stays Kim's steering creep."""
    from cvtdesign.diagnosis.diagnose import predictor
    built, real = [], predictor.compile_model
    monkeypatch.setattr(predictor, "compile_model", lambda *a, **k: built.append((a[1], k)) or real(*a, **k))
    path = dataset(layout, tmp_path, KIM, seed=1)
    rep = diagnose.diagnose(layout, measured.load_measured(path, layout), KIM[:1])
    assert rep.verdict == "steering_lateral_creep" and len(rep.candidates) == 7
    assert len(built) == 1
    effects, options = built[0]
    assert set(effects) == set(KIM[:1]) | set(rep.candidates) and options == {"switched": True}


def test_a_candidates_predictor_is_its_own_models(layout, tmp_path):
    """A Predictor of one effect set on the diagnosis's shared switched model gives the predictions and the
    Jacobian of that set's own model (core.sensitivity), to round-off: the solves' linear algebra is ordered
    by the Jacobian's sparsity, which the other effects' switched terms widen."""
    from cvtdesign.core.sensitivity import derivatives
    from cvtdesign.diagnosis.diagnose.predictor import Switched
    data = measured.merge_points(measured.load_measured(dataset(layout, tmp_path, KIM, seed=2), layout))
    r = data.rows
    g, w, t = np.radians(r["gamma_cmd_deg"].to_numpy()), r["omega_1"].to_numpy(), r["tau_perp"].to_numpy()
    shared = Switched(layout, KIM + ("drive_spin_creep", "traction_saturation", "steering_offset"))
    for effects in (KIM[:1], KIM, KIM[:1] + ("traction_saturation",), KIM[:1] + ("steering_offset",)):
        own, P = compile_model(layout, effects), diagnose.Predictor(layout, effects, data, shared)
        assert P.names == own.param_names and list(P.defaults) == own.param_values
        pred, ok, J = P(P.defaults, jacobian=True)
        ref = own.evaluate(g, t, speeds=w)
        np.testing.assert_array_equal(ok, ref["ok"])
        assert ok.sum() > 0.9 * len(r)
        d = derivatives(own, g, w, t, own.steering_guess(g)[0], ["alpha", "gamma_axis", "omega_2"],
                        list(range(len(own.param_names))), [])
        for k, mine, theirs, dk, j in (("alpha", pred["alpha"], np.degrees(ref["alpha"]), np.degrees(d[0][0]), 0),
                                       ("axis", pred["axis"], np.degrees(ref["gamma_axis"]), np.degrees(d[1][0]), 2),
                                       ("omega_2", pred["omega_2"], ref["omega_2"], d[2][0], 3)):
            np.testing.assert_allclose(mine[ok], theirs[ok], rtol=1e-8, atol=1e-8 * np.abs(theirs[ok]).max(), err_msg=k)
            np.testing.assert_allclose(J[j][ok], dk[ok], rtol=1e-6, atol=1e-6 * np.abs(dk[ok]).max(), err_msg=k)


def test_where_nothing_is_compiled_each_effect_set_has_a_model_of_its_own(layout, tmp_path, monkeypatch):
    """Interpreted (CVTDESIGN_COMPILE=never, or no C compiler), the model of every candidate costs 1.75× a
    set's own: each set's Predictor then evaluates a model of its effects alone, built once; compiled, they
    all share the one model."""
    from cvtdesign.diagnosis.diagnose.predictor import Models
    data = measured.merge_points(measured.load_measured(dataset(layout, tmp_path, KIM, seed=3), layout))
    every = KIM + ("traction_saturation", "steering_offset")
    monkeypatch.setenv("CVTDESIGN_COMPILE", "never")
    models = Models(layout, data, every)
    a, b = models.get(KIM), models.get(KIM[:1] + ("steering_offset",))
    assert a.shared.effects == KIM and b.shared.effects == KIM[:1] + ("steering_offset",)
    assert models.shared.view(KIM) is a.shared and models.get(every).shared is models.shared
    monkeypatch.setenv("CVTDESIGN_COMPILE", "auto")
    if native.compiler() is not None:
        assert Models(layout, data, every).get(KIM).shared.effects == every


def test_a_pinned_theta_is_solved_once_between_other_thetas(layout, tmp_path, monkeypatch):
    """A fit pins its start (the cross-validation's folds all start from the full fit's θ): the pinned θ's
    solutions and Jacobian are kept besides the last θ's, and give the same numbers as solving again."""
    data = measured.merge_points(measured.load_measured(dataset(layout, tmp_path, KIM, seed=4), layout))
    P = diagnose.Predictor(layout, KIM, data)
    calls = {"rows": 0, "derivatives": 0}
    for kind in calls:
        def counted(*a, real=getattr(P.shared, kind), kind=kind):
            calls[kind] += 1
            return real(*a)
        monkeypatch.setattr(P.shared, kind, counted)
    start, other = P.defaults, P.defaults * 1.05
    P.pin(start)
    first = P(start, jacobian=True)
    P(other, jacobian=True)
    P(other * 1.01)
    again = P(start, jacobian=True)
    assert calls == {"rows": 3, "derivatives": 2}
    np.testing.assert_array_equal(again[0]["alpha"], first[0]["alpha"])
    np.testing.assert_array_equal(again[2], first[2])
    P.pin(other)                         # another start: the first one is no longer kept
    P(other * 1.02)
    fresh = P(start)
    assert calls["rows"] == 5
    np.testing.assert_array_equal(fresh[0]["alpha"], first[0]["alpha"])
