"""Build the gallery: run every entry of ``entries.yaml`` and write its pictures and page.

Each entry shows one subcommand on a real DEM: the command lines that make it (``$DATA`` is the
folder of the real data, ``../shared/data`` beside the checkout), the picture they leave, and the
wall time of the commands on this machine. Entries run in list order in one work folder,
``docs/gallery/generated/work/`` (an entry may read what an earlier one wrote); an entry whose
``needs`` are absent is skipped with a note. An entry whose commands and files are unchanged
since its last run is not run again (``--force`` reruns all).

Outputs (all under ``docs/gallery/generated/``, which git ignores): ``ID.png`` per picture,
``results.json`` (per entry: pictures, seconds, or why it was skipped) and ``index.md``, the
gallery page. Usage: ``python docs/gallery/build_gallery.py [--force] [--only ID ...]``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
OUT = HERE / "generated"
WORK = OUT / "work"
ENTRIES = HERE / "entries.yaml"


def load_entries() -> list[dict]:
    """The gallery's entries, in page order (``entries.yaml``)."""
    return yaml.safe_load(ENTRIES.read_text())["entries"]


def data_dir() -> Path:
    return Path(os.environ.get("DATA", ROOT.parent / "shared" / "data")).resolve()


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env["DATA"] = str(data_dir())
    env["PATH"] = f"{ROOT / '.venv' / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env["GALLERY"] = str(HERE)
    return env


def _missing(entry: dict) -> list[str]:
    """What the entry needs and this machine lacks: files, or ``command: NAME`` on the PATH."""
    missing = []
    for need in entry.get("needs", []):
        if need.startswith("command: "):
            if _browser() is None:
                missing.append(need.removeprefix("command: "))
        elif not (ROOT / need.replace("$DATA", str(data_dir()))).exists():
            missing.append(need)
    return missing


def _browser() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


def _stamp(entry: dict) -> str:
    """What an entry's pictures depend on: its commands, files, needs and pictures (not its text)."""
    made_of = {key: entry.get(key) for key in ("run", "files", "needs", "pictures")}
    return hashlib.sha256(json.dumps(made_of, sort_keys=True).encode()).hexdigest()


def _links() -> None:
    """The work folder sees the checkout's sample DEMs and pipelines under their own names."""
    WORK.mkdir(parents=True, exist_ok=True)
    for name in ("sample_dems", "pipelines"):
        link = WORK / name
        if not link.exists():
            link.symlink_to(ROOT / name)


def run_entry(entry: dict, env: dict[str, str]) -> dict:
    """Run one entry's commands in the work folder; its pictures copied to ``OUT/ID[_k].png``."""
    for name, text in entry.get("files", {}).items():
        (WORK / name).parent.mkdir(parents=True, exist_ok=True)
        (WORK / name).write_text(text)
    start = time.perf_counter()
    for line in entry["run"]:
        done = subprocess.run(["bash", "-c", "set -euo pipefail; " + line], cwd=WORK, env=env,
                              capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"gallery entry {entry['id']}: `{line}` exited {done.returncode}:\n"
                               f"{done.stdout[-2000:]}{done.stderr[-2000:]}")
    seconds = time.perf_counter() - start
    pictures = []
    for k, picture in enumerate(entry["pictures"]):
        name = f"{entry['id']}.png" if k == 0 else f"{entry['id']}_{k}.png"
        shutil.copyfile(WORK / picture, OUT / name)
        pictures.append(name)
    return {"pictures": pictures, "seconds": round(seconds, 1), "cores": os.cpu_count()}


def build(force: bool = False, only: list[str] | None = None) -> dict:
    """Run the entries that changed (all with ``force``); return the results by entry id."""
    OUT.mkdir(parents=True, exist_ok=True)
    _links()
    results_path = OUT / "results.json"
    results = json.loads(results_path.read_text()) if results_path.exists() else {}
    env = _environment()
    for entry in load_entries():
        eid = entry["id"]
        if only and eid not in only:
            continue
        missing = _missing(entry)
        if missing:
            results[eid] = {"skipped": "absent: " + ", ".join(missing)}
            print(f"gallery: {eid} skipped ({results[eid]['skipped']})")
            continue
        stamp = _stamp(entry)
        previous = results.get(eid, {})
        pictures_there = all((OUT / p).exists() for p in previous.get("pictures", [None]) if p)
        if not force and previous.get("stamp") == stamp and pictures_there:
            continue
        print(f"gallery: {eid} …", flush=True)
        results[eid] = {**run_entry(entry, env), "stamp": stamp}
        print(f"gallery: {eid} {results[eid]['seconds']} s", flush=True)
        results_path.write_text(json.dumps(results, indent=1) + "\n")
    results_path.write_text(json.dumps(results, indent=1) + "\n")
    (OUT / "index.md").write_text(page(load_entries(), results))
    return results


def entry_markdown(entry: dict, result: dict, prefix: str = "", heading: str = "###") -> str:
    """One entry as Markdown: title, pictures, the commands and their time (or the skip note).

    ``prefix`` is the path from the page that shows it to ``docs/gallery/generated/``."""
    lines = [f"{heading} {entry['title']}" if heading else "", ""]
    if "skipped" in result or not result:
        why = result.get("skipped", "not built yet: run `make gallery`")
        lines += [f"*Not built on this machine ({why}).*", ""]
    else:
        width = "49%" if len(result["pictures"]) > 1 else "70%"
        lines += [" ".join(f"![{entry['title']}]({prefix}{name}){{ width=\"{width}\" }}"
                           for name in result["pictures"]), ""]
    if entry.get("caption"):
        lines += [" ".join(entry["caption"].split()), ""]
    for name, text in entry.get("files", {}).items():
        lines += [f"`{name}`:", "", "```yaml", text.rstrip(), "```", ""]
    lines += ["```sh", *entry["run"], "```", ""]
    if result.get("seconds") is not None:
        lines += [f"Wall time of these commands: {result['seconds']} s on {result['cores']} cores "
                  "(when the gallery was built, start-up and loading of the compiled kernels included).", ""]
    return "\n".join(lines)


def page(entries: list[dict], results: dict) -> str:
    """The gallery page: entries grouped by subcommand, in list order."""
    head = ["# Gallery", "",
            "Every subcommand on real DEMs, each picture with the commands that made it. The page and "
            "its pictures are built by `make gallery` (`docs/gallery/build_gallery.py` from "
            "`docs/gallery/entries.yaml`), which `make docs` runs: they cannot go stale. Commands run "
            "in one work folder, in this order; `$DATA` is `../shared/data` (the real DEMs and "
            "chronologies beside the checkout; `make gallery DATA=...` for another folder).", ""]
    body = [entry_markdown(e, results.get(e["id"], {}), heading=f"## `{e['command']}`:") for e in entries]
    return "\n".join(head) + "\n" + "\n".join(body)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--force", action="store_true", help="rerun every entry")
    parser.add_argument("--only", nargs="*", help="run only these entry ids")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    try:
        build(force=args.force, only=args.only)
    except RuntimeError as error:
        print(error, file=sys.stderr)
        return 1
    print(f"gallery: done in {time.perf_counter() - start:.0f} s → {OUT.relative_to(ROOT)}/index.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
