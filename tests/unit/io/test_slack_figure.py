"""The placement report's slack figure (issue 38): a slack of 1900 % was drawn as a plain 100 % bar. A bar
past 100 % is now hatched, ends in an arrow, and its label says it is cut and gives the share."""
from cvtdesign.io.plots import optimum as optimum_figures
from figure_checks import captured, text_problems


def test_a_slack_past_100_percent_is_not_a_full_bar(monkeypatch, tmp_path):
    figures = captured(monkeypatch, optimum_figures)
    rows = [("clearance", "38 mm (1900 % of the bound)", 1900.0, False),
            ("hertz_pressure", "2.1 MPa (35 % of the bound)", 35.0, False),
            ("normal_force", "0 N", 0.0, True)]
    optimum_figures.slack_figure(rows, tmp_path / "slack.png")
    assert (tmp_path / "slack.png").stat().st_size > 0
    fig = figures[-1]
    ax = fig.axes[0]
    bars = ax.patches
    assert [b.get_hatch() for b in bars] == ["///", None, None]
    texts = [t.get_text() for t in ax.texts]
    assert texts[0] == "bar cut at 100 %: 38 mm (1900 % of the bound)" and texts[1] == "2.1 MPa (35 % of the bound)"
    assert any(ln.get_marker() == ">" for ln in ax.get_lines())
    assert text_problems(fig) == []
