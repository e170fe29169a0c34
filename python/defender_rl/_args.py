"""Checks of the arguments the Python API takes, before they reach Rust: a wrong value gets an
error that names the argument (a conversion in Rust would say only "argument 0" or overflow)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ._core import DefenderError

U64_MAX = 2**64 - 1
I64_MAX = 2**63 - 1


def whole(name: str, value: Any, low: int, high: int, *, optional: bool = False) -> int | None:
    """``value`` as a Python int in ``[low, high]`` (None stays None when ``optional``); a bool
    is not a number here."""
    if value is None and optional:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        kind = "a whole number or None" if optional else "a whole number"
        raise TypeError(f"{name} must be {kind}, got {value!r} ({type(value).__name__})")
    if not low <= int(value) <= high:
        top = {U64_MAX: "2**64 - 1", I64_MAX: "2**63 - 1"}.get(high, str(high))
        raise DefenderError(f"{name} must be between {low} and {top}, got {value}")
    return int(value)
