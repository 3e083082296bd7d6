"""Peak memory of whole commands on big DEMs: ``python bench/memory.py [--size 8192] [--big 16384]
[--only NAME ...] [--data DIR]``.

Each case runs the installed ``unerode-cli`` as a child process; its peak resident memory is
the kernel's ``ru_maxrss`` of that child (``os.wait4``), its time the wall clock. The inputs
are a synthetic mountain range of ``--size``² cells at 30 m (``unerode-cli synth``) and, for
the end-to-end case, a ``--big``² GeoTIFF tiled from it by mirroring (written in strips, never
whole in memory). Inputs are kept in ``--data`` (default ``bench/.data``, not versioned).
Writes bench/memory.json and bench/memory.md (bytes per cell = peak RSS ÷ cells).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import rasterio
from rasterio.windows import Window

HERE = Path(__file__).resolve().parent
CLI = str(Path(sys.executable).with_name("unerode-cli"))


#: The memory cap (GiB, ``UNERODE_MEMORY_GIB``) under which the implicit step takes its lean
#: layout at 8192²: above erode's estimate (0.3 GiB + 67 M cells × its bytes per cell), below
#: what the ordered layout needs when it is chosen (about 2 GiB held by then, 4 GiB more).
LEAN_CAP_GIB = "5.5"


def cases(size: int, big: int) -> dict[str, tuple[str, list[str]]]:
    """name → (input, the command's arguments: IN, OUT stand for the input and the output;
    a leading ``UNERODE_MEMORY_GIB=...`` is set in the child's environment)."""
    return {
        f"flow mfd {size}²": (f"m{size}.tif", ["flow", "IN", "OUT"]),
        f"flow d8 {size}²": (f"m{size}.tif", ["flow", "IN", "OUT", "--method", "d8"]),
        f"erode default (mfd, auto) 1 step {size}²": (f"m{size}.tif", ["erode", "IN", "OUT", "--steps", "1"]),
        f"erode default, lean layout (cap {LEAN_CAP_GIB} GiB) 1 step {size}²": (
            f"m{size}.tif", [f"UNERODE_MEMORY_GIB={LEAN_CAP_GIB}", "erode", "IN", "OUT", "--steps", "1"]),
        f"erode implicit d8 1 step {size}²": (f"m{size}.tif", ["erode", "IN", "OUT", "--steps", "1",
                                                               "--scheme", "implicit", "--method", "d8"]),
        f"erode explicit 1 step of 10 y {size}²": (f"m{size}.tif", ["erode", "IN", "OUT", "--steps", "1",
                                                                     "--dt", "10", "--scheme", "explicit"]),
        f"unerode 1 step {size}²": (f"m{size}.tif", ["unerode", "IN", "OUT", "--steps", "1", "--dt", "10"]),
        f"read + flow + write {big}²": (f"m{big}.tif", ["flow", "IN", "OUT"]),
        f"erode default 1 step {big}²": (f"m{big}.tif", ["erode", "IN", "OUT", "--steps", "1"]),
    }


def synth(path: Path, size: int) -> None:
    subprocess.run([CLI, "synth", str(path), "--size", str(size), "--kind", "mountain"], check=True,
                   stdout=subprocess.DEVNULL)


def mirrored(source: Path, path: Path, times: int) -> None:
    """``path``: ``source`` tiled ``times`` × ``times``, every other copy mirrored so that the
    seams are continuous; written in strips of the source's rows."""
    with rasterio.open(source) as src:
        profile = src.profile | {"height": src.height * times, "width": src.width * times, "BIGTIFF": "YES"}
        with rasterio.open(path, "w", **profile) as dst:
            step = 512
            for first in range(0, src.height, step):
                rows = min(step, src.height - first)
                block = src.read(1, window=Window(0, first, src.width, rows))
                flipped = block[:, ::-1]
                line = np.concatenate([flipped if k % 2 else block for k in range(times)], axis=1)
                for k in range(times):
                    top = k * src.height + (src.height - first - rows if k % 2 else first)
                    dst.write(line[::-1] if k % 2 else line, 1, window=Window(0, top, line.shape[1], rows))


def measure(args: list[str]) -> tuple[float, float, int]:
    """(wall s, peak RSS bytes, exit code) of one child process."""
    env = dict(os.environ)
    while args and re.fullmatch(r"[A-Z_]+=.*", args[0]):
        key, value = args[0].split("=", 1)
        env[key] = value
        args = args[1:]
    start = time.perf_counter()
    child = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    return wall, usage.ru_maxrss * 1024.0, os.waitstatus_to_exitcode(status)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--size", type=int, default=8192)
    parser.add_argument("--big", type=int, default=16384)
    parser.add_argument("--only", action="append", default=[],
                        help="run the cases whose name contains this")
    parser.add_argument("--data", type=Path, default=HERE / ".data")
    args = parser.parse_args()
    args.data.mkdir(parents=True, exist_ok=True)
    out = args.data / "out"
    results = {}
    json_path = HERE / "memory.json"
    if json_path.exists():
        results = json.loads(json_path.read_text()).get("cases", {})
    for name, (source, argv) in cases(args.size, args.big).items():
        if args.only and not any(k in name for k in args.only):
            continue
        path = args.data / source
        size = int(source[1:-4])
        if not path.exists():
            if size == args.big and (args.data / f"m{args.size}.tif").exists() and args.big % args.size == 0:
                mirrored(args.data / f"m{args.size}.tif", path, args.big // args.size)
            else:
                synth(path, size)
        shutil.rmtree(out, ignore_errors=True)
        out.mkdir()
        named = {"IN": str(path), "OUT": str(out / "out.tif")}
        settings = [a for a in argv if re.fullmatch(r"[A-Z_]+=.*", a)]
        command = [*settings, CLI, *(named.get(a, a) for a in argv if a not in settings)]
        wall, peak, code = measure(command)
        cells = size * size
        shown = [("unerode-cli" if a == CLI else a) for a in command]
        results[name] = {"command": " ".join(shown), "cells": cells,
                         "wall_s": round(wall, 1), "peak_rss_gib": round(peak / 2**30, 3),
                         "bytes_per_cell": round(peak / cells, 1), "exit_code": code}
        print(f"{name:45s} {wall:8.1f} s {peak / 2**30:7.2f} GiB {peak / cells:6.1f} B/cell (exit {code})",
              flush=True)
        write_reports(results)
    shutil.rmtree(out, ignore_errors=True)


def write_reports(results: dict[str, dict]) -> None:
    """bench/memory.json and bench/memory.md, after every case (a long session keeps what it has)."""
    machine = {"cpus": os.cpu_count(), "python": platform.python_version(), "date": time.strftime("%Y-%m-%d")}
    (HERE / "memory.json").write_text(json.dumps({"machine": machine, "cases": results}, indent=2) + "\n")
    lines = ["| case | cells | wall (s) | peak RSS (GiB) | bytes/cell | exit |",
             "|---|---:|---:|---:|---:|---:|"]
    lines += [f"| {k} | {v['cells']:,} | {v['wall_s']} | {v['peak_rss_gib']} | {v['bytes_per_cell']} "
              f"| {v['exit_code']} |" for k, v in results.items()]
    title = (f"Peak memory of whole commands ({machine['cpus']} CPUs, {machine['date']}; "
             "`python bench/memory.py`)")
    (HERE / "memory.md").write_text(title + "\n\n" + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
