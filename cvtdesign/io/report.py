"""The HTML report of a command (`--report FILE.html`): one self-contained file, readable in any browser.

A command builds what it shows once, as blocks: `Table` (a title, column headers and rows of formatted text,
units included), `Note` (a line of text) and `Figure` (a PNG, embedded as base64). The command prints the
blocks (cli.printing.show) and hands the same blocks to `html_report`, so the report holds the printed data.
A report adds blocks that only it shows: `Summary` (the answer in plain words, then how sure it is: what a
report opens with), `Heading` (a section's title) and `Glossary` (what each figure and column means).
The page fits any width: wide tables scroll inside their own box; a figure shrinks to the page down to
READABLE of its own width (its text stays legible), and below that keeps that width and scrolls inside its own
box (a compare figure at 700 px).
Every text is HTML-escaped; the file references nothing outside itself (no scripts, styles or images
fetched), so it can be mailed or archived as it is.
"""
from __future__ import annotations

import base64
import datetime
import html
from dataclasses import dataclass, field
from pathlib import Path

from cvtdesign.errors import InputError

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
READABLE = 0.8      # the smallest share of its own width a figure is shown at: below, it scrolls in its own box
STYLES = ("", "good", "bad", "warn", "bold")     # what a row or a note stands for (colours in print and HTML)


@dataclass
class Table:
    """A table as printed and as reported: `rows` of already formatted cells (units included), one style
    of STYLES per row (default: none). The first column is text; the others are right-aligned."""
    title: str
    headers: list[str]
    rows: list[list[str]] = field(default_factory=list)
    styles: list[str] = field(default_factory=list)

    def add(self, *cells, style: str = ""):
        """Append a row of len(headers) cells (each turned into text)."""
        if len(cells) != len(self.headers):
            raise ValueError(f"table '{self.title}': {len(cells)} cells for {len(self.headers)} columns")
        self.rows.append([str(c) for c in cells])
        self.styles.append(style)


@dataclass
class Note:
    """A line of text, with a style of STYLES."""
    text: str
    style: str = ""


@dataclass
class Figure:
    """A PNG figure and its caption."""
    caption: str
    png: bytes


@dataclass
class Summary:
    """What a report opens with: the answer in plain words, then how sure it is."""
    answer: str
    sureness: str


@dataclass
class Heading:
    """A section's title."""
    text: str


@dataclass
class Glossary:
    """Terms and what they mean: every figure and every column a report shows."""
    entries: list[tuple[str, str]]


def png_figure(path, caption: str | None = None) -> Figure:
    """A written PNG file as a Figure (caption: the file name); one InputError line if it is not a PNG."""
    path = Path(path)
    data = path.read_bytes()
    if not data.startswith(PNG_SIGNATURE):
        raise InputError(f"{path}: not a PNG file; expected a figure written by cvtdesign")
    return Figure(caption or path.name, data)


CSS = """
body { font-family: system-ui, sans-serif; margin: 2em auto; padding: 0 1em; max-width: 1300px; color: #222; }
header { border-bottom: 1px solid #ccc; margin-bottom: 1.5em; }
code { background: #f4f4f4; padding: 0.1em 0.3em; }
code { overflow-wrap: anywhere; }
.scroll { overflow-x: auto; max-width: 100%; }
table { border-collapse: collapse; margin: 1.2em 0; font-size: 0.9em; }
caption { text-align: left; font-weight: bold; padding: 0.3em 0; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; }
th { background: #eef; }
td:not(:first-child) { text-align: right; font-variant-numeric: tabular-nums; }
.good { color: #060; } .bad { color: #b00; } .warn { color: #a60; } .bold { font-weight: bold; }
figure { margin: 1.5em 0; } img { max-width: 100%; height: auto; } figcaption { font-size: 0.9em; color: #555; }
.summary { background: #f5f8fc; border-left: 4px solid #36c; padding: 0.6em 1em; margin: 1em 0; }
.summary p { margin: 0.4em 0; }
dl { display: grid; grid-template-columns: minmax(8em, max-content) 1fr; gap: 0.3em 1em; }
dt { font-weight: bold; } dd { margin: 0; }
@media (max-width: 700px) { dl { grid-template-columns: 1fr; } dd { margin-left: 1em; } }
"""


def _table_html(t: Table) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in t.headers)
    body = []
    for row, style in zip(t.rows, t.styles or [""] * len(t.rows)):
        cls = f' class="{style}"' if style else ""
        body.append(f"<tr{cls}>" + "".join(f"<td>{html.escape(c)}</td>" for c in row) + "</tr>")
    return (f"<div class=\"scroll\"><table>\n<caption>{html.escape(t.title)}</caption>\n<thead><tr>{head}</tr></thead>\n"
            f"<tbody>\n" + "\n".join(body) + "\n</tbody>\n</table></div>")


def _block_html(block) -> str:
    if isinstance(block, Table):
        return _table_html(block)
    if isinstance(block, Note):
        cls = f' class="{block.style}"' if block.style else ""
        return f"<p{cls}>{html.escape(block.text)}</p>"
    if isinstance(block, Figure):
        data = base64.b64encode(block.png).decode("ascii")
        caption = html.escape(block.caption)
        width = int.from_bytes(block.png[16:20], "big")            # the PNG's IHDR width [pixels]
        return (f'<figure><div class="scroll"><img alt="{caption}" style="min-width: {round(READABLE * width)}px" '
                f'src="data:image/png;base64,{data}"></div><figcaption>{caption}</figcaption></figure>')
    if isinstance(block, Summary):
        return (f'<section class="summary" id="summary"><h2>Summary</h2><p class="answer">{html.escape(block.answer)}'
                f'</p><p class="sureness">{html.escape(block.sureness)}</p></section>')
    if isinstance(block, Heading):
        return f"<h2>{html.escape(block.text)}</h2>"
    if isinstance(block, Glossary):
        items = "".join(f"<dt>{html.escape(t)}</dt><dd>{html.escape(d)}</dd>" for t, d in block.entries)
        return f'<section id="glossary"><h2>Glossary</h2><dl>{items}</dl></section>'
    raise TypeError(f"not a report block: {type(block).__name__}")


def html_report(title: str, command: str, version: str, blocks: list) -> str:
    """The report as one HTML document: the title, the command line, the version and the time at the top,
    then the blocks (Summary, Heading, Table, Note, Figure, Glossary) in order."""
    when = datetime.datetime.now().isoformat(timespec="seconds")
    parts = [f"<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
             f"<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
             f"<title>{html.escape(title)}</title>\n<style>{CSS}</style>\n</head>\n<body>\n<header>\n"
             f"<h1>{html.escape(title)}</h1>\n<p>command: <code id=\"command\">{html.escape(command)}</code></p>\n"
             f"<p>cvtdesign <span id=\"version\">{html.escape(version)}</span>, {when}</p>\n</header>"]
    parts += [_block_html(b) for b in blocks]
    return "\n".join(parts) + "\n</body>\n</html>\n"
