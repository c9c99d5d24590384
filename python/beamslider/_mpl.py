"""matplotlib is optional (the extra ``plot``): computing needs none of it, figures do."""

from __future__ import annotations

INSTALL_HINT = 'pip install "beamslider[plot]"'


class PlotDependencyError(ImportError):
    """A figure was asked for but matplotlib is not installed."""


def require_matplotlib(what: str = "this figure") -> None:
    """Raise :class:`PlotDependencyError` (an ``ImportError``) naming the extra to install
    when matplotlib cannot be imported."""
    try:
        import matplotlib  # noqa: F401
    except ImportError as e:
        raise PlotDependencyError(
            f"{what} needs matplotlib, which is not installed: {INSTALL_HINT} (or pip install matplotlib)"
        ) from e
