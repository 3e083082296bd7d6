"""The documentation's promises that do not need a build: the README's length and first lines, a
user-guide page and a gallery entry for every subcommand, and every test the validation page
names. (``make docs`` builds the site, with warnings as errors.)"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import typer
import yaml

from unerode_cli.cli.app import app

ROOT = Path(__file__).resolve().parents[1]


def _subcommands() -> list[str]:
    return sorted(typer.main.get_command(app).commands)


def _nav_pages() -> set[str]:
    """Every page listed in mkdocs.yml's nav."""
    class Loader(yaml.SafeLoader):
        pass

    # mkdocs.yml may hold !!python/name tags (none today): read them as plain strings
    Loader.add_multi_constructor("tag:yaml.org,2002:python/", lambda loader, suffix, node: None)
    nav = yaml.load((ROOT / "mkdocs.yml").read_text(), Loader=Loader)["nav"]
    pages: set[str] = set()

    def walk(item) -> None:
        if isinstance(item, str):
            pages.add(item)
        elif isinstance(item, list):
            for entry in item:
                walk(entry)
        elif isinstance(item, dict):
            for value in item.values():
                walk(value)

    walk(nav)
    return pages


def test_the_readme_is_short_and_opens_with_its_two_commands() -> None:
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= 250
    commands = [line.split("#")[0].strip() for line in lines[:12] if line.startswith("make ")]
    assert commands[:2] == ["make demo", "make test"]


def test_every_subcommand_has_a_user_guide_page_in_the_nav() -> None:
    pages = _nav_pages()
    for name in _subcommands():
        page = f"guide/{name}.md"
        assert page in pages, f"{page} is not in mkdocs.yml's nav"
        text = (ROOT / "docs" / page).read_text()
        command = "pipeline run" if name == "pipeline" else name
        assert f"<!-- options: {command} -->" in text, f"{page} lacks its options table"
    for page in pages:
        assert (ROOT / "docs" / page).exists() or page.startswith("gallery/generated/"), page


def test_every_subcommand_has_a_gallery_entry() -> None:
    entries = yaml.safe_load((ROOT / "docs" / "gallery" / "entries.yaml").read_text())["entries"]
    shown = {entry["command"] for entry in entries}
    assert set(_subcommands()) <= shown
    ids = [entry["id"] for entry in entries]
    assert len(ids) == len(set(ids))
    for entry in entries:
        assert entry["run"] and entry["pictures"], entry["id"]


def test_every_test_named_on_the_validation_page_exists() -> None:
    named = re.findall(r"`(tests/[\w/]+\.py)::(\w+)`", (ROOT / "docs" / "validation.md").read_text())
    assert len(named) >= 40
    for path, name in named:
        tree = ast.parse((ROOT / path).read_text())
        functions = {node.name for node in ast.walk(tree) if isinstance(node, ast.FunctionDef)}
        assert name in functions, f"{path}::{name} does not exist"
