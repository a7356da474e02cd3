"""Virtual rig and the measured-data reader: format, noise, derived quantities, bad input."""
import re

import numpy as np
import pandas as pd
import pytest

import kim_closed_forms as kim  # tests/validation is on sys.path (tests/conftest.py)
from conftest import shipped_layout, shipped_model, variant_path

from cvtdesign.diagnosis import measured
from cvtdesign.diagnosis import rig
from cvtdesign.cli import main
from cvtdesign.errors import InputError

EXISTING = variant_path("existing_kim")
UNEQUAL = variant_path("unequal_kim")
KIM = ("drive_longitudinal_creep", "steering_lateral_creep")


@pytest.fixture(scope="module")
def layout(existing_layout):
    return existing_layout


def test_rig_cli_writes_kims_protocol(tmp_path, capsys):
    out = tmp_path / "d.csv"
    assert main(["rig", str(EXISTING), "--out", str(out), "--seed", "1"]) == 0
    df = pd.read_csv(out)
    assert list(df.columns) == ["gamma_cmd_deg", "omega_1", "omega_2", "tau_1", "tau_2", "gamma_axis_deg"]
    assert len(df) == 187                                       # 17 γ × 11 τ⊥ (Kim sec. 4.2)
    assert sorted(df["gamma_cmd_deg"].unique()) == list(np.arange(-80, 81, 10.0))
    assert "187 rows" in capsys.readouterr().out


def test_noise_free_rig_reproduces_the_model(layout, tmp_path):
    """With zero noise every column is the model's output and the derived α, τ⊥ are the model's."""
    rows, failed = rig.simulate(layout, KIM, noise=rig.Noise(0, 0, 0))
    assert failed == {}
    path = tmp_path / "d.csv"
    path.write_text(rig.to_csv_text(rows))
    data = measured.load_measured(path, layout)
    m = shipped_model("existing_kim", KIM)
    G, T = np.meshgrid(np.radians(np.arange(-80, 81, 10.0)), np.round(np.arange(-1, 1.0001, 0.2), 12), indexing="ij")
    res = m.evaluate(G, T)
    np.testing.assert_allclose(data.rows["alpha_deg"], np.degrees(res["alpha"]).ravel(), atol=1e-6)
    np.testing.assert_allclose(data.rows["tau_perp"], T.ravel(), atol=1e-7)
    np.testing.assert_allclose(data.rows["gamma_axis_deg"], np.degrees(res["gamma_axis"]).ravel(), atol=1e-6)
    assert data.rows["point"].nunique() == 187 and len(data.load_levels) == 11 and not data.replicated


def test_unequal_radii_alpha_uses_the_radius_ratio(tmp_path):
    """Kim eqs 8, 15 with the radius ratio: with unequal radii ω2 is scaled by r2/r1 first, so the ideal CVT
    has α = 0 (up to the model's rigid-direction compliance floor, under 3e-6° at 1 N·m)."""
    L = shipped_layout("unequal_kim")
    rows, _ = rig.simulate(L, (), noise=rig.Noise(0, 0, 0))
    path = tmp_path / "d.csv"
    path.write_text(rig.to_csv_text(rows))
    assert np.max(np.abs(measured.load_measured(path, L).rows["alpha_deg"])) < 3e-6


def test_replicates_give_the_noise_level(layout):
    """Replicated points: the scatter of ω2 is the rig's speed noise (1100 rows, ±10 % at 3σ)."""
    p = rig.kim_protocol(layout, replicates=6)
    noise = rig.Noise(speed=0.02, torque=0.01, axis=np.radians(0.1))
    rows, _ = rig.simulate(layout, KIM, protocol=p, noise=noise, seed=4)
    assert len(rows) == 6 * 187
    key = rows["gamma_cmd_deg"].astype(str) + "/" + (rows.index % 187).astype(str)
    for col, sigma in (("omega_2", 0.02), ("tau_1", 0.01), ("gamma_axis_deg", 0.1)):
        s = rows.groupby(key)[col].std(ddof=1)
        assert abs(np.sqrt(np.mean(s ** 2)) / sigma - 1) < 0.1, col


def test_protocol_file_and_settings(layout, tmp_path):
    proto = tmp_path / "p.yaml"
    proto.write_text("gamma: [-30 deg, 0 deg, 30 deg]\nload: {start: 0 N*m, stop: 0.5 N*m, step: 0.25 N*m}\n"
                     "motor_speed: [5 rad/s, 20 rad/s]\nreplicates: 2\n")
    p = rig.read_protocol(proto, layout)
    settings = rig.parse_settings(["steering_offset.offset=1 deg"], KIM + ("steering_offset",))
    assert settings == {"steering_offset": {"offset": pytest.approx(np.radians(1.0), rel=1e-12)}}
    rows, _ = rig.simulate(layout, KIM + ("steering_offset",), settings, p, noise=rig.Noise(0, 0, 0))
    assert len(rows) == 3 * 3 * 2 * 2
    assert set(np.round(rows["omega_1"])) == {5.0, 20.0}
    assert sorted(rows["gamma_cmd_deg"].round(9).unique()) == [-30.0, 0.0, 30.0]
    # the 1° setting is what the rig ran: at zero load the axis is Kim's eq 5 of φ(γ_cmd) + 1°
    idle = rows[(rows["tau_1"].abs() < 1e-9) & (rows["tau_2"].abs() < 1e-9)]
    assert len(idle) == 3 * 2 * 2
    g = np.radians(idle["gamma_cmd_deg"].to_numpy())
    shift = kim.wrap_half_pi(kim.kim_gamma_from_phi(kim.kim_phi_from_gamma(g) + np.radians(1.0)) - g)
    np.testing.assert_allclose(np.radians(idle["gamma_axis_deg"].to_numpy()) - g, shift, atol=1e-9)
    np.testing.assert_allclose(np.arctan2(idle["omega_2"], idle["omega_1"]) - g, shift, atol=1e-9)
    assert np.all(np.abs(shift) > np.radians(0.5))


# ------------------------------------------------------------------------------- bad measured data

GOOD = ("gamma_cmd_deg,omega_1,omega_2,tau_1,tau_2\n"
        "-30,10,-5.77,0.2,0.3\n0,10,0.01,0.1,0.5\n30,10,5.77,-0.2,0.4\n")

BAD_DATA = {
    "missing column": (GOOD.replace("omega_2", "omega2"), r"missing column 'omega_2' \(did you mean 'omega2'\?\)"),
    "non-numeric cell": (GOOD.replace("0,10,0.01", "0,10,abc"), r"line 3: column 'omega_2': 'abc' is not a number"),
    "empty cell": (GOOD.replace("30,10,5.77,-0.2,0.4", "30,10,5.77,,0.4"), r"line 4: column 'tau_1' is empty"),
    "zero speed": (GOOD.replace("-30,10,", "-30,0,"), r"line 2: omega_1 is 0"),
    "gamma out of range": (GOOD.replace("30,10,5.77", "85,10,5.77"), r"line 4: gamma_cmd_deg = 85 is outside the variant's range -80\.\.80 deg"),
    "not a csv": ("\x00\x01\x02binary", r"missing column|not a readable CSV"),
}


@pytest.mark.parametrize("case", BAD_DATA)
def test_bad_measured_data_one_line_exit_2(case, tmp_path, capsys):
    text, pattern = BAD_DATA[case]
    path = tmp_path / "bad.csv"
    path.write_text(text)
    js = tmp_path / "r.json"
    assert main(["diagnose", str(path), "--variant", str(EXISTING), "--json", str(js)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"cvtdesign: error: {path}: ") and re.search(pattern, err), err
    assert not js.exists()


def test_bad_base_effect_is_named(tmp_path, capsys):
    path = tmp_path / "d.csv"
    path.write_text(GOOD)
    assert main(["diagnose", str(path), "--variant", str(EXISTING), "--base", "drive_longitudinal_creep,steering_lateral"]) == 2
    err = capsys.readouterr().err
    assert "unknown effect 'steering_lateral' (did you mean 'steering_lateral_creep'?)" in err and err.count("\n") == 1


def test_drop_bad_counts_rows(layout, tmp_path):
    text = GOOD + "10,10,abc,0.1,0.1\n20,0,1,1,1\n,10,1,1,1\n70,10,nan,1,1\n"
    path = tmp_path / "d.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=r"line 5: .*\(3 more bad rows; --drop-bad"):
        measured.load_measured(path, layout)
    data = measured.load_measured(path, layout, drop_bad=True)
    assert len(data.rows) == 3
    assert data.dropped == {"non-numeric cell": 1, "motor at rest": 1, "empty cell": 2}
    assert list(data.rows["line"]) == [2, 3, 4]


def test_operating_points_separate_speeds_and_keep_replicates(layout, tmp_path):
    """Rows at two motor speeds are different operating points; repeated rows are replicates of one."""
    p = rig.Protocol(np.radians([-40.0, 0.0, 40.0]), np.array([-0.5, 0.0, 0.5]), np.array([5.0, 20.0]), "tau_perp", 2)
    rows, _ = rig.simulate(layout, KIM, protocol=p, noise=rig.Noise().scaled(3), seed=9)
    path = tmp_path / "d.csv"
    path.write_text(rig.to_csv_text(rows))
    data = measured.load_measured(path, layout)
    assert data.rows["point"].nunique() == 18 and data.replicated
    assert len(data.speed_levels) == 2 and len(data.load_levels) == 3


def test_a_fine_load_step_keeps_every_load_apart(layout, tmp_path):
    """Loads 0.04 N·m apart (with 3 replicates each, and without): a gap threshold of 2.5 % of the range
    chained them into 9 "operating points" of 459 rows, and diagnose refused the file. Every point now holds
    one commanded load, and without replicates every row is its own point."""
    loads = np.round(np.arange(-1.0, 1.0001, 0.04), 10)
    for replicates in (1, 3):
        p = rig.Protocol(np.radians([-60.0, -20.0, 20.0, 60.0]), loads, np.array([10.0]), "tau_perp", replicates)
        rows, _ = rig.simulate(layout, KIM, protocol=p, seed=5)
        path = tmp_path / f"fine{replicates}.csv"
        path.write_text(rig.to_csv_text(rows))
        r = measured.load_measured(path, layout).rows
        spread = r.groupby("point")["tau_perp"].agg(lambda t: t.max() - t.min())
        assert spread.max() < 0.02 and r["point"].nunique() >= 4 * len(loads) * (1 if replicates == 1 else 0.8)
        if replicates == 1:
            assert r["point"].nunique() == len(r)


def test_random_loads_are_not_taken_for_replicates(layout, tmp_path):
    """11 random loads at each γ (as another simulator or a sweeping rig writes them): loads that meet by
    chance were merged as replicates, up to 0.13 N·m apart, and their scatter made a noise of 3.2° (0.06° of
    noise in the data). No row is a replicate now, and the noise comes from second differences."""
    rng = np.random.default_rng(3)
    frames = []
    for g in range(-80, 81, 10):
        p = rig.Protocol(np.radians([float(g)]), np.sort(rng.uniform(-1, 1, 11)), np.array([10.0]), "tau_perp", 1)
        frames.append(rig.simulate(layout, KIM, protocol=p, seed=g + 100)[0])
    path = tmp_path / "random.csv"
    path.write_text(rig.to_csv_text(pd.concat(frames, ignore_index=True)))
    data = measured.load_measured(path, layout)
    assert data.rows["point"].nunique() == len(data.rows) == 187 and not data.replicated


# ------------------------------------------------------------------------------- one wild row, wrong signs

@pytest.fixture(scope="module")
def kim_rows(layout):
    """Kim's protocol on the existing CVT, steering creep on (187 rows, one motor speed)."""
    rows, _ = rig.simulate(layout, KIM, seed=3)
    return rows


def _refused(rows, tmp_path, capsys) -> str:
    """Diagnose `rows` written as a CSV: exit 2 with one line on stderr, naming the file; that line."""
    path = tmp_path / "d.csv"
    path.write_text(rows if isinstance(rows, str) else rig.to_csv_text(rows))
    assert main(["diagnose", str(path), "--variant", str(EXISTING)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"cvtdesign: error: {path}: "), err
    return err


def _points(layout, rows, tmp_path):
    path = tmp_path / "d.csv"
    path.write_text(rig.to_csv_text(rows))
    return measured.load_measured(path, layout)


@pytest.mark.parametrize("column, value", [("tau_1", 30.0), ("tau_1", -30.0)])
def test_one_wild_row_does_not_merge_the_operating_points(layout, kim_rows, tmp_path, column, value):
    """A single typo row (τ1 = ±30 N·m among loads of ±1) used to set the level tolerance for the whole
    dataset (5 % of the largest |ω1|, 2.5 % of τ⊥'s range) and merged Kim's 187 points into 18: the noise
    estimate became 6° and the diagnosis found no gap. It is now one point of its own."""
    clean = _points(layout, kim_rows, tmp_path)
    wild = kim_rows.copy()
    wild.loc[len(wild)] = wild.iloc[0]
    wild.loc[len(wild) - 1, column] = value
    data = _points(layout, wild, tmp_path)
    assert clean.rows["point"].nunique() == 187
    assert data.rows["point"].nunique() == 188
    assert np.array_equal(data.rows["point"].to_numpy()[:-1], clean.rows["point"].to_numpy())


@pytest.mark.parametrize("cell", ["1e300", "-2e5"])
def test_implausible_magnitudes_are_bad_rows(tmp_path, capsys, cell):
    err = _refused(GOOD.replace("0,10,0.01,0.1,0.5", f"0,{cell},0.01,0.1,0.5"), tmp_path, capsys)
    assert re.search(r"line 3: column 'omega_1': .* rad/s is not a plausible shaft speed \(expected \|omega_1\| ≤ 10000 rad/s\)", err), err


@pytest.mark.parametrize("flip, named", [("omega_2", "omega_2's sign reversed"),
                                         ("gamma_cmd_deg", "gamma_cmd_deg's sign reversed")])
def test_reversed_sign_convention_is_named(layout, kim_rows, tmp_path, capsys, flip, named):
    """Data whose ω2 (or γ) counts positive the other way imply slip angles of ~50° everywhere; the diagnosis
    used to fit them and answer 'unexplained'. The reader now says which sign would make them plausible."""
    rows = kim_rows.copy()
    rows[flip] = -rows[flip]
    err = _refused(rows, tmp_path, capsys)
    # Kim's law is odd in γ: reversing ω2 or γ gives the same |α|, so both are named, ω2 first
    assert "omega_2, gamma_cmd_deg: the rows imply slip angles of" in err
    assert named in err and "docs/measured-data.md" in err, err


def test_one_wild_speed_keeps_the_speed_levels(layout, tmp_path):
    """Two motor speeds (5 and 20 rad/s) stay two levels with a 1000 rad/s typo row added: the speed
    tolerance used to be 5 % of the largest |ω1| (50 rad/s), which merged them."""
    p = rig.Protocol(np.radians([-40.0, 0.0, 40.0]), np.array([-0.5, 0.0, 0.5]), np.array([5.0, 20.0]), "tau_perp", 2)
    rows, _ = rig.simulate(layout, KIM, protocol=p, noise=rig.Noise().scaled(3), seed=9)
    rows.loc[len(rows)] = rows.iloc[0]
    rows.loc[len(rows) - 1, "omega_1"] = 1000.0
    data = _points(layout, rows, tmp_path)
    assert len(data.speed_levels) == 3 and data.rows["point"].nunique() == 19


@pytest.mark.parametrize("flip, pattern", [
    (("tau_1",), r"power enters the CVT at both shafts, or leaves at both, at 9\d% of the rows"),
    (("tau_2",), r"power enters the CVT at both shafts, or leaves at both, at 9\d% of the rows"),
    (("tau_1", "tau_2"), r"the CVT gives out more power than it takes in \(τ1ω1 \+ τ2ω2 < 0\) at 9\d% of the rows")])
def test_reversed_torque_signs_break_the_energy_balance(layout, kim_rows, tmp_path, capsys, flip, pattern):
    """Torques counted the other way round (both: the torques the shafts exert, as another simulator may
    write them) used to be diagnosed as an 'unexplained' gap along τ⊥. A passive transmission passes power
    from one shaft to the other and loses some: the reader now refuses data that break that at most rows."""
    rows = kim_rows.copy()
    for c in flip:
        rows[c] = -rows[c]
    err = _refused(rows, tmp_path, capsys)
    assert ": tau_1, tau_2: " in err and re.search(pattern, err) and "docs/measured-data.md" in err, err


def test_the_ideal_cvt_passes_the_energy_check(layout, tmp_path):
    """Lossless data (the ideal CVT) sit on the energy balance's edge: their losses are noise, of either
    sign, and nothing is refused."""
    rows, _ = rig.simulate(layout, (), seed=5)
    assert len(_points(layout, rows, tmp_path).rows) == len(rows)


def test_torques_in_newton_millimetres_are_refused(kim_rows, tmp_path, capsys):
    """Torques written in N·mm (×1000) used to be read as 1000 N·m loads on a CVT whose contacts carry 3.2 N·m
    per shaft at preload: noise 17.5°, regions of 60–85° residual, and the verdict 'none'."""
    rows = kim_rows.copy()
    rows[["tau_1", "tau_2"]] *= 1000
    err = _refused(rows, tmp_path, capsys)
    assert "is beyond what shaft 1's contacts can carry (Σ μ·P·r = 3.2 N·m" in err, err
    assert "N·mm written as N·m?" in err


def test_a_file_appended_to_itself_is_refused(kim_rows, layout, tmp_path, capsys):
    """Rows repeated exactly (every cell) used to pass as replicates: noise 7e-15°, ΔBIC of ±1e26. With
    --drop-bad the copies are dropped and counted."""
    err = _refused(pd.concat([kim_rows, kim_rows.iloc[::10]], ignore_index=True), tmp_path, capsys)
    path = tmp_path / "d.csv"
    assert "line 189: repeats line 2 in every cell; expected each replicate measured anew (18 more bad rows" in err, err
    data = measured.load_measured(path, layout, drop_bad=True)
    assert len(data.rows) == len(kim_rows) and data.dropped == {"duplicate row": 19}


def test_gamma_in_radians_and_a_repeated_column_are_named(kim_rows, tmp_path, capsys):
    """γ_cmd written in radians in the degree column used to be diagnosed (residual 35°, 'unexplained'); a
    header with omega_2 twice was read with the first of them, silently."""
    rows = kim_rows.copy()
    rows["gamma_cmd_deg"] = np.radians(rows["gamma_cmd_deg"])
    err = _refused(rows, tmp_path, capsys)
    assert "gamma_cmd_deg: the rows imply slip angles of" in err
    assert "with gamma_cmd_deg read as radians they are" in err and "expected gamma_cmd_deg in degrees" in err
    text = rig.to_csv_text(kim_rows).splitlines()
    err = _refused("\n".join([text[0] + ",omega_2"] + [t + ",1" for t in text[1:]]) + "\n", tmp_path, capsys)
    assert "column 'omega_2' appears more than once in the header" in err
