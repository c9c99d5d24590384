"""JSON helpers shared by the command line, the reports and the studies.

One convention for numbers JSON cannot hold, in every file the package writes (and in the Rust
core's results rows): NaN (a value that does not exist, e.g. no turning point) is ``null``;
±infinity (a value that does, e.g. ideal clamping k_r = inf) is the string ``"inf"`` / ``"-inf"``.
Readers take ``null`` as NaN and ``"inf"``/``"-inf"`` as float infinities."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


def json_safe(x: Any) -> Any:
    """Plain JSON values: numpy scalars as Python numbers, NaN as ``None`` (null), ±inf as the
    strings ``"inf"``/``"-inf"`` (module docstring), paths as strings, dict keys as strings."""
    if isinstance(x, dict):
        return {str(k): json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    if isinstance(x, (np.floating, float)):
        v = float(x)
        if np.isnan(v):
            return None
        return v if np.isfinite(v) else str(v)
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, Path):
        return str(x)
    return x
