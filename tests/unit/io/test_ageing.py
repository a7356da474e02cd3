"""The materials' ageing constants (io/ageing.py): from the library, overridden by the variant's own material
constant by constant, in SI with a relative σ."""
from __future__ import annotations

import pytest
import yaml

from conftest import ROOT

from cvtdesign.core.life.props import modulus_factor
from cvtdesign.errors import InputError
from cvtdesign.io.ageing import material_ageing, roller_ageing
from cvtdesign.io.variant import load_spec


def test_library_gives_what_the_variant_omits():
    f = str(ROOT / "variants" / "box_kim.yaml")
    a = roller_ageing(f, load_spec(f), ["A", "N1"])
    urethane, ball = a["A"]
    assert urethane.material == "urethane_82A" and ball.material == "bowling_ball"
    assert urethane["max_temperature"] == pytest.approx(343.15)          # 70 °C
    assert urethane.std["max_temperature"] == pytest.approx(5 / 343.15)  # 5 K, relative
    assert urethane.std["wear_coefficient"] == pytest.approx(0.6)
    assert "library" in urethane.source["density"]
    assert a["N1"][0].material == "urethane_84A"


def test_variant_overrides_one_constant(tmp_path):
    data = yaml.safe_load((ROOT / "variants" / "box_kim.yaml").read_text())
    data["materials"]["urethane_82A"]["ageing"] = {
        "wear_coefficient": {"value": "2e-5 mm**3/J", "std": "1e-5 mm**3/J", "source": "our abrasion test"}}
    f = tmp_path / "v.yaml"
    f.write_text(yaml.safe_dump(data))
    m = material_ageing(str(f), load_spec(f), "urethane_82A")
    assert m["wear_coefficient"] == pytest.approx(2e-14) and m.std["wear_coefficient"] == pytest.approx(0.5)
    assert "our abrasion test" in m.source["wear_coefficient"] and m["density"] == 1100.0


def test_half_modulus_at_93C():
    f = str(ROOT / "variants" / "box_kim.yaml")
    m = material_ageing(f, load_spec(f), "urethane_82A")
    assert modulus_factor(m, 366.15) == pytest.approx(0.5) and modulus_factor(m, 298.15) == pytest.approx(1.0)


@pytest.mark.parametrize("entry, expect", [
    ({"value": "-1 m**3/J", "std": "10 %", "source": "x"}, "wear_coefficient.value: expected a positive"),
    ({"value": "1e-14 m**3/J", "std": "-10 %", "source": "x"}, "wear_coefficient.std: expected a standard"),
    ({"value": "1e-14 N", "std": "10 %", "source": "x"}, "wear_coefficient.value: expected a wear_coefficient"),
])
def test_bad_constant(tmp_path, entry, expect):
    data = yaml.safe_load((ROOT / "variants" / "box_kim.yaml").read_text())
    data["materials"]["urethane_82A"]["ageing"] = {"wear_coefficient": entry}
    f = tmp_path / "v.yaml"
    f.write_text(yaml.safe_dump(data))
    with pytest.raises(InputError, match=expect.replace("(", r"\(")):
        material_ageing(str(f), load_spec(f), "urethane_82A")
