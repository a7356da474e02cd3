"""`compare` run in-process (cli.main with an argv) turns Python's garbage collector off only while it runs
and ends its plotting process, on success and on bad input alike."""
import gc
import multiprocessing

import pytest
from conftest import variant_path

from cvtdesign.cli import main


@pytest.mark.parametrize("collecting", [True, False])
def test_compare_leaves_the_collector_as_it_was(tmp_path, capsys, collecting):
    was = gc.isenabled()
    (gc.enable if collecting else gc.disable)()
    try:
        assert main(["compare", str(tmp_path / "missing.yaml"), "--out", str(tmp_path / "out")]) == 2
        assert "missing.yaml" in capsys.readouterr().err
        assert gc.isenabled() is collecting
        assert main(["compare", str(variant_path("box")), "--out", str(tmp_path / "out")]) == 0
        assert gc.isenabled() is collecting
    finally:
        (gc.enable if was else gc.disable)()
    assert not multiprocessing.active_children()
    assert (tmp_path / "out" / "compare.png").stat().st_size > 20_000
