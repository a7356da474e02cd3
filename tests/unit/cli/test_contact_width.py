"""`contact` prints at the terminal's width and never cuts a number (issue 38): it printed at a fixed 150
columns whatever the terminal, cutting numbers to `0.0007…` and `(theor…`. A table wider than the terminal
wraps its headers at their words and keeps every cell whole; the notes follow the terminal's width."""
import pytest

from conftest import variant_data, write_yaml

from cvtdesign.cli import main


@pytest.mark.parametrize("columns", [60, 100, 250])
def test_contact_follows_the_terminal_and_never_cuts_a_number(tmp_path, capsys, monkeypatch, columns):
    data = variant_data("box")
    data["contact"] = {"calibration": {"drive": 1, "steering": 1}}        # theory only: ε used '… (theory)'
    f = write_yaml(tmp_path / "theory.yaml", data)
    monkeypatch.setenv("COLUMNS", str(columns))
    assert main(["contact", str(f)]) == 0
    lines = capsys.readouterr().out.splitlines()
    rows = [ln for ln in lines if ln.startswith("│ ")]
    assert len(rows) == 8 and not any("…" in ln for ln in lines), "\n".join(lines)
    assert all("(theory)" in ln and "0.00121" in ln for ln in rows if "drive" in ln), "\n".join(rows)
    notes = [ln for ln in lines if ln and ln[0] not in "│┃┏┡└ " and "contact patches" not in ln]
    assert notes and max(len(ln) for ln in notes) <= columns, notes
    if columns == 250:           # wide enough: the table as it is, no header wrapped
        assert max(len(ln) for ln in lines) <= columns and sum(ln.startswith("┃") for ln in lines) == 1
