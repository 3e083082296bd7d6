"""The memory this process may still take, as the operating system reports it: the kernel's
``MemAvailable`` (``/proc/meminfo``: free memory plus what the page cache can give back), or
``os.sysconf``'s free pages where there is no ``/proc/meminfo``; inside a cgroup (v2) with a
memory limit, no more than the limit minus its current use."""

from __future__ import annotations

import os
from pathlib import Path

_MEMINFO = Path("/proc/meminfo")
_CGROUP = Path("/sys/fs/cgroup")


def memory_available() -> float:
    """Bytes available now (see the module docstring); infinity where nothing can say."""
    free = _meminfo_available()
    if free is None:
        free = _sysconf_available()
    limit = _cgroup_room()
    return float(free if limit is None else min(free, limit))


def _meminfo_available() -> float | None:
    try:
        text = _MEMINFO.read_text()
    except OSError:
        return None
    for line in text.splitlines():
        if line.startswith("MemAvailable:"):
            fields = line.split()
            try:
                return float(fields[1]) * (1024.0 if fields[2:3] == ["kB"] else 1.0)
            except (IndexError, ValueError):
                return None
    return None


def _sysconf_available() -> float:
    """Free physical memory from ``os.sysconf``; infinity where it cannot say."""
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES")) * float(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return float("inf")


def _cgroup_room() -> float | None:
    """The cgroup v2 memory limit of this process minus its current use; None without a limit."""
    try:
        limit = (_CGROUP / "memory.max").read_text().strip()
        if limit == "max":
            return None
        current = (_CGROUP / "memory.current").read_text().strip()
        return max(float(limit) - float(current), 0.0)
    except (OSError, ValueError):
        return None


def resident_bytes() -> float:
    """Bytes this process holds in memory now (its resident set; 0 where /proc is missing)."""
    try:
        with open("/proc/self/statm") as statm:
            return float(int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE"))
    except (OSError, ValueError, IndexError):
        return 0.0
