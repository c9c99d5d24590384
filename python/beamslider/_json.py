"""JSON helpers shared by the command line and the reports."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


def json_safe(x: Any) -> Any:
    """Plain JSON values: numpy scalars as Python numbers, non-finite floats as the strings
    ``"inf"``, ``"-inf"``, ``"nan"``, paths as strings, dict keys as strings."""
    if isinstance(x, dict):
        return {str(k): json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return v if np.isfinite(v) else str(v)
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, Path):
        return str(x)
    return x
