"""The shape every result of the Python API shares: the rows as the command's JSON holds them (`rows`), a
pandas DataFrame of their plain fields (`table`), the command's JSON text (`to_json`) and its figure
(`plot`)."""
from __future__ import annotations

from abc import ABC, abstractmethod
from pathlib import Path

from cvtdesign.io.points import data_frame
from cvtdesign.io.strict_json import finite, json_text


def table_row(row: dict, prefix: str = "") -> dict:
    """The plain fields of one JSON row, for a table: numbers, strings and booleans as they are, each 95 %
    interval ``[low, high]`` as two columns ``<figure>_low`` and ``<figure>_high``; nested records (budgets,
    calibrations, where a figure is taken) are left to the rows."""
    out = {}
    for key, value in finite(row).items():
        if key.endswith("_interval") and isinstance(value, list) and len(value) == 2:
            out[f"{prefix}{key[:-len('_interval')]}_low"], out[f"{prefix}{key[:-len('_interval')]}_high"] = value
        elif value is None or isinstance(value, (bool, int, float, str)):
            out[prefix + key] = value
    return out


class Result(ABC):
    """A command's result in Python: `rows` (list of dict), the records of the command's JSON, with units in
    the field names (``_deg`` [°], ``_Nm`` [N·m], ``_MPa`` [MPa], ``_W`` [W], ``_h`` [h]); `table` (a
    pandas.DataFrame of their plain fields); `to_json()` (the command's ``--json`` text); `plot(path)`."""

    rows: list[dict]

    @abstractmethod
    def content(self) -> dict:
        """The command's JSON document (a dict), before it is made text."""

    def table_rows(self) -> list[dict]:
        """The table's rows (Result.table): each of `rows`, with its plain fields only (table_row)."""
        return [table_row(r) for r in self.rows]

    @property
    def table(self):
        """The rows' plain fields as a pandas.DataFrame, one row per record, each 95 % interval as the columns
        ``<figure>_low`` and ``<figure>_high``, in the units the column names give."""
        return data_frame(self.table_rows())

    def to_json(self) -> str:
        """The command's ``--json`` text: strict JSON (NaN and ±inf as null), indented, byte for byte what the
        command writes for the same inputs."""
        return json_text(self.content())

    @abstractmethod
    def plot(self, path=None) -> Path:
        """Draw the command's figure as a PNG at `path` (default: where the command would put it, under out/),
        through the one writer; returns the path written."""
