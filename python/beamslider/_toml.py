"""TOML for the whole package: read with the standard library's ``tomllib`` (``tomli`` before
Python 3.11), written with ``tomli-w``; no TOML is written by hand. (Parameter text is made
canonical by the core: ``Parameters.toml_text``.)"""

from __future__ import annotations

import os
from typing import Any, Callable, Dict, TypeVar, Union

import tomli_w

try:
    import tomllib as _reader
except ImportError:  # pragma: no cover - Python < 3.11
    import tomli as _reader  # type: ignore[no-redef]

TOMLDecodeError = _reader.TOMLDecodeError
loads = _reader.loads
dumps = tomli_w.dumps

T = TypeVar("T")


def loads_config(text: str, what: str) -> Dict[str, Any]:
    """The TOML of a ``what`` configuration (study, design, ...); a syntax error is a ValueError."""
    try:
        return loads(text)
    except TOMLDecodeError as e:
        raise ValueError(f"cannot read the {what} configuration: {e}") from None
    except RecursionError:
        raise ValueError(f"cannot read the {what} configuration: arrays or tables nested too deeply") from None


def read_config_file(path: Union[str, "os.PathLike[str]"], parse: Callable[[str], T]) -> T:
    """``parse`` the UTF-8 text of the file ``path``; its errors are prefixed with the path."""
    with open(os.fspath(path), "rb") as f:
        data = f.read()
    try:
        return parse(data.decode("utf-8"))
    except ValueError as e:  # UnicodeDecodeError included
        raise ValueError(f"{os.fspath(path)}: {e}") from None


__all__ = ["ConfigFile", "TOMLDecodeError", "dumps", "loads", "loads_config", "read_config_file"]


class ConfigFile:
    """TOML in for a configuration class with ``from_dict`` (studies, design runs): ``TOML_KIND``
    names it in the errors."""

    TOML_KIND = "configuration"

    @classmethod
    def from_toml_text(cls, text: str) -> Any:
        """Parse the configuration's TOML text (see the class docstring)."""
        return cls.from_dict(loads_config(text, cls.TOML_KIND))  # type: ignore[attr-defined]

    @classmethod
    def from_toml(cls, path: Union[str, "os.PathLike[str]"]) -> Any:
        """Read the configuration's TOML file."""
        return read_config_file(path, cls.from_toml_text)
