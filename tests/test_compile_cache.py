"""numba's cache follows every module of the package, not only the file defining a kernel
(``cobotsafety/compile_cache.py``): a kernel calling a changed function of another module is
compiled afresh, never loaded with the old callee's machine code."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from numba.core import config

import cobotsafety
from cobotsafety import compile_cache

ROOT = Path(__file__).resolve().parents[1]
CALLEE = '''
import numba

@numba.njit(cache=True)
def gain():
    return {value}
'''
CALLER = '''
import numba
from pkg.callee import gain

@numba.njit(cache=True)
def command():
    return 2.0 * gain()
'''
INIT_KEYED = '''
from pathlib import Path
from cobotsafety import compile_cache
compile_cache.configure(Path(__file__).resolve().parent)
'''


@pytest.fixture
def cache_env(monkeypatch):
    """``configure`` sets ``NUMBA_CACHE_DIR`` and numba's configuration: both restored after."""
    yield monkeypatch
    monkeypatch.undo()
    config.reload_config()


def _package(tmp_path: Path, init: str) -> Path:
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text(init)
    (package / "caller.py").write_text(CALLER)
    (package / "callee.py").write_text(CALLEE.format(value=1.0))
    return package


def _command(tmp_path: Path, cache: Path) -> float:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache),
           "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT), os.environ.get("PYTHONPATH", "")])}
    env.pop("NUMBA_DISABLE_JIT", None)
    result = subprocess.run([sys.executable, "-c", "from pkg.caller import command; print(command())"], env=env,
                            capture_output=True, text=True, timeout=300, check=True)
    return float(result.stdout.strip())


def _change_the_callee(package: Path) -> None:
    (package / "callee.py").write_text(CALLEE.format(value=5.0))


def test_numbas_own_cache_keeps_a_changed_callees_old_code(tmp_path):
    """The trap itself, in this numba: the caller's file unchanged, its cache entry loads the old
    callee (if a numba release fixes it, this fails and the module can go)."""
    package = _package(tmp_path, "")
    assert _command(tmp_path, tmp_path / "cache") == 2.0
    _change_the_callee(package)
    assert _command(tmp_path, tmp_path / "cache") == 2.0  # stale: the source now says 10


def test_a_cache_keyed_by_the_whole_source_compiles_a_changed_callee_afresh(tmp_path):
    package = _package(tmp_path, INIT_KEYED)
    before = compile_cache.PREFIX + compile_cache.source_key(package)
    assert _command(tmp_path, tmp_path / "cache") == 2.0
    assert _command(tmp_path, tmp_path / "cache") == 2.0  # (and loads from its cache)
    _change_the_callee(package)
    assert _command(tmp_path, tmp_path / "cache") == 10.0
    after = compile_cache.PREFIX + compile_cache.source_key(package)
    for version in (before, after):  # (beside them, cobotsafety's own: the package imports it)
        assert any(path.suffix == ".nbi" for path in (tmp_path / "cache" / version).rglob("*")), version


def test_the_package_compiles_into_the_directory_of_its_own_source():
    directory = Path(os.environ["NUMBA_CACHE_DIR"])
    package_dir = Path(cobotsafety.__file__).resolve().parent
    assert directory.name == compile_cache.PREFIX + compile_cache.source_key(package_dir)
    assert directory.is_dir()
    config.reload_config()
    assert config.CACHE_DIR == str(directory)


def test_the_key_changes_with_any_module_and_a_started_process_keeps_its_parents_directory(tmp_path, cache_env):
    package = _package(tmp_path, "")
    key = compile_cache.source_key(package)
    (package / "sub").mkdir()
    (package / "sub" / "deep.py").write_text("X = 1\n")
    assert compile_cache.source_key(package) != key
    key = compile_cache.source_key(package)
    (package / "sub" / "deep.py").write_text("X = 2\n")
    assert compile_cache.source_key(package) != key
    cache_env.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    first = compile_cache.configure(package)
    assert first.parent == tmp_path / "cache"
    assert compile_cache.configure(package) == first  # a worker inherits the variable: not nested


def _versions(base: Path, ages_s: dict[str, float]) -> None:
    now = time.time()
    for name, age in ages_s.items():
        (base / name).mkdir(parents=True)
        os.utime(base / name, (now - age,) * 2)


def test_older_versions_are_pruned_but_the_most_recent_and_those_still_in_use(tmp_path, cache_env):
    package = _package(tmp_path, "")
    window, prefix = compile_cache.KEEP_RECENT_S, compile_cache.PREFIX
    # Six versions last used days ago (and a directory not ours): the three most recent stay.
    old = tmp_path / "old"
    _versions(old, {f"{prefix}{i}": 86400.0 * (i + 1) for i in range(6)} | {"someone_else": 86400.0 * 9})
    cache_env.setenv("NUMBA_CACHE_DIR", str(old))
    current = compile_cache.configure(package)
    assert {d.name for d in old.iterdir()} == {current.name, "someone_else"} | {
        f"{prefix}{i}" for i in range(compile_cache.KEEP_VERSIONS)}
    # Five versions used within the window (processes may still run on them) and two older: the
    # five stay, beyond the three most recent.
    recent = tmp_path / "recent"
    _versions(recent, {f"{prefix}r{i}": window * (i + 1) / 6 for i in range(5)}
              | {f"{prefix}d{i}": window + 86400.0 * (i + 1) for i in range(2)})
    cache_env.setenv("NUMBA_CACHE_DIR", str(recent))
    current = compile_cache.configure(package)
    assert {d.name for d in recent.iterdir()} == {current.name} | {f"{prefix}r{i}" for i in range(5)}


def test_an_unusable_cache_directory_falls_back_to_the_packages_own(tmp_path, cache_env):
    package = _package(tmp_path, "")
    (tmp_path / "a_file").write_text("not a directory")
    cache_env.setenv("NUMBA_CACHE_DIR", str(tmp_path / "a_file"))
    directory = compile_cache.configure(package)
    assert directory == package / "__pycache__" / "numba" / (compile_cache.PREFIX + compile_cache.source_key(package))
    assert os.environ["NUMBA_CACHE_DIR"] == str(directory)
