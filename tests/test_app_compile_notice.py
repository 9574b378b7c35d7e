"""The first start says that numba compiles (issue 22, a newcomer's path); a cached start is silent."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

KERNEL = '''
import numba

@numba.njit(cache=True)
def twice(x):
    return 2.0 * x
'''
SCRIPT = '''
import sys
sys.path.insert(0, sys.argv[1])
from cobotsafety.app.compile_notice import announce_compilation
with announce_compilation("cobotsafety demo"):
    import kernel
    assert kernel.twice(2.0) == 4.0
print("done")
'''


def run(tmp_path: Path) -> list[str]:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
           "PYTHONPATH": os.pathsep.join([str(Path(__file__).resolve().parents[1]), os.environ.get("PYTHONPATH", "")])}
    result = subprocess.run([sys.executable, "-c", SCRIPT, str(tmp_path)], env=env, capture_output=True, text=True,
                            timeout=120, check=True)
    return result.stdout.splitlines()


def test_a_first_start_announces_the_compilation_and_a_cached_start_does_not(tmp_path):
    (tmp_path / "kernel.py").write_text(KERNEL)
    first = run(tmp_path)
    assert first[0].startswith("cobotsafety demo: compiling the numba kernels (first start only")
    assert first[1].startswith("cobotsafety demo: compiled 1 numba kernel in ") and first[2] == "done"
    assert run(tmp_path) == ["done"]  # loaded from the cache: nothing to say
