"""The README's code runs as printed, and its fences pair up (issue 22, a newcomer's path)."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def fenced_blocks() -> list[tuple[int, str, str]]:
    """(line, language, code) of each fenced block; an opening fence inside a block fails."""
    blocks, current = [], None
    for number, line in enumerate(README.read_text().splitlines(), start=1):
        fence = re.match(r"^\s*```(\w*)\s*$", line)
        if fence is None:
            if current is not None:
                current[2].append(line)
            continue
        if current is None:
            current = (number, fence.group(1), [])
        else:
            assert not fence.group(1), f"README.md:{number}: a ```{fence.group(1)} fence opens inside the block of line {current[0]}"
            blocks.append((current[0], current[1], textwrap.dedent("\n".join(current[2]))))
            current = None
    assert current is None, f"README.md:{current[0]}: a fence is never closed"
    return blocks


def test_every_fence_opens_and_closes_once():
    blocks = fenced_blocks()
    assert blocks and all(language in ("bash", "python", "") for _, language, _ in blocks)
    assert all(code.strip() for _, _, code in blocks), "an empty code block"


@pytest.mark.parametrize("line, code", [(line, code) for line, language, code in fenced_blocks()
                                        if language == "python"])
def test_the_python_snippets_run_as_printed(line, code, monkeypatch):
    monkeypatch.chdir(README.parent)  # paths in the snippets are relative to the checkout
    exec(compile(code, f"README.md:{line}", "exec"), {"__name__": "readme"})
