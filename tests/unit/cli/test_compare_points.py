"""`cvtdesign compare --points FILE`: every contact's state at every operating point, and the efficiency figures
that mean something under Kalker's law (worst efficiency over the points that deliver power, and the loss
where none is delivered)."""
import json

import numpy as np
import pandas as pd
import pytest
from conftest import ROOT, shipped_model

from cvtdesign.cli import main
from cvtdesign.core.metrics import envelope
from cvtdesign.io.points import COLUMNS

EXPECTED = ["variant", "gamma_cmd_deg", "tau_perp_Nm", "status", "roller", "role", "N_N", "xi", "eta", "phi_1_m",
            "F_long_N", "F_lat_N", "M_spin_Nm", "utilisation", "a_mm", "b_mm", "p0_MPa", "G_MPa", "mu", "C11",
            "C22", "C23", "loss_W", "T_fork_Nm", "T_fork_standstill_Nm"]


@pytest.fixture(scope="module")
def kalker_points(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("points")
    files = [str(ROOT / f"variants/{n}.yaml") for n in ("existing", "box_kim")]
    assert main(["compare", *files, "--out", str(tmp), "--points", str(tmp / "p.csv"), "--json", str(tmp / "f.json"),
                 "--as-written"]) == 0
    assert main(["compare", *files, "--out", str(tmp), "--points", str(tmp / "p.parquet"), "--as-written"]) == 0
    return pd.read_csv(tmp / "p.csv"), pd.read_parquet(tmp / "p.parquet"), json.loads((tmp / "f.json").read_text())


@pytest.mark.slow
def test_one_row_per_variant_point_and_contact(kalker_points):
    """The columns outside tools rely on, in order; 357 points × 4 contacts of existing and × 8 of the box;
    the CSV and the Parquet file hold the same table."""
    csv, parquet, _ = kalker_points
    assert list(csv.columns[:len(EXPECTED)]) == EXPECTED == COLUMNS
    assert csv.groupby("variant").size().to_dict() == {"existing": 357 * 4, "box_kim": 357 * 8}
    pd.testing.assert_frame_equal(csv, parquet, check_dtype=False, rtol=1e-8)


def test_rows_are_the_model_s_state(kalker_points):
    """Each row is the model's contact state, in Kalker's patch frame: the forces sum to the shaft torques' loss
    budget (Σ loss_W over a point's contacts = τ1ω1 + τ2ω2, to 1e-9 W), |F| = utilisation·μN, and the creep
    coefficients are as used: the materials library's creep modulus makes the drive rollers' G·C11 the theory's
    (G 7.19 MPa, C11 5.64) over 3.1364, the factor that gives Kim's ε_D."""
    csv, _, _ = kalker_points
    ek = csv[(csv.variant == "existing") & (csv.status == "ok")]
    np.testing.assert_allclose(np.hypot(ek.F_long_N, ek.F_lat_N), ek.utilisation * ek.mu * ek.N_N, rtol=1e-6, atol=1e-3)
    res = envelope(shipped_model("existing"))
    power = (res["tau_1"] * res["omega_1"] + res["tau_2"] * res["omega_2"]).ravel()
    loss = ek.groupby(["gamma_cmd_deg", "tau_perp_Nm"], sort=True).loss_W.sum().to_numpy()
    np.testing.assert_allclose(loss, power[np.isfinite(power)], atol=1e-9)
    d1 = ek[ek.roller == "D1"]
    GC11 = d1.G_MPa * d1.C11
    assert GC11.min() == pytest.approx(7.1946 * 5.64 / 3.1364, rel=5e-3) and GC11.max() == pytest.approx(GC11.min(), rel=1e-6)


@pytest.mark.slow
def test_points_that_are_not_ok_carry_their_status_and_no_numbers(tmp_path):
    """A load range past the physics (±6 N·m on Kim's CVT): the failed points keep their status and every number
    of theirs is empty."""
    text = (ROOT / "variants/existing_kim.yaml").read_text().replace("load: {start: -1 N*m, stop: 1 N*m, step: 0.1 N*m}",
                                                                  "load: {start: -6 N*m, stop: 6 N*m, step: 3 N*m}")
    v = tmp_path / "heavy.yaml"
    v.write_text(text)
    assert main(["compare", str(v), str(ROOT / "variants/box_kim.yaml"), "--out", str(tmp_path), "--points",
                 str(tmp_path / "p.csv")]) == 0
    p = pd.read_csv(tmp_path / "p.csv")
    bad = p[p.status != "ok"]
    assert len(bad) > 0 and set(bad.status) <= {"lost_contact", "gross_slip", "not_converged", "reversed"}
    assert bad[EXPECTED[6:]].isna().all().all() and p[p.status == "ok"][EXPECTED[6:]].notna().all().all()


def test_worst_efficiency_is_taken_where_power_is_delivered(kalker_points):
    """Under Kalker's law zero-load points lose power (spin) and deliver none: their efficiency, 0, printed
    'worst efficiency 0.000' for both kalker variants. It is now taken over the points that deliver power, and
    the zero-output points' losses are a figure of their own: existing 0.052 over 254 points (2 more in
    range deliver none), 3.81 W lost at a point that delivers none; Kim's law unchanged (0.729 on the box)."""
    _, _, out = kalker_points
    ek, box = out["variants"]
    assert ek["min_efficiency"] == pytest.approx(0.052, abs=2e-3) and ek["efficiency_points"] == 254
    assert ek["no_output_points"] == 2 and ek["max_loss_no_output_W"] == pytest.approx(3.81, abs=0.02)
    assert box["min_efficiency"] == pytest.approx(0.729, abs=5e-4) and box["no_output_points"] == 0
