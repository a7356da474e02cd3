"""No silent loss, no false report (issue 38): options that were accepted and then quietly lost something.

* Two outputs on one path: `--json o.csv --points o.csv` wrote the points over the JSON and printed both
  "written to" lines.
* Contradicting options: `--envelope FILE --as-written` ignored --envelope without a word; `--workers N
  --scheduler ADDRESS` ignored --workers; rig's `--noise axis=… --no-axis` ignored the axis noise.
* Empty values: `resteer --table t.csv --table-ratios ''` (an unset shell variable) wrote the default table of
  17 ratios, where a reversed grid or a count of 0 is refused; `--json ''` wrote no JSON.

Each case goes through the CLI in-process and keeps the promise of test_every_command.py: exit status 2, one
line naming the option, no traceback, nothing written."""
from __future__ import annotations

import pytest

from test_every_command import cli, run_and_check


CASES = []


def case(id, expect, *argv):
    CASES.append(pytest.param(cli(*argv), expect, id=id))


# two outputs on one path (item 1): one check for every command's output options
case("compare: --json and --points on one file", ("--points", "o.csv is also --json's path"),
     "compare", "{v}", "--out", "{out}/p", "--json", "{out}/o.csv", "--points", "{out}/o.csv")
case("compare: --json and --report on one file, spelt two ways", ("--report", "is also --json's path"),
     "compare", "{v}", "--out", "{out}/p", "--json", "{out}/r.html", "--report", "{out}/./r.html")
case("compare: --json on the --out folder", ("--out", "is also --json's path"),
     "compare", "{v}", "--out", "{out}/p", "--json", "{out}/p")
case("capacity: --json into the --plots folder's path", ("--plots", "is also --json's path"),
     "capacity", "{v}", "--json", "{out}/c", "--plots", "{out}/c")
case("diagnose: --json and --report on one file", ("--report", "is also --json's path"),
     "diagnose", "{csv}", "--variant", "{v}", "--json", "{out}/d.json", "--report", "{out}/d.json")
case("diagnose: --save-calibration and --json on one file", ("--save-calibration", "is also --json's path"),
     "diagnose", "{csv}", "--variant", "{v}", "--json", "{out}/d.yaml", "--save-calibration", "{out}/d.yaml")
case("optimise: --json and --report on one file", ("--report", "is also --json's path"),
     "optimise", "{tmp}/work/studies/box_placement.yaml", "--json", "{out}/o.json", "--report", "{out}/o.json")
case("tolerance: --json and --store on one path", ("--store", "is also --json's path"),
     "tolerance", "{v}", "--tolerances", "{tmp}/work/studies/box_tolerances.yaml", "--json", "{out}/t",
     "--store", "{out}/t")
case("contact: --json on the --plots folder", ("--plots", "is also --json's path"),
     "contact", "{v}", "--json", "{out}/k", "--plots", "{out}/k")
case("compare: --json on the default --out folder", ("--out", "is also --json's path"),
     "compare", "{v}", "--json", "out/compare")

# contradicting options (item 2)
case("compare: --envelope with --as-written", ("--envelope", "expected one of --envelope and --as-written"),
     "compare", "{v}", "--out", "{out}/p", "--envelope", "{v}", "--as-written")
case("study: --workers with --scheduler", ("--workers", "expected one of --workers and --scheduler"),
     "study", "{tmp}/work/studies/box_placement.yaml", "--out", "{out}/s", "--workers", "1",
     "--scheduler", "tcp://127.0.0.1:1")
case("selfcheck: --workers with --scheduler", ("--workers", "expected one of --workers and --scheduler"),
     "selfcheck", "--quick", "--workers", "1", "--scheduler", "tcp://127.0.0.1:1", "--json", "{out}/s.json")
case("tolerance: --workers with --scheduler", ("--workers", "expected one of --workers and --scheduler"),
     "tolerance", "{v}", "--tolerances", "{tmp}/work/studies/box_tolerances.yaml", "--workers", "1",
     "--scheduler", "tcp://127.0.0.1:1")
case("rig: --noise axis=… with --no-axis", ("--noise", "--no-axis", "expected one of them"),
     "rig", "{v}", "--out", "{out}/d.csv", "--no-axis", "--noise", "speed=0.01,axis=0.1 deg")

# empty values (item 3): the empty grid is refused as a reversed one is, and so is every other empty value
case("resteer: --table-ratios ''", ("--table-ratios", "empty"), "resteer", "{v}", "--table", "{out}/t.csv",
     "--table-ratios", "")
case("resteer: --table-loads ''", ("--table-loads", "empty"), "resteer", "{v}", "--table", "{out}/t.csv",
     "--table-loads", "")
case("resteer: --ratios ''", ("--ratios", "empty"), "resteer", "{v}", "--json", "{out}/r.json", "--ratios", "")
case("compare: --json ''", ("--json", "empty"), "compare", "{v}", "--out", "{out}/p", "--json", "")
case("rig: --effects ''", ("--effects", "empty"), "rig", "{v}", "--out", "{out}/d.csv", "--effects", "")
case("compare: an empty variant argument", ("variants", "empty"), "compare", "{v}", "", "--out", "{out}/p")
case("capacity: --plots '  '", ("--plots", "empty"), "capacity", "{v}", "--plots", "  ")


@pytest.mark.parametrize("build, expect", CASES)
def test_refused_in_one_line(build, expect, tmp_path, capfd, monkeypatch):
    run_and_check(build, expect, tmp_path, capfd, monkeypatch, 60)


def test_an_empty_table_axis_is_refused_by_the_parser_itself():
    """resteer.parse_axis refuses '' as it refuses a reversed grid (not only the command line)."""
    from cvtdesign.diagnosis.resteer import parse_axis, ratio_value
    from cvtdesign.errors import InputError
    for text in ("", " ", ","):
        with pytest.raises(InputError, match="--table-ratios"):
            parse_axis(text, "--table-ratios", ratio_value)
