"""Argument types for the ``cobotsafety`` command: nonsense is refused while parsing.

Each type takes the argument's text and returns its value, or raises
``argparse.ArgumentTypeError`` with one sentence saying what is allowed; the parser prints
that sentence on one line and exits with status 2 (``CommandParser.error``).
"""

from __future__ import annotations

import argparse
import math
from typing import NoReturn

from cobotsafety.app.tick_schedule import MAX_RATE_HZ, MIN_RATE_HZ
from cobotsafety.trial.pseudonyms import check_pseudonyms

__all__ = ["MAX_RATE_HZ", "MIN_RATE_HZ"]  # the loop's rates, re-exported for the commands


class CommandParser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors are one line: ``cobotsafety demo: what (see --help)``."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: {one_line(message)} (see {self.prog} --help)\n")


def one_line(text: object) -> str:
    """``text`` on one line (newlines and runs of spaces become one space)."""
    return " ".join(str(text).split())


def _number(text: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number ({what})") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number ({what})")
    return value


def _integer(text: str, what: str) -> int:
    try:
        return int(text, 10)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number ({what})") from None


def port(text: str) -> int:
    """A TCP port, 1-65535."""
    value = _integer(text, "a port is 1-65535")
    if not 1 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"{value} is not a port (1-65535)")
    return value


def rate_hz(text: str) -> float:
    """A control rate [Hz] within ``MIN_RATE_HZ``-``MAX_RATE_HZ``."""
    value = _number(text, f"a rate in Hz, {MIN_RATE_HZ:.0f}-{MAX_RATE_HZ:.0f}")
    if not MIN_RATE_HZ <= value <= MAX_RATE_HZ:
        raise argparse.ArgumentTypeError(f"{value:g} Hz is outside {MIN_RATE_HZ:.0f}-{MAX_RATE_HZ:.0f} Hz")
    return value


def positive_int(text: str) -> int:
    """A whole number >= 1."""
    value = _integer(text, "at least 1")
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} must be at least 1")
    return value


def non_negative_int(text: str) -> int:
    """A whole number >= 0."""
    value = _integer(text, "0 or more")
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value} must be 0 or more")
    return value


def existing_file(text: str) -> str:
    """The path of a file that exists (a program the command starts, e.g. Chromium)."""
    import os  # noqa: PLC0415

    if not os.path.isfile(text):
        raise argparse.ArgumentTypeError(f"{text!r} is not a file")
    return text


def positive_ints(text: str) -> list[int]:
    """Comma-separated whole numbers >= 1 (``1,8``)."""
    values = [positive_int(part.strip()) for part in text.split(",") if part.strip()]
    if not values:
        raise argparse.ArgumentTypeError(f"{text!r} holds no number")
    return values


def positive_seconds(text: str) -> float:
    """A finite duration > 0 [s]."""
    value = _number(text, "seconds > 0")
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"{value:g} s must be more than 0")
    return value


def bounded_float(low: float, high: float, unit: str):
    """A type accepting finite numbers in ``(low, high]`` (``unit`` for the message)."""

    def parse(text: str) -> float:
        value = _number(text, f"({low:g}, {high:g}] {unit}")
        if not low < value <= high:
            raise argparse.ArgumentTypeError(f"{value:g} {unit} is outside ({low:g}, {high:g}] {unit}")
        return value

    return parse


def pseudonyms(text: str) -> list[str]:
    """Comma-separated pseudonyms (``P01,P02``): each valid, none twice, at least one."""
    try:
        return check_pseudonyms([part.strip() for part in text.split(",") if part.strip()])
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None

