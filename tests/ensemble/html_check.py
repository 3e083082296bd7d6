"""Validation of a self-contained report page: well-formed HTML (every element closed in order),
no reference outside the page (links to files of the run folder beside it only where the
caller names that folder, and then to files that exist), and embedded PNG images that decode."""

from __future__ import annotations

import base64
import io
import urllib.parse
from html.parser import HTMLParser
from pathlib import Path

import matplotlib.image

#: Elements without a closing tag.
VOID = {"meta", "img", "br", "wbr", "hr", "link", "input"}


class _Page(HTMLParser):
    def __init__(self, folder: Path | None = None) -> None:
        super().__init__()
        self.folder = folder
        self.links: list[Path] = []
        self.open: list[str] = []
        self.problems: list[str] = []
        self.images: list[bytes] = []
        self.headings: list[str] = []
        self.tables: list[list[list[str]]] = []
        self._text: list[str] | None = None
        self._cell: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        values = dict(attrs)
        for name in ("src", "href"):
            link = values.get(name) or ""
            if link and not link.startswith(("data:image/png;base64,", "#")) \
                    and not (tag == "a" and name == "href" and self._beside(link)):
                self.problems.append(f"<{tag} {name}={link[:40]}> points outside the page")
        if tag == "img":
            self.images.append(base64.b64decode(values["src"].split(",", 1)[1], validate=True))
        if tag in ("link", "script", "iframe"):
            self.problems.append(f"<{tag}> in a self-contained page")
        if tag in ("h1", "h2", "h3", "h4"):
            self._text = []
        if tag == "table":
            self.tables.append([])
        if tag == "tr":
            self.tables[-1].append([])
        if tag in ("td", "th"):
            self._cell = []
        if tag not in VOID:
            self.open.append(tag)

    def _beside(self, link: str) -> bool:
        """A relative link to a file that exists in the folder named by the caller."""
        if self.folder is None or ":" in link or link.startswith("/"):
            return False
        target = (self.folder / urllib.parse.unquote(link)).resolve()
        if target.is_file() and target.is_relative_to(self.folder.resolve()):
            self.links.append(target)
            return True
        return False

    def handle_endtag(self, tag: str) -> None:
        if not self.open or self.open[-1] != tag:
            self.problems.append(f"</{tag}> closes <{self.open[-1] if self.open else 'nothing'}>")
            return
        self.open.pop()
        if tag in ("h1", "h2", "h3", "h4") and self._text is not None:
            self.headings.append("".join(self._text).strip())
            self._text = None
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1][-1].append("".join(self._cell).strip())
            self._cell = None

    def handle_data(self, data: str) -> None:
        for sink in (self._text, self._cell):
            if sink is not None:
                sink.append(data)


def check_page(text: str, folder: Path | None = None) -> _Page:
    """Parse ``text``; assert it is well formed and self-contained and its images decode. With
    ``folder`` (where the page lies), links to existing files under it are allowed."""
    assert text.startswith("<!DOCTYPE html>")
    page = _Page(folder)
    page.feed(text)
    page.close()
    assert page.problems == []
    assert page.open == []
    for png in page.images:
        image = matplotlib.image.imread(io.BytesIO(png), format="png")
        assert image.ndim == 3 and image.shape[0] > 100 and image.shape[1] > 100
    return page
