"""What a cold `cvtdesign compare` loads: not pyplot (the figure is drawn on an Agg canvas), not Dask (pint,
the units library, would import dask.base if io.units did not hide it), not CadQuery or OpenCascade. One
fresh process runs the command with `python -X importtime`, whose report on stderr names every module
imported by the process and by the plotting process it forks. How long it takes is measured in
benchmarks/bench_model.py, not here."""
import re
import subprocess
import sys

import pytest

from conftest import ROOT

NOT_LOADED = ("dask", "distributed", "cadquery", "OCP")     # packages, and pyplot
SCRIPT = """
import sys
from cvtdesign.cli import main
status = main(["compare", "variants/box_kim.yaml", "--out", sys.argv[1]])
print("status", status, "parent modules:", " ".join(sorted(sys.modules)))
"""


@pytest.mark.slow
def test_compare_imports_no_pyplot_dask_or_cadquery(tmp_path):
    run = subprocess.run([sys.executable, "-X", "importtime", "-c", SCRIPT, str(tmp_path)], cwd=ROOT,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0 and "status 0" in run.stdout, run.stderr[-2000:]
    imported = set(re.findall(r"^import time:\s+\d+ \|\s+\d+ \|\s*(\S+)", run.stderr, re.MULTILINE))
    imported |= set(run.stdout.split("parent modules:")[1].split())
    assert "cvtdesign.cli.compare" in imported and "matplotlib.figure" in imported   # both processes reported
    loaded = sorted(m for m in imported if m.split(".")[0] in NOT_LOADED or m.startswith("matplotlib.pyplot"))
    assert not loaded, f"loaded on the compare path: {loaded}"
    assert (tmp_path / "box.png").stat().st_size > 20_000
