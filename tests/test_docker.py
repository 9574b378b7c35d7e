"""The container recipe, checked without a Docker engine (issue 22, a newcomer's path).

What can be tested here is tested: the build context (``.dockerignore`` under Docker's rules:
a pattern matches a path or one of its parent folders; ``**/`` any depth), the two stages
and their order, the dependency list the build stage installs (by running its own command),
and the README's example. Git's ignore list is asked to ``git check-ignore``.
"""

from __future__ import annotations

import fnmatch
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def docker_patterns() -> list[str]:
    lines = (REPO / ".dockerignore").read_text().splitlines()
    return [line.strip().rstrip("/") for line in lines if line.strip() and not line.startswith("#")]


def excluded(path: str, patterns: list[str]) -> bool:
    parts = Path(path).parts
    prefixes = ["/".join(parts[:k]) for k in range(1, len(parts) + 1)]
    for pattern in patterns:
        assert not pattern.startswith("!"), "exceptions are not modelled here"
        for prefix in prefixes:
            if fnmatch.fnmatchcase(prefix, pattern):
                return True
            if pattern.startswith("**/") and fnmatch.fnmatchcase(prefix.split("/")[-1], pattern[3:]):
                return True
    return False


@pytest.mark.parametrize("path", [".git", ".git/HEAD", ".venv/bin/python", "venv/lib/x.py", "out/fig.png",
                                  "trials/trials.jsonl", "tests/test_cli.py", "cobotsafety/__pycache__/x.pyc",
                                  "cobotsafety/arm/__pycache__/packed.k-1.py311.nbi", ".hypothesis/x", "docs/a.png"])
def test_the_build_context_leaves_out(path):
    assert excluded(path, docker_patterns())


def test_the_build_context_keeps_what_the_image_needs():
    patterns = docker_patterns()
    tracked = subprocess.run(["git", "ls-files", "pyproject.toml", "README.md", "cobotsafety"], cwd=REPO,
                             capture_output=True, text=True, check=True).stdout.split()
    assert "pyproject.toml" in tracked and any(p.startswith("cobotsafety/assets/") for p in tracked)
    assert [p for p in tracked if excluded(p, patterns)] == []


def stages() -> list[list[str]]:
    """The Dockerfile's instructions (continuations joined), split at each FROM."""
    text = re.sub(r"\\\n", " ", (REPO / "Dockerfile").read_text())
    instructions = [line.strip() for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#")]
    result: list[list[str]] = []
    for instruction in instructions:
        if instruction.upper().startswith("FROM "):
            result.append([])
        result[-1].append(instruction)
    return result


def test_two_stages_the_runtime_without_browser_or_test_extra_as_a_user_with_a_healthcheck():
    build, runtime = stages()
    assert build[0].endswith(" AS build") and runtime[0].endswith(" AS runtime")
    runtime_text = "\n".join(runtime)
    assert "chromium" not in runtime_text.lower() and "[test]" not in runtime_text and "playwright" not in runtime_text
    assert "COPY --from=build /opt/venv /opt/venv" in runtime_text and "COPY . " not in runtime_text
    users = [i for i in runtime if i.startswith("USER ")]
    assert users and users[-1].split()[1] not in ("root", "0")
    assert runtime.index(users[-1]) < next(i for i, x in enumerate(runtime) if x.startswith("CMD "))
    assert any(i.startswith("HEALTHCHECK ") and "127.0.0.1:8080" in i for i in runtime)
    assert "[test]" not in "\n".join(build)


def test_dependencies_are_installed_before_the_source_is_copied():
    build, _ = stages()
    install = next(i for i, x in enumerate(build) if "pip install -r" in x)
    source = next(i for i, x in enumerate(build) if x.startswith("COPY cobotsafety"))
    copied_before = [x for x in build[:install] if x.startswith("COPY ")]
    assert install < source and copied_before == ["COPY pyproject.toml ./"]


def test_the_build_stage_installs_exactly_the_runtime_dependencies(tmp_path):
    import tomllib

    build, _ = stages()
    run = next(x for x in build if "tomllib" in x)
    command = shlex.split(run.split("RUN ", 1)[1].split(">", 1)[0])
    assert command[:2] == ["python", "-c"]
    (tmp_path / "pyproject.toml").write_bytes((REPO / "pyproject.toml").read_bytes())
    listed = subprocess.run([sys.executable, "-c", command[2]], cwd=tmp_path, capture_output=True, text=True,
                            check=True).stdout.split()
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    assert listed == project["dependencies"] and not any("playwright" in d for d in listed)


def test_the_readme_publishes_the_container_on_loopback_only():
    readme = (REPO / "README.md").read_text()
    runs = re.findall(r"docker run[^`\n]*", readme)
    assert runs and all("-p 127.0.0.1:8080:8080" in r for r in runs), runs
    assert all("-p 127.0.0.1:8080:8080" in line for line in (REPO / "Dockerfile").read_text().splitlines()
               if "docker run" in line)


@pytest.mark.parametrize("path", ["out/figure.png", "trials/trials.jsonl", "out/trials/traj_P01.npy"])
def test_git_ignores_outputs(path):
    assert subprocess.run(["git", "check-ignore", "-q", path], cwd=REPO).returncode == 0
