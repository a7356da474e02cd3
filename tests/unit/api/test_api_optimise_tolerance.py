"""api.optimise and api.tolerance: the same JSON as `cvtdesign optimise --json` and `cvtdesign tolerance
--json` (but for the run-time seconds), a table, and the files written only when asked."""
import json

import pytest

from conftest import ROOT, variant_data, write_yaml

from cvtdesign import api
from cvtdesign.cli import main
from cvtdesign.cli.tolerance import LABELS
from cvtdesign.errors import InputError
from cvtdesign.uses import tolerance as uses_tolerance

KIM = ROOT / "studies" / "box_placement_kim.yaml"


def without_seconds(obj):
    """The document without its run-time fields (seconds differ between two runs)."""
    if isinstance(obj, dict):
        return {k: without_seconds(v) for k, v in obj.items() if not k.endswith(("_s", "seconds"))}
    if isinstance(obj, list):
        return [without_seconds(v) for v in obj]
    return obj


@pytest.mark.slow
def test_optimise_gives_the_commands_json(tmp_path):
    assert main(["optimise", str(KIM), "--starts", "1", "--out", str(tmp_path / "cli"),
                 "--json", str(tmp_path / "o.json")]) == 0
    result = api.optimise(KIM, starts=1, out=tmp_path / "cli")
    assert without_seconds(json.loads(result.to_json())) == without_seconds(json.loads((tmp_path / "o.json").read_text()))
    body = lambda text: [line for line in text.splitlines() if not line.startswith("#")]   # the header is dated
    assert body(result.variant_text) == body((tmp_path / "cli" / result.rows[0]["variant_file"]).read_text())
    table = result.table
    assert list(table["variable"]) == list(result.rows[0]["design"])
    assert (table["optimum"] == [result.rows[0]["design"][n] for n in table["variable"]]).all()
    # within the bounds, as IPOPT holds them (a variable on its bound may sit 1e-9 outside)
    assert ((table["lower"] - 1e-9 <= table["optimum"]) & (table["optimum"] <= table["upper"] + 1e-9)).all()
    assert list(result.intervals["design"]) == ["base", "optimum"]
    assert result.plot(tmp_path / "p").stat().st_size > 0


@pytest.mark.slow
def test_optimise_writes_its_variant_only_when_asked(tmp_path):
    result = api.optimise(KIM, starts=1, out=tmp_path / "o")
    assert not (tmp_path / "o").exists()
    [path] = result.write()
    assert path.read_text() == result.variant_text and str(path) == result.rows[0]["variant_file"]


def test_optimise_refuses_a_count_of_starts():
    with pytest.raises(InputError, match="--starts"):
        api.optimise(KIM, starts=0)


@pytest.mark.slow
def test_tolerance_gives_the_commands_json(tmp_path):
    d = variant_data("box")
    d["envelope"]["gamma"] = {"start": "-40 deg", "stop": "40 deg", "step": "40 deg"}
    d["envelope"]["load"] = {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}
    v = write_yaml(tmp_path / "small.yaml", d)
    tol = write_yaml(tmp_path / "t.yaml", {"name": "t", "seed": 0, "tolerances": [
        {"dimension": "axle", "rollers": "all", "normal": "0.1 deg"}]})
    store = tmp_path / "s"
    assert main(["tolerance", str(v), "--tolerances", str(tol), "--samples", "4", "--workers", "1",
                 "--dimensions-only", "--store", str(store), "--json", str(tmp_path / "t.json")]) == 0
    result = api.tolerance(v, tol, samples=4, dimensions_only=True, store=store, workers=1)
    assert result.to_json() == (tmp_path / "t.json").read_text()
    assert result.drawn_before == 4
    ranked = result.rows[0]["effects"]["max_abs_alpha_deg"]
    assert list(result.table["effect_deg"]) == [e["effect"] for e in ranked]
    assert result.plot(tmp_path / "p").name == "small_t_tolerance.png"
    assert uses_tolerance.LABELS["max_abs_alpha_deg"] == LABELS["max_abs_alpha_deg"]    # compare's header
