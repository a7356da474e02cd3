"""Bad duty-cycle files (io/duty_file.py): each is one InputError line naming the file, the field or row, and
what was expected."""
from __future__ import annotations

import pytest
import yaml

from conftest import ROOT

from cvtdesign.errors import InputError
from cvtdesign.io.duty_file import load_duty

SHIPPED = yaml.safe_load((ROOT / "studies" / "cobot_duty.yaml").read_text())
HEADER = "time_s,gamma_deg,tau_perp_Nm,motor_speed_rad_s\n"


def _refused(tmp_path, data, *expect, log: str | None = None):
    if log is not None:
        (tmp_path / "log.csv").write_text(log)
    f = tmp_path / "duty.yaml"
    f.write_text(yaml.safe_dump(data))
    with pytest.raises(InputError) as e:
        load_duty(f)
    text = str(e.value)
    assert "\n" not in text and str(f) in text or "log.csv" in text, text
    for x in expect:
        assert x in text, text
    return text


def _with(**changes):
    d = {k: v for k, v in SHIPPED.items()}
    d["points"] = [dict(p) for p in SHIPPED["points"]]
    d.update(changes)
    return {k: v for k, v in d.items() if v is not None}


def _point(i, **changes):
    d = _with()
    d["points"][i].update(changes)
    return d


def test_shipped_duty_reads():
    d = load_duty(ROOT / "studies" / "cobot_duty.yaml")
    assert d.period == pytest.approx(12.0) and d.shares.sum() == pytest.approx(1.0)
    assert d.ambient == pytest.approx(298.15) and d.wear_limit is None and len(d.gamma) == 8


@pytest.mark.parametrize("data, expect", [
    (_point(2, share="15 N*m"), ("points.2.share", "plain number")),
    (_point(1, gamma="10 mm"), ("points.1: gamma", "angle")),
    (_point(3, gamma="100 deg"), ("points.3: gamma", "at most 89")),
    (_point(0, motor_speed="10 Hz"), ("points.0: motor_speed",)),
    (_point(0, motor_speed="-1 rad/s"), ("points.0: motor_speed", "more than 0")),
    (_point(4, share="50 %"), ("shares add up to 140", "expected 100 %")),
    (_point(4, share=None, hours="3 h"), ("points.4", "expected share")),
    (_point(5, share="-10 %"), ("points.5.share", "at least 0")),
    (_point(6, tau_perp=float("nan")), ("points.6: tau_perp", "finite")),
    (_with(cycle="0 s"), ("cycle", "more than 0")),
    (_with(ambient="25 mm"), ("ambient", "temperature")),
    (_with(ambient=25), ("ambient", "did you mean '25 degC'")),
    (_with(wear_limit=0.4), ("wear_limit", "did you mean '0.4 mm'")),
    (_with(hub_ratio=1.5), ("hub_ratio", "at most 0.95")),
    (_with(points=None), ("either points or log", "neither")),
    (_with(log={"file": "log.csv"}), ("either points or log", "both")),
    (_with(extra=1), ("extra",)),
])
def test_bad_duty_file(tmp_path, data, expect):
    _refused(tmp_path, data, *expect)


LOG = {k: v for k, v in SHIPPED.items() if k != "points"} | {"log": {"file": "log.csv", "step": "1 s"}}


@pytest.mark.parametrize("log, expect", [
    ("time,gamma\n0,1\n", ("row 1", "expected the header")),
    (HEADER + "0,10,0.2,10\n1,10,0.2\n", ("row 3", "expected 4 values")),
    (HEADER + "0,10,0.2,10\n1,ten,0.2,10\n", ("row 3", "gamma_deg", "finite number")),
    (HEADER + "0,10,0.2,10\n1,95,0.2,10\n", ("row 3", "gamma", "at most 89")),
    (HEADER + "0,10,0.2,10\n2,10,0.2,10\n1,10,0.2,10\n", ("row 4", "time_s", "increase")),
    (HEADER + "0,10,0.2,10\n", ("1 data rows", "at least 2")),
    (HEADER + "0,10,0.2,10\n1,10,0.2,0\n", ("row 3", "motor_speed", "more than 0")),
])
def test_bad_task_log(tmp_path, log, expect):
    _refused(tmp_path, LOG, *expect, log=log)


def test_missing_task_log(tmp_path):
    _refused(tmp_path, LOG, "log.file", "no such file")


def test_task_log_resampled(tmp_path):
    """A log of 0–3 s held at 1 s steps: three samples of 1 s, each the last row logged at or before it."""
    (tmp_path / "log.csv").write_text(HEADER + "0,10,0.2,10\n0.5,20,0.4,12\n2.2,30,0.6,14\n3,30,0.6,14\n")
    f = tmp_path / "duty.yaml"
    f.write_text(yaml.safe_dump(LOG))
    d = load_duty(f)
    assert list(d.seconds) == [1.0, 1.0, 1.0]
    assert list(d.load) == [0.2, 0.4, 0.4] and list(d.speed) == [10, 12, 12]
    assert d.gamma[0] == pytest.approx(0.17453292519943295)
