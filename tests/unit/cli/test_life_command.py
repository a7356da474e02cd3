"""`cvtdesign life`: the table, the JSON interface outside tools read (docs/life.md), the figures and report,
and its refusals."""
from __future__ import annotations

import json

import pytest
import yaml

from conftest import ROOT

from cvtdesign.cli import main

DUTY = str(ROOT / "studies" / "cobot_duty.yaml")
VARIANT_KEYS = {"name", "life_h", "life_h_interval", "limit", "contact", "contacts"}
CONTACT_KEYS = {"contact", "loss_mean_W", "loss_peak_W", "T_steady_C", "T_peak_C", "wear_um_per_h", "life_h", "limit"}


@pytest.fixture(scope="module")
def life_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("life")
    argv = ["life", str(ROOT / "variants" / "box.yaml"), str(ROOT / "variants" / "existing.yaml"), "--duty", DUTY,
            "--json", str(out / "life.json"), "--plots", str(out / "plots"), "--report", str(out / "life.html")]
    assert main(argv) == 0
    return out


def test_json_is_the_interface(life_run):
    data = json.loads((life_run / "life.json").read_text())
    assert set(data) == {"variants"} and [v["name"] for v in data["variants"]] == ["box", "existing"]
    for v in data["variants"]:
        assert set(v) == VARIANT_KEYS
        lo, hi = v["life_h_interval"]
        assert 0 < lo < v["life_h"] < hi
        assert v["limit"] in ("temperature", "wear", "fatigue", "runaway")
        for c in v["contacts"]:
            assert set(c) == CONTACT_KEYS and c["limit"] in ("temperature", "wear", "fatigue", "runaway")
            assert 25 < c["T_steady_C"] <= c["T_peak_C"] and c["loss_peak_W"] >= c["loss_mean_W"] > 0
        first = min(v["contacts"], key=lambda c: c["life_h"])
        assert v["life_h"] == first["life_h"] and v["contact"] == first["contact"] and v["limit"] == first["limit"]
    box, existing = data["variants"]
    assert box["contact"] in ("B", "B_") and existing["contact"] == "D2"   # spin wear where drive rollers pivot


def test_readme_figures_are_the_tools(life_run):
    """The README's life figures are what the command gives (as its table prints them, thousands spaced)."""
    from cvtdesign.io.units import number
    readme = (ROOT / "README.md").read_text()
    for v in json.loads((life_run / "life.json").read_text())["variants"]:
        lo, hi = v["life_h_interval"]
        text, lo, hi = (f"{float(number(x, 3)):,.0f}".replace(",", " ") for x in (v["life_h"], lo, hi))
        bounds = f"{lo}, {hi}"
        assert f"{text} h [{bounds}]" in readme, (text, bounds)
        assert f"({v['contact']}" in readme or f"{v['contact']})" in readme or f"rollers {v['contact']}" in readme


def test_figures_and_report(life_run):
    for f in ("box+existing_temperature.png", "box+existing_life.png"):
        assert (life_run / "plots" / f).read_bytes().startswith(b"\x89PNG")
    html = (life_run / "life.html").read_text()
    assert "cvtdesign life" in html and html.count("<img") == 2 and "limited by wear" in html


def test_record_is_the_interface():
    """The record of one variant (the fast part of the JSON check above): the keys and the first contact."""
    from conftest import shipped_model
    from cvtdesign.uses.life import ageing_of, variant_record
    from cvtdesign.core.life.run import machine_life
    from cvtdesign.io.duty_file import load_duty
    model, duty = shipped_model("existing"), load_duty(DUTY)
    life = machine_life(model, duty, ageing_of(ROOT / "variants" / "existing.yaml", model))
    rec = variant_record("existing", life, {"machine": (0.5 * life.life, 2 * life.life)}, duty.shares)
    assert set(rec) == VARIANT_KEYS and all(set(c) == CONTACT_KEYS for c in rec["contacts"])
    assert rec["life_h_interval"] == [life.life / 7200, life.life / 1800]
    assert rec["contact"] == "D2" and rec["limit"] == "wear"     # spin wear at a drive roller (FASTSIM law)


def test_duty_beyond_the_variant_is_one_line(tmp_path, capsys):
    data = yaml.safe_load(open(DUTY))
    data["points"][3]["tau_perp"] = "5 N*m"
    f = tmp_path / "duty.yaml"
    f.write_text(yaml.safe_dump(data))
    assert main(["life", str(ROOT / "variants" / "existing.yaml"), "--duty", str(f),
                 "--json", str(tmp_path / "o.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "duty point 4" in err and str(f) in err and "capacity" in err
    assert not (tmp_path / "o.json").exists()


def test_duty_is_required(capsys):
    with pytest.raises(SystemExit) as e:
        main(["life", str(ROOT / "variants" / "box.yaml")])
    assert e.value.code == 2 and "--duty" in capsys.readouterr().err


@pytest.mark.slow
def test_compare_takes_duty(tmp_path, capsys):
    """compare --duty adds each variant's life, limit and contact (the same as life's), '—' for the ideal CVT."""
    assert main(["compare", str(ROOT / "variants" / "box.yaml"), "--duty", DUTY, "--out", str(tmp_path / "c"),
                 "--json", str(tmp_path / "c.json")]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if "life on the duty cycle [h]" in line)
    assert "—" in row and "6130 (wear at D2)" in row and "6040 (wear at B)" in row
    rows = json.loads((tmp_path / "c.json").read_text())["variants"]
    assert [r.get("life_limit") for r in rows] == [None, "wear", "wear"] and rows[2]["life_contact"] == "B"
