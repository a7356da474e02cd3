"""The tolerance figure and its printed table rank the same dimensions (issue 38): the figure ranked 15 of
them and the table 10. Both now show cli.tolerance.RANKED, the largest first, and say of how many."""
import re

import pytest

from conftest import variant_data, write_yaml

from cvtdesign.cli import main
from cvtdesign.cli.tolerance import RANKED
from cvtdesign.io import plots
from figure_checks import captured, text_problems


@pytest.mark.slow
def test_figure_and_table_rank_the_same_dimensions(tmp_path, capsys, monkeypatch):
    d = variant_data("box")
    d["envelope"]["gamma"] = {"start": "-40 deg", "stop": "40 deg", "step": "40 deg"}
    d["envelope"]["load"] = {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}
    v = write_yaml(tmp_path / "small.yaml", d)
    tol = write_yaml(tmp_path / "t.yaml", {"name": "t", "seed": 0, "tolerances": [     # 8 + 2 + 2 = 12 dimensions
        {"dimension": "axle", "rollers": "all", "normal": "0.1 deg"},
        {"dimension": "fork", "rollers": "steering", "normal": "0.1 deg"},
        {"dimension": "preload", "rollers": ["A", "B"], "uniform": "10 %"}]})
    drawn = captured(monkeypatch, plots)
    assert main(["tolerance", str(v), "--tolerances", str(tol), "--samples",
                 "4", "--workers", "1", "--plots", str(tmp_path / "p"), "--store", str(tmp_path / "s")]) == 0
    out = " ".join(capsys.readouterr().out.split())
    printed = re.search(r"\((\d+) of (\d+); all in --json\)", out)
    assert printed and int(printed[1]) == RANKED < int(printed[2]), out
    ranked = drawn[-1].axes[1]
    names = [t.get_text() for t in ranked.get_yticklabels()]
    assert len(names) == RANKED and f"({RANKED} of {printed[2]})" in ranked.get_title()
    rows = out.split("(10 of")[1]
    assert all(n.split(",")[0] in rows for n in names), (names, rows)
    assert text_problems(drawn[-1]) == []
