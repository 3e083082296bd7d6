"""A self-contained HTML report: sections of text, tables and PNG figures, the images embedded
as base64 ``data:`` URIs and the style inline, so the page needs no other file and no network
to be read (mailed, archived, opened offline); links (:class:`Link`) point to files of the run
beside the page, for the reader who has the folder.

The layout follows the window: consecutive figures share a grid of columns at least 32 em wide
(two side by side on a 1400 px window, one on a phone), and each table sits in a box that
scrolls sideways rather than widening the page; text in cells wraps between words and after
each ``/`` or ``_`` (paths, long names), numbers never."""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import BinaryIO

_STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto;
       max-width: 84em; padding: 0 1.2em; color: #222; line-height: 1.45; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; overflow-wrap: anywhere; }
h2 { border-bottom: 1px solid #ccc; margin-top: 2em; } h2, h3, h4 { overflow-wrap: anywhere; }
h3 { margin-top: 1.4em; } .subtitle { color: #666; margin-top: 0; overflow-wrap: anywhere; }
p { max-width: 60em; }
.table-wrap { max-width: 100%; overflow-x: auto; margin: 0.6em 0 1em; }
table { border-collapse: collapse; font-size: 0.9em; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: left; vertical-align: top;
         overflow-wrap: break-word; }
th { background: #f3f3f3; } td.number { text-align: right; font-variant-numeric: tabular-nums;
                                        white-space: nowrap; overflow-wrap: normal; }
.figures { display: grid; gap: 0.8em 1.2em; margin: 0.6em 0 1em;
           grid-template-columns: repeat(auto-fill, minmax(min(100%, 32em), 1fr)); }
figure { margin: 0; min-width: 0; } figure.wide { grid-column: 1 / -1; }
figure img { max-width: 100%; height: auto; border: 1px solid #eee; display: block; }
figcaption { font-size: 0.85em; color: #555; overflow-wrap: anywhere; }
nav ul { columns: 2; } caption { text-align: left; font-weight: bold; padding-bottom: 0.3em; }
a { color: #1f5fa8; }
@media (max-width: 48em) { nav ul { columns: 1; } body { padding: 0 0.6em; } }
"""

@dataclass(frozen=True)
class Table:
    """A table: ``rows`` of cells (text or numbers) under ``columns``."""

    columns: Sequence[str]
    rows: Sequence[Sequence[object]]
    caption: str = ""


@dataclass(frozen=True)
class Figure:
    """A PNG image (its bytes) with a caption; ``wide`` takes the page's whole width instead
    of a column of the figure grid."""

    png: bytes
    caption: str = ""
    wide: bool = False


@dataclass(frozen=True)
class Link:
    """A table cell or paragraph that links to a file beside the page: ``href`` a relative
    URL (from the page's folder), ``text`` what the reader sees."""

    text: str
    href: str


Block = str | Table | Figure | Link


@dataclass
class Section:
    """A titled part of the report: paragraphs (str), tables and figures in order, and
    subsections."""

    title: str
    blocks: list[Block] = field(default_factory=list)
    subsections: list[Section] = field(default_factory=list)


def png_bytes(draw: Callable[[BinaryIO], None]) -> bytes:
    """The PNG that ``draw(file)`` writes into a file object (a viz ``save_*`` function)."""
    buffer = io.BytesIO()
    draw(buffer)
    return buffer.getvalue()


def render(title: str, subtitle: str, sections: Sequence[Section]) -> str:
    """The whole HTML page (UTF-8 text) with a table of contents."""
    parts = ["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
             '<meta name="viewport" content="width=device-width, initial-scale=1">',
             f"<title>{_e(title)}</title>", f"<style>{_STYLE}</style>", "</head>", "<body>",
             f"<h1>{_e(title)}</h1>", f'<p class="subtitle">{_e(subtitle)}</p>']
    if len(sections) > 1:
        parts.append("<nav><ul>")
        parts += [f'<li><a href="#s{i}">{_e(s.title)}</a></li>' for i, s in enumerate(sections, 1)]
        parts.append("</ul></nav>")
    for i, section in enumerate(sections, 1):
        parts += _section(section, 2, f"s{i}")
    parts += ["</body>", "</html>", ""]
    return "\n".join(parts)


def _section(section: Section, level: int, anchor: str) -> list[str]:
    parts = [f'<section id="{anchor}">', f"<h{level}>{_e(section.title)}</h{level}>"]
    figures: list[str] = []
    for block in section.blocks:
        if isinstance(block, Figure):
            data = base64.b64encode(block.png).decode("ascii")
            wide = ' class="wide"' if block.wide else ""
            figures.append(f'<figure{wide}><img src="data:image/png;base64,{data}" alt="{_e(block.caption)}">'
                           f"<figcaption>{_e(block.caption)}</figcaption></figure>")
            continue
        parts += _figure_grid(figures)
        figures = []
        if isinstance(block, Table):
            parts.append(_table(block))
        elif isinstance(block, Link):
            parts.append(f"<p>{_link(block)}</p>")
        else:
            parts.append(f"<p>{_e(block)}</p>")
    parts += _figure_grid(figures)
    for j, sub in enumerate(section.subsections, 1):
        parts += _section(sub, min(level + 1, 6), f"{anchor}-{j}")
    parts.append("</section>")
    return parts


def _figure_grid(figures: list[str]) -> list[str]:
    return ['<div class="figures">', *figures, "</div>"] if figures else []


def _table(table: Table) -> str:
    head = "".join(f"<th>{_breakable(_e(c))}</th>" for c in table.columns)
    body = "".join("<tr>" + "".join(_cell(v) for v in row) + "</tr>" for row in table.rows)
    caption = f"<caption>{_e(table.caption)}</caption>" if table.caption else ""
    return (f'<div class="table-wrap"><table>{caption}<thead><tr>{head}</tr></thead>'
            f"<tbody>{body}</tbody></table></div>")


def _cell(value: object) -> str:
    if isinstance(value, Link):
        return f"<td>{_link(value)}</td>"
    if isinstance(value, float):
        return f'<td class="number">{value:.6g}</td>'
    if isinstance(value, int) and not isinstance(value, bool):
        return f'<td class="number">{value}</td>'
    return f"<td>{_breakable(_e('' if value is None else value))}</td>"


def _breakable(text: str) -> str:
    """Escaped ``text`` with a line-break opportunity (``<wbr>``) after each ``/`` and ``_``: a
    long path wraps at its folders and a long name (``incision_rmse_mm_per_ka``,
    ``bintanja_vandewal2008_3Myr.csv``) at its parts, so that a column need only be as wide as
    the longest part."""
    return text.replace("/", "/<wbr>").replace("_", "_<wbr>")


def _link(link: Link) -> str:
    return f'<a href="{_e(link.href)}">{_e(link.text)}</a>'


def _e(value: object) -> str:
    return html.escape(str(value), quote=True)
