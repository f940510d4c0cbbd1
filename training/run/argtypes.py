"""Argparse ``type=`` helpers shared by every command line (``cdcr-gym`` and ``experiments``).

Each helper turns the text of one option into a value or raises
:class:`argparse.ArgumentTypeError`, which argparse reports as a usage error naming the option
(``error: argument --steps: must be an integer >= 1, got '-1'``, exit status 2, no traceback)::

    parser.add_argument("--steps", type=positive_int, default=400)
    parser.add_argument("--tension", type=non_negative_float, default=40.0)
    parser.add_argument("--dpi", type=int_at_least(30), default=150)
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

__all__ = [
    "finite_float",
    "positive_float",
    "non_negative_float",
    "fraction",
    "positive_int",
    "non_negative_int",
    "int_at_least",
    "float_in",
    "nonempty_str",
]


def _int(text: str) -> int:
    try:
        return int(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None


def _float(text: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def finite_float(text: str) -> float:
    """A finite number (no NaN, no infinity)."""
    return _float(text)


def positive_float(text: str) -> float:
    """A finite number > 0."""
    value = _float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be a number > 0, got {text!r}")
    return value


def non_negative_float(text: str) -> float:
    """A finite number >= 0."""
    value = _float(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a number >= 0, got {text!r}")
    return value


def fraction(text: str) -> float:
    """A number in [0, 1]."""
    value = _float(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be a number in [0, 1], got {text!r}")
    return value


def float_in(lo: float, hi: float) -> Callable[[str], float]:
    """A ``type=`` for a finite number in the closed interval ``[lo, hi]``."""

    def parse(text: str) -> float:
        value = _float(text)
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be a number in [{lo:g}, {hi:g}], got {text!r}")
        return value

    parse.__name__ = f"float_in_{lo:g}_{hi:g}"
    return parse


def int_at_least(lo: int) -> Callable[[str], int]:
    """A ``type=`` for an integer >= ``lo``."""

    def parse(text: str) -> int:
        value = _int(text)
        if value < lo:
            raise argparse.ArgumentTypeError(f"must be an integer >= {lo}, got {text!r}")
        return value

    parse.__name__ = f"int_at_least_{lo}"
    return parse


positive_int = int_at_least(1)
positive_int.__doc__ = "An integer >= 1."
positive_int.__name__ = "positive_int"
non_negative_int = int_at_least(0)
non_negative_int.__doc__ = "An integer >= 0."
non_negative_int.__name__ = "non_negative_int"


def nonempty_str(text: str) -> str:
    """A non-blank string."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"must not be empty, got {text!r}")
    return text
