"""What a cold `cvtdesign compare` loads: not pyplot (the figure is drawn on an Agg canvas), not Dask (pint,
the units library, would import dask.base if io.units did not hide it), not CadQuery or OpenCascade, not
pandas (only `--points` writes a table with it) and not scipy.optimize (only a linkage being refused is fitted
with it). One
fresh process runs the command with `python -X importtime`, whose report on stderr names every module
imported by the process and by the plotting process it forks. How long it takes is measured in
benchmarks/bench_model.py, not here."""
import re
import subprocess
import sys

import pytest

from conftest import ROOT

NOT_LOADED = ("dask", "distributed", "cadquery", "OCP", "pandas")     # packages, and pyplot and scipy.optimize
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
    loaded = sorted(m for m in imported if m.split(".")[0] in NOT_LOADED or m.startswith(("matplotlib.pyplot",
                                                                                        "scipy.optimize")))
    assert not loaded, f"loaded on the compare path: {loaded}"
    assert (tmp_path / "box_kim.png").stat().st_size > 20_000


IMPORT_ONLY = """
import sys
from cvtdesign.cli import main, compare
from cvtdesign.io import plots
from cvtdesign.io.variant import load_variant
load_variant("variants/box.yaml")
print(" ".join(sorted(sys.modules)))
"""


def test_the_compare_path_imports_no_pandas_or_scipy_optimize():
    """Importing the command line and compare's module and reading a variant (its linkage checked) loads
    neither pandas nor scipy.optimize: about half a second of a cold compare's CPU time before they were left to
    `--points` and to a linkage's refusal (the full run's imports: the slow test above)."""
    run = subprocess.run([sys.executable, "-c", IMPORT_ONLY], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    modules = set(run.stdout.split())
    assert "cvtdesign.cli.compare" in modules and "cvtdesign.core.linkage" in modules
    assert not sorted(m for m in modules if m.split(".")[0] == "pandas" or m.startswith("scipy.optimize"))
