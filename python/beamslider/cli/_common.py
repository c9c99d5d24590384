"""Helpers every subcommand shares: user errors and exit codes, the common options (--out,
--params, ...), output planning (no silent overwrites), figures without matplotlib, JSON output
and the one parser of START:STOP:STEP ranges.

This module imports nothing from the subcommand modules (they import from it: no cycle)."""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

from .. import _core
from .._json import json_safe
from .._mpl import PlotDependencyError
from ..params import Parameters

DEFAULT_OUT = "beamslider-out"

EXIT_ERROR = 1
EXIT_FAULT = 3
EXIT_INTERRUPTED = 130

MAX_GRID: int = _core.MAX_AXIS_VALUES
"""Most values of a START:STOP:STEP range (the core's; a tiny step is a typing error)."""


class UserError(Exception):
    """A mistake on the command line or in an input file: reported in one line."""


def one_line(e: BaseException) -> str:
    """An error message on one line (the core's TOML errors quote the offending line with a caret
    underneath; keep the quoted text, drop the drawing)."""
    parts = []
    for ln in str(e).splitlines():
        ln = ln.strip()
        if not ln or set(ln) <= set("|^ "):
            continue
        m = re.match(r"^\d+ \| (.*)$", ln)
        parts.append(f"({m.group(1).strip()})" if m else ln)
    return " ".join(parts)


def print_report(text: str, summary: str, paths: Sequence[Path]) -> int:
    """Print a run's text report, its one-line summary and the files it wrote; the exit code 0."""
    print(text, end="")
    print(summary)
    for p in paths:
        print(f"wrote {p}")
    return 0


def doc_body(doc: Optional[str]) -> Optional[str]:
    """A subcommand's description: its module's docstring after the first paragraph (the module's
    summary), white space folded as argparse prints it (None where docstrings are stripped)."""
    parts = (doc or "").split("\n\n", 1)
    return " ".join(parts[1].split()) if len(parts) == 2 else None


def fmt(x: float) -> str:
    """A number for a file name: ``0.3`` → ``0p3``."""
    return f"{x:g}".replace(".", "p")


def write_json(path: Path, data: Dict[str, Any]) -> None:
    """``data`` as indented JSON (non-finite numbers by the package's convention, ``_json``)."""
    with open(path, "w", encoding="utf-8") as f:
        json.dump(json_safe(data), f, indent=2)
        f.write("\n")


def write_json_atomic(path: Path, data: Dict[str, Any]) -> None:
    """JSON written under a temporary name and renamed: never a half-written summary."""
    tmp = path.with_name(f".{path.name}.partial-{os.getpid()}")
    write_json(tmp, data)
    os.replace(tmp, path)


# --- options ----------------------------------------------------------------------------------


MAX_INT = 2**63 - 1
"""Largest integer option value (counts such as --record-every, --threads)."""


def positive(kind):
    """An argparse type: ``kind(text)`` that must be > 0 (finite; integers at most ``MAX_INT``)."""
    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a valid {kind.__name__}") from None
        if not v > 0:
            raise argparse.ArgumentTypeError(f"{text!r} must be > 0")
        if kind is int and v > MAX_INT:
            raise argparse.ArgumentTypeError(f"{text!r} is too large (at most {MAX_INT})")
        if kind is float and v == float("inf"):
            raise argparse.ArgumentTypeError(f"{text!r} must be finite")
        return v
    return parse


def add_common(sp: argparse.ArgumentParser, *, model_options: bool = True, window: bool = True,
               out: str = DEFAULT_OUT, force: bool = False) -> None:
    """--out (default ``out``), --progress/--no-progress, --window (``window``: only where an
    envelope is drawn), (``model_options``) --params, --dt, --solver and (``force``) --force."""
    sp.add_argument("--out", default=out, metavar="DIR",
                    help=f"output folder for CSV/JSON/PNG (default ./{out})")
    sp.add_argument("--progress", dest="progress", action="store_true", default=None,
                    help="progress bars even when standard error is not a terminal (default: only on a terminal)")
    sp.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bars")
    if window:  # maps and studies classify with the core's fixed 1-s window: no option there
        sp.add_argument("--window", type=positive(float), default=1.0, metavar="S",
                        help="moving-average window of the envelope [s] (default 1)")
    if model_options:
        sp.add_argument("--params", metavar="TOML", help="parameter file (TOML keys of beamslider.Parameters, listed in docs/model.md §1)")
        sp.add_argument("--dt", type=positive(float), metavar="S", help="time step [s] (default 2e-5)")
        sp.add_argument("--solver", choices=["fast", "reference"], help="local contact solver (default fast)")
    if force:
        add_force(sp)


def add_config_run(sp: argparse.ArgumentParser, what: str) -> None:
    """--config and --print-config of a ``what`` configuration (study, design), and where it runs:
    --scheduler / --scheduler-file (Dask) or --threads (local)."""
    sp.add_argument("--config", metavar="TOML", help=f"{what} configuration (see --print-config)")
    sp.add_argument("--print-config", action="store_true", help="print an example configuration (TOML) and exit")
    sp.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address, e.g. tcp://host:8786 (default: local)")
    sp.add_argument("--scheduler-file", metavar="FILE",
                    help="Dask scheduler file (dask scheduler --scheduler-file FILE) instead of --scheduler")
    sp.add_argument("--threads", "-j", type=int, metavar="N", help="local worker threads (default: one per core)")


def add_force(sp: argparse.ArgumentParser) -> None:
    """--force."""
    sp.add_argument("--force", action="store_true",
                    help="overwrite files of an earlier run in --out (default: refuse and write nothing)")


def params_from_args(args: argparse.Namespace) -> Parameters:
    """The model of --params with --dt / --solver applied, validated once (by the core, after the
    overrides)."""
    changes: Dict[str, Any] = {}
    if getattr(args, "dt", None) is not None:
        changes["dt_s"] = args.dt
    if getattr(args, "solver", None) is not None:
        changes["contact_solver"] = args.solver
    return Parameters.from_toml(args.params, **changes) if args.params else Parameters(**changes)


# --- output files -----------------------------------------------------------------------------


def out_dir(args: argparse.Namespace) -> Path:
    """The --out folder, created if need be."""
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UserError(f"cannot create output folder {out}: {e.strerror or e}") from None
    return out


def _finished(existing: Sequence[Path]) -> str:
    """Whether the earlier run of these files finished, as its JSON summary says (``complete``)."""
    for path in existing:
        if path.suffix == ".json":
            try:
                complete = json.loads(path.read_text(encoding="utf-8")).get("complete")
            except (OSError, ValueError, AttributeError):
                continue
            if complete is False:
                return f" that did not finish ({path.name} says complete: false)"
            if complete is True:
                return " that finished"
    return ""


def plan_outputs(args: argparse.Namespace, names: Sequence[str]) -> Path:
    """Check, before anything runs, that the output folder can be made and that none of the files
    ``names`` exists (unless ``--force``). Creates nothing: the folder is made when the first file
    is written (:func:`out_dir`)."""
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"cannot use output folder {out}: it is a file")
    parent = out
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not out.exists() and not (parent.is_dir() and os.access(parent, os.W_OK | os.X_OK)):
        raise UserError(f"cannot create output folder {out}: {parent} is not a writable folder")
    if not getattr(args, "force", False):
        existing = [out / n for n in names if (out / n).exists()]
        if existing:
            more = f" (and {len(existing) - 1} more)" if len(existing) > 1 else ""
            raise UserError(f"{existing[0]}{more} exists from an earlier run{_finished(existing)}: pass --force to overwrite, "
                            "or choose another folder with --out DIR")
    return out


def figure(draw, *args: Any, **kwargs: Any) -> bool:
    """Draw a figure; without matplotlib print a one-line note instead and return False."""
    try:
        draw(*args, **kwargs)
        return True
    except PlotDependencyError as e:
        print(f"beamslider: figure skipped: {e}", file=sys.stderr)
        return False


def report(result: Any, written: Sequence[Path]) -> int:
    """Print the written files; a run that did not complete is a warning and exit status 3."""
    for path in written:
        print(f"wrote {path}")
    if not result.completed:
        print(f"beamslider: warning: {result.message}", file=sys.stderr)
        return EXIT_FAULT
    return 0


# --- ranges -----------------------------------------------------------------------------------


def axis_values(name: str, text: str, *, what: str = "a comma-separated list") -> List[float]:
    """Values of a command-line grid: ``START:STOP:STEP`` or a comma-separated list (at least one
    value). The range is the core's (``map::Axis``, the same rule as a map configuration's
    ``{ start, stop, step }``): STOP included when within STEP/1000 of the grid, values rounded
    to 1e-9, at most ``MAX_GRID`` values. A UserError naming ``name`` otherwise."""
    text = text.strip()
    try:
        if ":" in text:
            lo, hi, step = (float(v) for v in text.split(":"))
            return list(_core.range_values(name, lo, hi, step))
        vals = [float(v) for v in text.split(",") if v.strip()]
        if not vals:
            raise ValueError
        return vals
    except ValueError:
        raise UserError(f"{name} {text!r}: give START:STOP:STEP (STOP >= START, at most {MAX_GRID} values) "
                        f"or {what}") from None


def print_written(out: Path, stem: str, drew: bool) -> int:
    """Print the ``wrote`` lines of a ``stem``.csv/.json(/.png) result (the figure only if drawn); exit 0."""
    for ext in ("csv", "json", "png") if drew else ("csv", "json"):
        print(f"wrote {out / f'{stem}.{ext}'}")
    return 0
