"""How long a command keeps running, and how much CPU it burns, after its last output is written.

    .venv/bin/python bench/bench_exit_after_write.py OUTDIR -- unerode-cli glaciate ... OUTDIR/out.tif ...

Runs the command (a fresh process), polls every 0.05 s the modification times of the files under
OUTDIR and the CPU time of the process and of every process it started (/proc: user + system of
all their threads), and prints: the wall time to the last file written, from it to the
process's exit, the CPU seconds the process tree spent in that interval, and the threads still
alive at the last poll before the exit.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """user + system CPU seconds of process ``pid`` (all its threads)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK


def tree(pid: int) -> list[int]:
    """``pid`` and every process descended from it."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError):
                continue
            children.setdefault(ppid, []).append(int(entry.name))
    found, todo = [], [pid]
    while todo:
        found.append(todo.pop())
        todo.extend(children.get(found[-1], []))
    return found


def tree_cpu_seconds(pids: list[int]) -> float:
    total = 0.0
    for pid in pids:
        try:
            total += cpu_seconds(pid)
        except (OSError, IndexError):
            pass
    return total


def threads(pid: int) -> list[str]:
    """The names and CPU seconds of the threads of ``pid``."""
    out = []
    for task in sorted(Path(f"/proc/{pid}/task").iterdir()):
        try:
            name = (task / "comm").read_text().strip()
            fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
            out.append(f"{name}[{task.name}] {(int(fields[11]) + int(fields[12])) / TICK:.2f}s")
        except OSError:
            continue
    return out


def newest(folder: Path) -> float:
    times = [p.stat().st_mtime for p in folder.rglob("*") if p.is_file()]
    return max(times, default=0.0)


def main() -> None:
    folder = Path(sys.argv[1])
    command = sys.argv[sys.argv.index("--") + 1:]
    folder.mkdir(parents=True, exist_ok=True)
    start = time.time()
    proc = subprocess.Popen(command)
    samples: list[tuple[float, float]] = []         # (wall time, CPU s of the process tree)
    alive: list[str] = []
    seen: set[int] = set()                          # every process of the tree, exited ones too
    spent: dict[int, float] = {}
    while proc.poll() is None:
        try:
            pids = tree(proc.pid)
            seen.update(pids)
            for pid in pids:
                spent[pid] = max(spent.get(pid, 0.0), tree_cpu_seconds([pid]))
            samples.append((time.time(), sum(spent.values())))
            alive = [t for pid in pids for t in threads(pid)]
        except (OSError, IndexError):
            pass
        time.sleep(0.05)
    end = time.time()
    last_file = newest(folder)
    after = [cpu for t, cpu in samples if t >= last_file]
    before = [cpu for t, cpu in samples if t < last_file]
    used = (after[-1] - before[-1]) if after and before else 0.0
    print(f"exit code {proc.returncode}; run {end - start:.2f} s; last file written at "
          f"{last_file - start:.2f} s; exit {end - last_file:.2f} s after it, "
          f"{used:.2f} CPU s spent after it by {len(seen)} process(es) (last sample)")
    print("threads at the last poll: " + ", ".join(alive))


if __name__ == "__main__":
    main()
