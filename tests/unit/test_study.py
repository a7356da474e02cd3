"""Batch studies on a real Dask LocalCluster: the store, resume after a kill, recorded statuses."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from cvtdesign.study import make_cases, read_store, run_study

ROOT = Path(__file__).resolve().parents[2]


def small_study(tmp_path, **extra):
    data = {"name": "small", "base": str(ROOT / "variants/box.yaml"),
            "design": {"d": {"lower": "30 mm", "upper": "110 mm"}},
            "constraints": {"clearance": "2 mm"},
            "envelope": {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "60 deg"},
                         "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "2 N*m"}},
            "multistart": {"starts": 3, "seed": 2},
            "batch": {"sweep": {"r_steer": ["30 mm", "38 mm"]}}}
    data.update(extra)
    path = tmp_path / "small.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    return path


def comparable(df):
    cols = ["case_id", "point", "status", "success", "objective", "design.d"]
    return df[cols].sort_values(["case_id", "point"]).reset_index(drop=True)


def test_cases_are_the_product(tmp_path):
    cases = make_cases(small_study(tmp_path))
    assert len(cases) == 6 and len({c["id"] for c in cases}) == 6
    assert {c["fixed"]["r_steer"] for c in cases} == {0.030, 0.038}


def test_study_resumes_after_kill(tmp_path):
    # enough work that the kill lands mid-study: 16 cases on Kim's envelope (a case takes ~0.06 s once its
    # worker has built the problem, so the 6 small cases above all finish within one poll of the kill loop)
    study = small_study(tmp_path, multistart={"starts": 8, "seed": 2},
                        envelope={"gamma": {"start": "-80 deg", "stop": "80 deg", "step": "10 deg"},
                                  "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "0.1 N*m"}})
    n = len(make_cases(study))
    assert n == 16
    # uninterrupted reference
    ref = run_study(study, tmp_path / "ref", workers=2)["table"]
    assert len(ref) == n and ref["success"].all()
    # the real thing: the command killed with SIGKILL (workers too) once two cases are stored
    out = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-m", "cvtdesign.cli", "study", str(study), "--out", str(out),
                             "--workers", "2"], start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, cwd=ROOT)
    deadline = time.time() + 120
    while time.time() < deadline and len(list((out / "cases").glob("[!.]*.parquet"))) < 2:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    partial = len(list((out / "cases").glob("[!.]*.parquet")))
    assert 2 <= partial < n
    res = run_study(study, out, workers=2)
    assert res["skipped"] == partial and res["ran"] == n - partial
    pd.testing.assert_frame_equal(comparable(res["table"]), comparable(ref), rtol=1e-9)
    # the optimum: the closed form of test_optimise for each steering radius
    for rs, d in zip((0.030, 0.038), sorted(ref.groupby("fixed")["design.d"].mean())):
        assert d == pytest.approx(0.0635 * (2 * rs + 0.002) / (0.0635 + rs), rel=1e-4)


def test_other_study_in_store_is_refused(tmp_path):
    study = small_study(tmp_path, multistart={"starts": 1})
    run_study(study, tmp_path / "s", workers=1)
    assert "110 mm" in study.read_text()
    study.write_text(study.read_text().replace("110 mm", "100 mm"))
    from cvtdesign.units import InputError
    with pytest.raises(InputError, match="holds another version of this study"):
        run_study(study, tmp_path / "s", workers=1)


def test_failed_case_status_is_recorded(tmp_path):
    """An infeasible case (clearance impossible inside the bounds) is stored with IPOPT's status."""
    study = small_study(tmp_path, constraints={"clearance": "80 mm"}, multistart={"starts": 1},
                        batch={"sweep": {}})
    res = run_study(study, tmp_path / "f", workers=1)
    df = read_store(tmp_path / "f")
    assert len(df) == 1 and not df["success"].iloc[0]
    assert df["status"].iloc[0] in ("Infeasible_Problem_Detected", "Restoration_Failed", "Maximum_Iterations_Exceeded")
    assert df["variant_file"].iloc[0] is None
