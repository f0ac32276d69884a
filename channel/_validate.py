"""Input checks shared by the channel models: every failure raises ChannelError naming the parameter and range."""

from __future__ import annotations

import numpy as np

from channel.errors import ChannelError


def as_float_array(name: str, value) -> np.ndarray:
    """``value`` as a float ndarray; non-numeric or non-finite input is a ChannelError naming ``name``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise ChannelError(f"{name} must be a number (got {value!r})") from err
    if not np.all(np.isfinite(arr)):
        raise ChannelError(f"{name} must be finite (got {_show(arr)})")
    return arr


def _show(arr: np.ndarray) -> str:
    flat = np.ravel(arr)
    return repr(float(flat[0])) if flat.size == 1 else f"array with values in [{np.nanmin(flat):g}, {np.nanmax(flat):g}]"


def check_range(name: str, value, lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
                hi_open: bool = False, unit: str = "") -> np.ndarray:
    """Return ``value`` as an array after checking lo <= value <= hi (open ends when asked)."""
    arr = as_float_array(name, value)
    bad = np.zeros(arr.shape, dtype=bool)
    if lo is not None:
        bad |= (arr <= lo) if lo_open else (arr < lo)
    if hi is not None:
        bad |= (arr >= hi) if hi_open else (arr > hi)
    if np.any(bad):
        left = "(" if lo_open else "["
        right = ")" if hi_open or hi is None else "]"
        lo_s = "-inf" if lo is None else f"{lo:g}"
        hi_s = "inf" if hi is None else f"{hi:g}"
        suffix = f" {unit}" if unit else ""
        offending = arr[bad]
        raise ChannelError(
            f"{name} must be in {left}{lo_s}, {hi_s}{right}{suffix} (got {_show(offending)})"
        )
    return arr


def check_positive(name: str, value, unit: str = "") -> np.ndarray:
    """value > 0."""
    return check_range(name, value, 0.0, None, lo_open=True, unit=unit)
