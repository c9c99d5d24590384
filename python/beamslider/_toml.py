"""TOML for the whole package: read with the standard library's ``tomllib`` (``tomli`` before
Python 3.11), written with ``tomli-w``; no TOML is written by hand. (Parameter text is made
canonical by the core: ``Parameters.toml_text``.)"""

from __future__ import annotations

import tomli_w

try:
    import tomllib as _reader
except ImportError:  # pragma: no cover - Python < 3.11
    import tomli as _reader  # type: ignore[no-redef]

TOMLDecodeError = _reader.TOMLDecodeError
loads = _reader.loads
dumps = tomli_w.dumps

__all__ = ["TOMLDecodeError", "dumps", "loads"]
