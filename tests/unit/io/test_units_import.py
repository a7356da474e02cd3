"""io.units hides Dask from pint while pint loads (pint 0.25 would import dask.base, a tenth of a second of
every start, only to recognise dask arrays). Units still convert, Dask still imports afterwards, and a
process that imported Dask first keeps pint's Dask support. Each case runs in a fresh interpreter."""
import subprocess
import sys

import pytest

CASES = {
    "units first": ("import sys\n"
                    "from cvtdesign.io.units import to_si\n"
                    "assert 'dask' not in sys.modules, 'pint loaded dask'\n"
                    "assert to_si('40 mm', 'length', 'x') == 0.04 and to_si('1 N*m', 'torque', 'x') == 1.0\n"
                    "import dask.base, pint.compat\n"
                    "assert dask.base.is_dask_collection(1) is False and not pint.compat.HAS_DASK\n"),
    "dask first": ("import dask.base\n"
                   "from cvtdesign.io.units import to_si\n"
                   "import pint.compat\n"
                   "assert pint.compat.HAS_DASK and to_si('25 MPa', 'pressure', 'x') == 25e6\n"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_pint_without_dask_and_dask_after(case):
    run = subprocess.run([sys.executable, "-c", CASES[case]], check=False, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
