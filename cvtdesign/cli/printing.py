"""What the commands print and write: quantities in engineering units, tables and notes (printed with rich,
reported in HTML), strict JSON, counts of left-out points, progress bars."""
from __future__ import annotations

import contextlib
import shlex
from importlib.metadata import version

from rich import table as rich_tables
from rich.cells import cell_len
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.text import Text

from cvtdesign.io.report import Note, Table, html_report
from cvtdesign.io.units import KINDS, dimension_of, dimensions

def kind_of(*raws) -> str:
    """The kind (a units.KINDS key) of a quantity from how a file writes it: the first of `raws` with a unit
    decides ('30 mm' a length, '10 deg' an angle, '100 N' a force); plain numbers and expressions say
    nothing, and with nothing said the kind is 'dimensionless'."""
    for raw in raws:
        dim = dimension_of(raw)            # None: an expression, {}: a plain number
        kind = next((k for k in KINDS if dim and dim in dimensions(k)), None)
        if kind:
            return kind
    return "dimensionless"


def rich_table(t: Table):
    """A report Table as a rich table (cells taken as plain text, not as rich markup)."""
    out = rich_tables.Table(title=t.title)
    for i, h in enumerate(t.headers):
        out.add_column(Text(h), justify="left" if i == 0 else "right", no_wrap=i == 0)   # names in full
    for row, style in zip(t.rows, t.styles or [""] * len(t.rows)):
        out.add_row(*[Text(c) for c in row], style=RICH_STYLES[style])
    return out


def cell_widths(t: Table) -> list[int]:
    """Per column, the width that shows every cell whole and its header wrapped at its words."""
    return [max([cell_len(w) for w in h.split()] + [cell_len(r[i]) for r in t.rows] + [1])
            for i, h in enumerate(t.headers)]


RICH_STYLES = {"": None, "good": "green", "bad": "red", "warn": "yellow", "bold": "bold"}


def show(console, blocks: list):
    """Print the blocks of a report: Tables and Notes (Figures are for the HTML report only). A table is never
    cut: where the console is narrower than the table at its narrowest (each column as wide as its longest
    word: a number, a name), it is printed that wide, and the terminal wraps its lines, rather than its
    numbers ending in '…'."""
    for b in blocks:
        if isinstance(b, Table):
            table, width, need = rich_table(b), console.width, cell_widths(b)
            if sum(max(cell_len(h), n) + 3 for h, n in zip(b.headers, need)) + 1 > width:
                for column, n in zip(table.columns, need):     # the headers wrap at their words, no cell is cut
                    column.width = n
                console.width = max(width, sum(n + 3 for n in need) + 1)
            console.print(table)
            console.width = width
        elif isinstance(b, Note):
            console.print(b.text, style=RICH_STYLES[b.style], markup=False)


def command_line(args) -> str:
    """The command as typed ('cvtdesign compare variants/box_kim.yaml --report r.html'), from args.argv (the
    arguments main parsed)."""
    return shlex.join(["cvtdesign", *getattr(args, "argv", [args.command])])


def report_text(args, title: str, blocks: list) -> str:
    """The HTML report (io.report.html_report) of a command's blocks, headed by its command line and the
    installed version of cvtdesign."""
    return html_report(title, command_line(args), version("cvtdesign"), blocks)


def left_out_text(counts: dict) -> str:
    """'gross slip at 12 points (D1 ×8, S1 ×4); lost contact at 3 points (S2 ×3)' from model.status_counts."""
    parts = []
    named = {"reversed": "the sphere turning backwards (reversed)",
             "multiple_roots": "two roots, the state depending on the load's history (multiple roots)"}
    for key in ("lost_contact", "gross_slip", "not_converged", "reversed", "multiple_roots"):
        if counts.get(key):
            at = counts.get(f"{key}_at") or {}
            if isinstance(at, list):        # points (core.metrics: not_converged_at), the first few
                at = {f"γ {p['gamma_deg']:g}° τ⊥ {p['tau_perp_Nm']:g} N·m": 1 for p in at[:3]} | \
                    ({"…": len(at) - 3} if len(at) > 3 else {})
            where = f" ({', '.join(f'{k} ×{v}' if v > 1 or k == '…' else k for k, v in at.items())})" if at else ""
            what = named.get(key, key.replace('_', ' '))
            parts.append(f"{what} at {counts[key]} points{where}")
    return "; ".join(parts)


@contextlib.contextmanager
def progress_bar(console, label: str, describe, transient: bool = False):
    """A rich progress bar (label, bar, done/total, elapsed time, the last item) as the callback
    progress(done, total, item) that long computations take; `describe(item)` says what the item was
    (item None: nothing finished yet). The bar appears at the first call, once the computation has checked
    its inputs and starts: a command refused before that prints its one line and no empty bar."""
    bar = Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                   TextColumn("{task.description}"), console=console, transient=transient)
    tasks = []

    def progress(done, total, item):
        if not tasks:
            bar.start()
            tasks.append(bar.add_task("", total=None))
        bar.update(tasks[0], total=total, completed=done, description="" if item is None else describe(item))

    try:
        yield progress
    finally:
        if tasks:
            bar.stop()
