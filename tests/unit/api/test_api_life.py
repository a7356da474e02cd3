"""api.life: the same JSON as `cvtdesign life --json`, and a table of every contact."""
import pytest

from conftest import ROOT

from cvtdesign import api
from cvtdesign.cli import main
from cvtdesign.errors import InputError

DUTY = ROOT / "studies" / "cobot_duty.yaml"
EXISTING = ROOT / "variants" / "existing.yaml"


@pytest.mark.slow
def test_life_gives_the_commands_json(tmp_path):
    assert main(["life", str(EXISTING), "--duty", str(DUTY), "--json", str(tmp_path / "life.json")]) == 0
    result = api.life(EXISTING, duty=DUTY)
    assert result.to_json() == (tmp_path / "life.json").read_text()
    record = result.rows[0]
    table = result.table
    assert list(table["contact"]) == [c["contact"] for c in record["contacts"]]
    assert (table["machine_life_h"] == record["life_h"]).all()
    assert record["life_h_interval"][0] <= record["life_h"] <= record["life_h_interval"][1]
    folder = result.plot(tmp_path / "figures")
    assert sorted(p.name for p in folder.iterdir()) == ["existing_life.png", "existing_temperature.png"]


def test_life_refuses_no_variant():
    with pytest.raises(InputError, match="no variant"):
        api.life(duty=DUTY)
