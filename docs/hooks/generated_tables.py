"""MkDocs hook: tables generated at build time from the code and from bench/results.json.

A page asks for a table with an HTML comment on a line of its own:

- ``<!-- options: SUBCOMMAND -->`` (``pipeline run`` for the pipeline runner): every option of
  the subcommand, grouped by the panels of its ``--help``, with its flags, default and help text,
  read from the command-line application itself (so the page is the ``--help`` of the code it
  is built with);
- ``<!-- gallery: ID -->``: the gallery entry ID (``docs/gallery/entries.yaml``) with its
  picture, commands and time as ``make gallery`` last built it, or a note where it was skipped;
- ``<!-- bench-results -->``: the machine and the table of ``make bench`` (``bench/results.json``
  and ``bench/results.md``, as the last ``make bench`` left them; nothing is rerun).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MARKER = re.compile(r"^<!-- (options: (?P<command>[a-z -]+?)|gallery: (?P<entry>[a-z-]+)|bench-results) -->$",
                    re.M)


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 (MkDocs' signature)
    def table(match: re.Match) -> str:
        if match.group("command"):
            return options_markdown(match.group("command").strip())
        if match.group("entry"):
            depth = page.file.src_uri.count("/")
            return gallery_markdown(match.group("entry"), "../" * depth + "gallery/generated/")
        return bench_markdown()

    return MARKER.sub(table, markdown)


def _command(name: str):
    import typer

    from unerode_cli.cli.app import app

    command = typer.main.get_command(app)
    for part in name.split():
        command = command.commands[part]
    return command


def _cell(text: str) -> str:
    text = " ".join(str(text).split())
    text = text.replace("|", "\\|").replace("<", "&lt;").replace(">", "&gt;").replace("*", "\\*")
    return re.sub(r"``([^`]+)``", r"`\1`", text)


def _default(param) -> str:
    if param.param_type_name == "argument":
        return "required" if param.required else ""
    if getattr(param, "is_flag", False) and not param.secondary_opts:
        return "off" if not param.default else "on"
    if getattr(param, "is_flag", False):
        return param.opts[0] if param.default else param.secondary_opts[0]
    if param.required:
        return "required"
    if param.default is None or param.default == () or param.default == [] or param.count:
        return ""
    default = getattr(param.default, "value", param.default)  # a choice's enum member
    return f"`{default}`"


def options_markdown(name: str) -> str:
    """Markdown tables of a subcommand's parameters, one per ``--help`` panel, in its order."""
    command = _command(name)
    panels: dict[str, list[str]] = {}
    for param in command.params:
        if param.param_type_name == "argument":
            panel = "Arguments"
            flags = f"`{(param.metavar or param.name).upper()}`"
        else:
            panel = getattr(param, "rich_help_panel", None) or "Options"
            flags = ", ".join(f"`{flag}`" for flag in [*param.opts, *param.secondary_opts])
        help_text = getattr(param, "help", None) or ""
        panels.setdefault(panel, []).append(f"| {flags} | {_cell(_default(param))} | {_cell(help_text)} |")
    panels.setdefault("Options", []).append("| `--help`, `-h` | | Show the help and exit. |")
    out = []
    for panel, rows in panels.items():
        out += [f"**{panel}**", "", "| option | default | meaning |", "|---|---|---|", *rows, ""]
    return "\n".join(out)


def bench_markdown() -> str:
    """The machine of the last ``make bench`` and its results table."""
    data = json.loads((ROOT / "bench" / "results.json").read_text())
    machine = data.get("machine", {})
    head = (f"Machine of the last run: {machine.get('node_cpus', '?')} CPU cores, "
            f"{machine.get('machine', '?')}, Python {machine.get('python', '?')}.")
    return head + "\n\n" + (ROOT / "bench" / "results.md").read_text()


def gallery_markdown(entry_id: str, prefix: str) -> str:
    """One gallery entry, as the gallery page shows it, for a page ``prefix`` away from it."""
    import sys

    sys.path.insert(0, str(ROOT / "docs" / "gallery"))
    import build_gallery

    entries = {e["id"]: e for e in build_gallery.load_entries()}
    results_path = build_gallery.OUT / "results.json"
    results = json.loads(results_path.read_text()) if results_path.exists() else {}
    return build_gallery.entry_markdown(entries[entry_id], results.get(entry_id, {}), prefix, heading="")
