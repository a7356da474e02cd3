"""What `cvtdesign diagnose` loads: not scipy.stats (issue 35). The diagnosis's three significance tests (χ²,
one-way ANOVA, Wilcoxon signed-rank) are computed by diagnose.significance from numpy and scipy.special, which
the fit loads anyway; scipy.stats cost about a third of a second of a 3.5 s run on Kim's 187 rows. Each test
runs a fresh process; how long the command takes is measured in benchmarks/bench_diagnose.py, not here."""
import subprocess
import sys

import pytest

from conftest import ROOT

IMPORT_ONLY = """
import sys
from cvtdesign.cli import main, diagnose
from cvtdesign.diagnosis.diagnose import crossval, explain, sequence
print(" ".join(sorted(sys.modules)))
"""

WHOLE_RUN = """
import sys
from cvtdesign.cli import main
folder = sys.argv[1]
open(folder + "/p.yaml", "w").write("gamma: {start: -60 deg, stop: 60 deg, step: 10 deg}\\n"
                                    "load: ['-0.8 N*m', '-0.4 N*m', '0 N*m', '0.4 N*m', '0.8 N*m']\\n")
assert main(["rig", "variants/existing_kim.yaml", "--protocol", folder + "/p.yaml", "--out", folder + "/d.csv"]) == 0
status = main(["diagnose", folder + "/d.csv", "--variant", "variants/existing_kim.yaml", "--base",
               "drive_longitudinal_creep", "--json", folder + "/r.json"])
print("status", status, "modules:", " ".join(sorted(sys.modules)))
"""


COLLECTOR = """
import gc
passes = []
gc.callbacks.append(lambda phase, info: phase == "start" and passes.append(info["generation"]))
from cvtdesign.cli import parser
passes.clear()
module = parser._command_module("diagnose", None)
print(module.__name__, "passes", len(passes), "enabled", gc.isenabled(), "frozen", gc.get_freeze_count())
"""


def stats_modules(modules) -> list:
    return sorted(m for m in modules if m == "scipy.stats" or m.startswith("scipy.stats."))


def test_the_diagnose_path_imports_no_scipy_stats():
    """Importing the command line, diagnose's command and the diagnosis's modules that test significance."""
    run = subprocess.run([sys.executable, "-c", IMPORT_ONLY], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    modules = set(run.stdout.split())
    assert {"cvtdesign.cli.diagnose", "cvtdesign.diagnosis.diagnose.crossval"} <= modules
    assert not stats_modules(modules), f"loaded on the diagnose path: {stats_modules(modules)[:5]}"


@pytest.mark.slow
def test_a_whole_diagnosis_imports_no_scipy_stats(tmp_path):
    """A whole `diagnose` run (65 rows of the virtual rig on Kim's CVT), its report's p-values computed."""
    run = subprocess.run([sys.executable, "-c", WHOLE_RUN, str(tmp_path)], cwd=ROOT, capture_output=True, text=True,
                         timeout=600)
    assert run.returncode == 0 and "status 0" in run.stdout, run.stderr[-2000:]
    modules = set(run.stdout.split("modules:")[1].split())
    assert not stats_modules(modules), f"loaded by a diagnosis: {stats_modules(modules)[:5]}"
    assert "scipy.optimize" in modules and "cvtdesign.diagnosis.diagnose.significance" in modules
    assert '"p"' in (tmp_path / "r.json").read_text()


def test_the_diagnose_module_is_imported_without_the_collector_then_frozen():
    """The collector's passes during the imports of diagnose's libraries took 0.12–0.15 s, for no garbage; the
    objects they made are frozen when the command is the process's (so the exit does not walk them either)."""
    run = subprocess.run([sys.executable, "-c", COLLECTOR], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    name, _, passes, _, enabled, _, frozen = run.stdout.split()
    assert name == "cvtdesign.cli.diagnose" and int(passes) == 0 and enabled == "True" and int(frozen) > 50_000
