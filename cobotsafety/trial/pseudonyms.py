"""Participant pseudonyms: what a trial accepts as a participant id.

A pseudonym names the participant's trajectory files (``traj_<pseudonym>_...npy``), so it is
refused before a session starts unless it is letters, digits, ``_`` and ``-``.
"""

from __future__ import annotations

import re

from cobotsafety.errors import PseudonymError

PSEUDONYM = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,31}")
"""Letters, digits, ``_`` and ``-`` (not first), at most 32 characters: no ``/``, ``.``,
spaces or anything else a file name could misread."""


def check_pseudonyms(names: list[str]) -> list[str]:
    """``names`` if each is a valid pseudonym and none repeats; else ``PseudonymError`` naming the first bad one."""
    if not names:
        raise PseudonymError("no participant pseudonyms given")
    seen: set[str] = set()
    for name in names:
        if not isinstance(name, str) or not PSEUDONYM.fullmatch(name):
            raise PseudonymError(f"{name!r} is not a pseudonym: letters, digits, '_' and '-' (not first), "
                             "at most 32 characters")
        if name in seen:
            raise PseudonymError(f"pseudonym {name!r} is given twice")
        seen.add(name)
    return names
