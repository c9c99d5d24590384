"""The ``beamslider`` command: simulate, manifold, compare, map, plot, enma, hb-manifold, drift-table,
predict, discover, synthesize, study, design.

Each subcommand writes CSV/JSON results and PNG figures into an output folder (``--out``,
default ``./beamslider-out``). ``simulate``, ``manifold``, ``compare`` and ``plot`` never replace an
existing file without ``--force``, and a refused run creates nothing (not even the folder).
Figures need matplotlib (``pip install "beamslider[plot]"``); without it these commands write
their data and skip the figure with a one-line note (``beamslider plot`` is an error). ``beamslider
simulate`` without options runs the paper's signature-move case (124 Hz, 14 m/s², s₀ = 0.3) for
60 s with the harmonic-balance manifold overlaid (``--manifold pcs``: the PCS one). User errors give a one-line message and a non-zero exit
status, never a traceback.

Layout (imports run one way only: this file → subcommand modules → shared helpers):

- one module per subcommand (imported only when its command is run, see ``COMMANDS``), each with
  ``add_parser(sub)`` and its ``cmd_*`` function:
  :mod:`.simulate`, :mod:`.manifold`, :mod:`.compare`, :mod:`.plot`, :mod:`.map`, :mod:`.enma`,
  :mod:`.hb_manifold`, :mod:`.predict` (``drift-table``, ``fit-law`` and ``predict``), :mod:`.discover` (``discover`` and ``synthesize``), :mod:`.benchmark` (``discover-benchmark``), :mod:`.study`, :mod:`.design`;
- shared helpers: :mod:`._common` (errors, exit codes, common options, output planning, ranges),
  :mod:`._files` (stems and the CSV/JSON files of a run), :mod:`._manifold` (the manifold options).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import warnings
from typing import Any, Optional, Sequence

from .. import _core
from .._mpl import PlotDependencyError
from ..trajectory import ParquetDependencyError
from ._common import (DEFAULT_OUT, EXIT_ERROR, EXIT_FAULT, EXIT_INTERRUPTED, MAX_GRID, UserError, one_line,
                      write_json)
from ._files import (DEFAULT_MANIFOLD_RECORD, MANIFOLD_HEADER, manifold_file_stem, manifold_stem,
                     read_manifold_csv, read_simulation_csv, run_stem, simulation_stem, simulation_summary,
                     write_manifold_csv, write_simulation_csv)

SUBCOMMAND_MODULES = ("simulate", "manifold", "compare", "map", "plot", "enma", "hb_manifold", "predict", "discover",
                      "benchmark", "study", "design")
"""The subcommand modules in the order ``beamslider --help`` lists them."""

COMMANDS = {"simulate": "simulate", "manifold": "manifold", "compare": "compare", "map": "map", "plot": "plot",
            "enma": "enma", "hb-manifold": "hb_manifold", "drift-table": "predict", "fit-law": "predict", "predict": "predict",
            "discover": "discover", "synthesize": "discover", "discover-benchmark": "benchmark", "study": "study", "design": "design"}
"""Each command and the module that registers it: ``beamslider simulate ...`` imports only
``cli/simulate.py`` and what it needs (no discover, maps, Dask, ...; tests/test_scale.py)."""


def _module(name: str):
    import importlib

    return importlib.import_module(f".{name}", __name__)

__all__ = [
    "DEFAULT_MANIFOLD_RECORD", "DEFAULT_OUT", "EXIT_ERROR", "EXIT_FAULT", "EXIT_INTERRUPTED", "MANIFOLD_HEADER",
    "MAX_GRID", "UserError", "build_parser", "main", "manifold_file_stem", "manifold_stem", "one_line",
    "read_manifold_csv", "read_simulation_csv", "run_stem", "simulation_stem", "simulation_summary", "write_json",
    "write_manifold_csv", "write_simulation_csv",
]


def build_parser(command: Optional[str] = None) -> argparse.ArgumentParser:
    """The argument parser of the ``beamslider`` command: every subcommand registered, or only
    ``command``'s module when it names one (quicker start: the others are not imported)."""
    ap = argparse.ArgumentParser(
        prog="beamslider",
        description="Self-adaptive beam-slider system (Müller, Beck & Krack, MSSP 2023): simulations, "
                    "super-slow manifolds and comparison with measurements.",
    )
    ap.add_argument("--version", action="version", version="beamslider 0.1.0")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    names = (COMMANDS[command],) if command in COMMANDS else SUBCOMMAND_MODULES
    for name in names:
        _module(name).add_parser(sub)
    return ap


EXIT_BROKEN_PIPE = 141
"""Exit status when standard output is a pipe whose reader has closed it (128 + SIGPIPE, as a shell reports a
tool killed by it)."""


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised as Ctrl-C is: every writer's clean-up runs (partial files
    removed, finished rows kept) and the command exits with 128 + the signal's number."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def _raise_terminated(signum: int, _frame: Any) -> None:
    raise Terminated(signum)


def _catch_termination() -> None:
    """SIGTERM and SIGHUP end a command as Ctrl-C does (in the main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        return
    for name in ("SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is not None and signal.getsignal(sig) in (signal.SIG_DFL, None):
            signal.signal(sig, _raise_terminated)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``beamslider`` console script."""
    words = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(words[0] if words else None).parse_args(words)
    warnings.simplefilter("ignore", RuntimeWarning)  # run faults are reported by the commands
    _catch_termination()
    try:
        code = args.func(args)
        sys.stdout.flush()  # a closed pipe shows here, not at interpreter exit
        return code
    except BrokenPipeError:
        # `beamslider ... | head`: the reader has gone. Exit quietly, as a tool killed by SIGPIPE
        # does (status 128 + 13), and send what is left to /dev/null so the exit flush is silent.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except KeyboardInterrupt as e:
        note = getattr(e, "beamslider_note", None)  # what was kept and how to go on (a command sets it)
        note = f": {note}" if note else ""
        if isinstance(e, Terminated):
            print(f"beamslider: terminated ({signal.Signals(e.signum).name}){note}", file=sys.stderr)
            return 128 + e.signum
        print(f"beamslider: interrupted{note}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (UserError, ValueError, OverflowError, _core.SimulationError) as e:
        print(f"beamslider: error: {one_line(e)}", file=sys.stderr)
        return EXIT_ERROR
    except (PlotDependencyError, ParquetDependencyError) as e:
        print(f"beamslider: error: {e}", file=sys.stderr)
        return EXIT_ERROR
    except OSError as e:
        where = f"{e.filename}: " if getattr(e, "filename", None) else ""
        print(f"beamslider: error: {where}{e.strerror or e}", file=sys.stderr)
        return EXIT_ERROR


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
