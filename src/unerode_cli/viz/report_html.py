"""A self-contained HTML report: sections of text, tables and PNG figures, the images embedded
as base64 ``data:`` URIs and the style inline, so the page needs no other file and no network
to be read (mailed, archived, opened offline)."""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import BinaryIO

_STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto;
       max-width: 70em; padding: 0 1em; color: #222; line-height: 1.45; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; margin-top: 2em; }
h3 { margin-top: 1.4em; } .subtitle { color: #666; margin-top: 0; }
table { border-collapse: collapse; margin: 0.6em 0 1em; font-size: 0.9em; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f3f3f3; } td.number { text-align: right; font-variant-numeric: tabular-nums; }
figure { display: inline-block; margin: 0.5em 1em 1em 0; vertical-align: top; }
figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { font-size: 0.85em; color: #555; }
nav ul { columns: 2; } caption { text-align: left; font-weight: bold; padding-bottom: 0.3em; }
"""


@dataclass(frozen=True)
class Table:
    """A table: ``rows`` of cells (text or numbers) under ``columns``."""

    columns: Sequence[str]
    rows: Sequence[Sequence[object]]
    caption: str = ""


@dataclass(frozen=True)
class Figure:
    """A PNG image (its bytes) with a caption."""

    png: bytes
    caption: str = ""


Block = str | Table | Figure


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
    for block in section.blocks:
        if isinstance(block, Table):
            parts.append(_table(block))
        elif isinstance(block, Figure):
            data = base64.b64encode(block.png).decode("ascii")
            parts.append(f'<figure><img src="data:image/png;base64,{data}" alt="{_e(block.caption)}">'
                         f"<figcaption>{_e(block.caption)}</figcaption></figure>")
        else:
            parts.append(f"<p>{_e(block)}</p>")
    for j, sub in enumerate(section.subsections, 1):
        parts += _section(sub, min(level + 1, 6), f"{anchor}-{j}")
    parts.append("</section>")
    return parts


def _table(table: Table) -> str:
    head = "".join(f"<th>{_e(c)}</th>" for c in table.columns)
    body = "".join("<tr>" + "".join(_cell(v) for v in row) + "</tr>" for row in table.rows)
    caption = f"<caption>{_e(table.caption)}</caption>" if table.caption else ""
    return f"<table>{caption}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _cell(value: object) -> str:
    if isinstance(value, float):
        return f'<td class="number">{value:.6g}</td>'
    if isinstance(value, int) and not isinstance(value, bool):
        return f'<td class="number">{value}</td>'
    return f"<td>{_e('' if value is None else value)}</td>"


def _e(value: object) -> str:
    return html.escape(str(value), quote=True)
