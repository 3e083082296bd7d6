"""Keep numba's on-disk kernel cache in step with the sources.

Numba keys a cached kernel on the time stamp of the file that defines it, not on the kernels
it calls from other modules, so editing a called kernel (or a ``git pull`` that changes it)
can leave a stale, even crashing, cached caller. The fingerprint of every source file of the
package (path, size, modification time) is kept beside the cache; when it changes, the cache
files are deleted and the kernels compile afresh. A package that cannot be written (a system
install) is left alone: numba then caches elsewhere, and a reinstall renews every time stamp.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent
STAMP = PACKAGE / "__pycache__" / "kernel-sources.stamp"
CACHE_PATTERNS = ("*.nbi", "*.nbc")


def sources_fingerprint(package: Path = PACKAGE) -> str:
    """Hex digest of (relative path, size, mtime in ns) of every ``.py`` file in ``package``."""
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        stat = path.stat()
        digest.update(f"{path.relative_to(package)}\0{stat.st_size}\0{stat.st_mtime_ns}\n".encode())
    return digest.hexdigest()


def refresh(package: Path = PACKAGE, stamp: Path = STAMP) -> bool:
    """Delete the package's numba cache files when its sources changed since the last call;
    returns whether it did. Where the stamp cannot be written (a read-only install) nothing
    is deleted; an error while deleting (a race with another process) leaves the old stamp,
    so the next call tries again."""
    fingerprint = sources_fingerprint(package)
    try:
        if stamp.read_text() == fingerprint:
            return False
    except OSError:
        pass
    try:
        stamp.parent.mkdir(exist_ok=True)
        if not os.access(stamp.parent, os.W_OK):
            return False
        for pattern in CACHE_PATTERNS:
            for path in package.rglob(pattern):
                path.unlink(missing_ok=True)
        stamp.write_text(fingerprint)
    except OSError:
        return False
    return True
