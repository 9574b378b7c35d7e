"""Where numba keeps the compiled kernels: one directory per version of the package's source.

numba's cache (``cache=True``) is keyed by the file that *defines* each function (numba 0.68
hashes that file's bytes). A compiled kernel carries the machine code of every function it
calls, so when only a callee's module changes (``arm/braking.py``) the caller's cache entry
(``step_kernel.arm_step``) still matches its own unchanged file and loads the *old* braking:
the robot would run code that is no longer the source, silently. Found on 2026-12-07: a
measurement at f6ff93c with a cache kept from 44d422f reproduced 44d422f's 1,218 runs exactly.
Upgrading an installed package does the same (pip leaves the cache files it did not install).

So the cache lives in a directory named after a hash of every module of the package
(``cobotsafety-<16 hex>``): any change anywhere compiles afresh, and an unchanged tree loads as
before. The directory is inside ``NUMBA_CACHE_DIR`` when that is set, else in the package's
``__pycache__`` (else, when that is not writable, the user's cache directory, else the system's
temporary one). ``configure`` sets ``NUMBA_CACHE_DIR`` itself, for this process's numba and for
the processes it starts (campaign workers), so it runs before any kernel is defined: first thing
in ``cobotsafety/__init__.py``. Older versions' directories are removed, but the few most
recently used and any used within ``KEEP_RECENT_S`` (a process still running an older tree).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

PREFIX = "cobotsafety-"
#: Older versions' cache directories kept beside the current one (switching branches back).
KEEP_VERSIONS = 3
#: An older version's directory used within this long is kept: a process started on it (a demo, a
#: campaign of an hour) may still compile into it, and numba fails when its directory is gone.
KEEP_RECENT_S = 6 * 3600.0


def source_key(package_dir: Path) -> str:
    """A hash of every ``.py`` file under ``package_dir`` (their paths and bytes), 16 hex digits."""
    digest = hashlib.sha256()
    for path in sorted(package_dir.rglob("*.py")):
        digest.update(path.relative_to(package_dir).as_posix().encode())
        digest.update(b"\0")
        digest.update(path.read_bytes())
        digest.update(b"\0")
    return digest.hexdigest()[:16]


def _writable(directory: Path) -> bool:
    try:
        directory.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=directory).close()
    except OSError:
        return False
    return True


def _bases(package_dir: Path) -> list[Path]:
    """The directories the versions' directories may live in, in order of preference."""
    given = os.environ.get("NUMBA_CACHE_DIR", "").rstrip("/\\")
    # (a process started by one that configured already, a campaign worker: the parent's base)
    chosen = [Path(given).parent if Path(given).name.startswith(PREFIX) else Path(given)] if given else []
    user = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "cobotsafety" / "numba"
    uid = os.getuid() if hasattr(os, "getuid") else 0
    return chosen + [package_dir / "__pycache__" / "numba", user,
                     Path(tempfile.gettempdir()) / f"cobotsafety-numba-{uid}"]


def _prune(base: Path, keep: Path) -> None:
    """Remove older versions' directories in ``base`` but the ``KEEP_VERSIONS`` most recently
    used and any used within ``KEEP_RECENT_S``."""
    try:
        older = sorted((d for d in base.iterdir() if d.is_dir() and d.name.startswith(PREFIX) and d != keep),
                       key=lambda d: d.stat().st_mtime, reverse=True)
    except OSError:
        return
    now = time.time()
    for directory in older[KEEP_VERSIONS:]:
        try:
            if now - directory.stat().st_mtime > KEEP_RECENT_S:
                shutil.rmtree(directory, ignore_errors=True)
        except OSError:
            pass


def configure(package_dir: Path | None = None) -> Path | None:
    """Point numba's cache at this source version's directory (created) and return it; ``None``
    (numba's own choice left, with a warning) when no candidate directory is writable."""
    package_dir = Path(__file__).resolve().parent if package_dir is None else package_dir
    key = PREFIX + source_key(package_dir)
    for base in _bases(package_dir):
        directory = base / key
        if _writable(directory):
            break
    else:
        warnings.warn(f"cobotsafety: no writable directory for numba's cache in {_bases(package_dir)}; "
                      "a kernel whose callee changed may load its old code", stacklevel=2)
        return None
    os.utime(directory)  # (most recently used: kept by the next prune)
    os.environ["NUMBA_CACHE_DIR"] = str(directory)
    if "numba" in sys.modules:  # imported before us: its configuration follows the environment
        from numba.core import config
        config.reload_config()
    _prune(base, directory)
    return directory
