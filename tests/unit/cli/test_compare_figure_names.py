"""A compare run on another basis keeps its own figure (issue 38): `--envelope FILE` overwrote the figure of
the same variants on the first file's envelope. It is now `<stems>_on_<FILE's stem>.png`, and with
`--as-written` `<stems>_as_written.png`."""
import hashlib

import pytest

from conftest import variant_data, write_yaml

from cvtdesign.cli import main


def small(tmp_path, name, load_stop):
    d = variant_data("existing_kim")
    d["name"] = name
    d["envelope"]["gamma"]["step"] = "40 deg"
    d["envelope"]["load"] = {"start": f"-{load_stop} N*m", "stop": f"{load_stop} N*m", "step": "0.5 N*m"}
    return write_yaml(tmp_path / f"{name}.yaml", d)


@pytest.mark.slow
def test_each_basis_its_own_figure(tmp_path, capsys):
    a, b = small(tmp_path, "wide", 1), small(tmp_path, "narrow", 0.5)
    out = tmp_path / "p"
    assert main(["compare", str(a), str(b), "--out", str(out)]) == 0
    first = out / "narrow+wide.png"
    digest = hashlib.sha1(first.read_bytes()).hexdigest()
    assert main(["compare", str(a), str(b), "--out", str(out), "--envelope", str(b)]) == 0
    assert main(["compare", str(a), str(b), "--out", str(out), "--as-written"]) == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == ["narrow+wide.png", "narrow+wide_as_written.png", "narrow+wide_on_narrow.png"], names
    assert hashlib.sha1(first.read_bytes()).hexdigest() == digest
    assert "narrow+wide_on_narrow.png" in capsys.readouterr().out
