"""capacity with a safety factor so large that nothing qualifies (issue 38): every row shows '—', the
summary read "smallest capacity 0 N·m (… gross slip at ), 0×…" with an empty contact name, and the JSON's
`smallest` named a contact (D1) that no row named. Now the summary says there is no load capacity and why,
and `smallest` names no contact."""
import json

from conftest import ROOT

from cvtdesign.cli import main


def test_nothing_qualifies(tmp_path, capsys):
    out_json = tmp_path / "c.json"
    assert main(["capacity", str(ROOT / "variants" / "existing_kim.yaml"), "--safety", "1e6", "--json", str(out_json)]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "at )" not in out and "smallest capacity 0" not in out, out
    assert "existing_kim: no load capacity: 34 of 34 searches (first at γ -80°, τ⊥ > 0) reach gross slip without load: " \
           "F/(μN) reaches 1/1e+06 = 1e-06 already at τ⊥ = 0; expected a smaller --safety" in out, out
    least = json.loads(out_json.read_text())["variants"][0]["smallest"]
    assert least == {"tau_perp_Nm": 0.0, "gamma_deg": -80.0, "side": "max", "limit": "gross_slip", "contact": None}
