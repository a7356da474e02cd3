"""cvtdesign as a library: what the commands do, as functions that return Python objects (docs/python-api.md).

    >>> from cvtdesign import api
    >>> box = api.load_variant("variants/box.yaml")
    >>> states = api.evaluate(box, gamma_deg=[-40, 0, 40], load_Nm=0.5)      # a pandas.DataFrame
    >>> result = api.compare("variants/existing.yaml", "variants/box.yaml")
    >>> result.table                                                         # a pandas.DataFrame
    >>> result.to_json() == open("out/compare.json").read()                  # `cvtdesign compare --json`'s text
    >>> api.diagnose("variants/existing_kim.yaml", pandas.read_csv("rig.csv")).report.verdict

Every value is in the unit its name gives (``_deg`` [°], ``_Nm`` [N·m], ``_MPa`` [MPa], ``_W`` [W]), inputs
and layouts in SI otherwise. Bad input raises cvtdesign.errors.InputError, one line naming the file, field or
argument. The names below are the interface; the modules behind them may change.
"""
from cvtdesign.uses.comparison import Comparison, compare
from cvtdesign.uses.diagnosis import Diagnosis, diagnose
from cvtdesign.uses.life import Life, life
from cvtdesign.uses.load_capacity import Capacity, capacity
from cvtdesign.uses.optimum import Optimum, optimise
from cvtdesign.uses.result import Result
from cvtdesign.uses.tolerance import Tolerance, tolerance
from cvtdesign.uses.transient import Transient, transient
from cvtdesign.uses.variant import evaluate, load_variant
from cvtdesign.errors import InputError

__all__ = ["Capacity", "Comparison", "Diagnosis", "InputError", "Life", "Optimum", "Result", "Tolerance", "Transient", "capacity",
           "compare", "diagnose", "evaluate", "life", "load_variant", "optimise", "tolerance", "transient"]
