"""``beamslider simulate``: one operating point (default: the signature move, 124 Hz, 14 m/s², s₀ = 0.3,
60 s) streamed to NPZ (or CSV, Parquet) + JSON + the three-panel figure, with the super-slow manifold overlaid
(harmonic balance by default, ``--manifold pcs`` for the PCS continuation)."""

from __future__ import annotations

import argparse
import functools
import os
import sys
import threading
import time
from pathlib import Path
from typing import Any, Callable, Dict, Optional

from .. import _core
from .._util import remove_dead_partials
from ..simulate import simulate
from ..trajectory import check_disk
from ._common import EXIT_FAULT, figure, one_line, out_dir, params_from_args, plan_outputs, positive, report, write_json_atomic
from ._files import run_stem, simulation_summary
from ._manifold import (add_operating_point, add_run_options, check_manifold_args, manifold_name,
                        resolve_manifold, run_manifold)


def add_parser(sub: Any) -> None:
    """Register ``beamslider simulate``."""
    sp = sub.add_parser("simulate", help="run one operating point and plot it (default: the signature move)",
                        description="Run one operating point (default: 124 Hz, 14 m/s², s0 = 0.3, 60 s) and "
                                    "write <stem>.npz (or .csv, .parquet), <stem>.json and the three-panel figure <stem>.png.")
    add_operating_point(sp)
    sp.add_argument("--s0", type=float, default=0.3, help="initial slider position x/L (0.3)")
    sp.add_argument("--t-end", type=positive(float), default=60.0, metavar="S", help="simulated time [s] (60)")
    sp.add_argument("--model", choices=["fs", "pcs", "beam"], default="fs",
                    help="free slider, pseudo-constrained slider or beam only (fs)")
    sp.add_argument("--s-pcs", type=float, metavar="S", help="slider position of the PCS model (default s0)")
    sp.add_argument("--format", choices=["npz", "csv", "parquet"], default="npz",
                    help="trajectory file: npz (NumPy, default; np.load or beamslider.read_trajectory), csv "
                         "(shortest round-trip numbers) or parquet (needs pip install \"beamslider[parquet]\"); "
                         "streamed to disk as the run goes")
    sp.add_argument("--no-figure", dest="figure", action="store_false",
                    help="write no <stem>.png (matplotlib costs about a second per run; `beamslider plot` draws it later)")
    add_run_options(sp)
    sp.set_defaults(func=cmd_simulate)


class _Background:
    """``fn(*args, stop=event)`` in a thread; :meth:`result` waits (Ctrl-C stays responsive) and
    re-raises its exception, :meth:`cancel` sets the event and waits for the thread to stop."""

    def __init__(self, fn: Callable[..., Any], *args: Any) -> None:
        self.stop = threading.Event()
        self._value: Any = None
        self._error: Optional[BaseException] = None

        def run() -> None:
            try:
                self._value = fn(*args, stop=self.stop)
            except BaseException as e:  # handed to the main thread
                self._error = e

        self._thread = threading.Thread(target=run, name="beamslider-background")
        self._thread.start()

    def result(self) -> Any:
        try:
            while self._thread.is_alive():
                self._thread.join(0.1)
        except BaseException:
            self.cancel()
            raise
        if self._error is not None:
            raise self._error
        return self._value

    def cancel(self) -> None:
        self.stop.set()
        self._thread.join()


def _preload_figure(stop: threading.Event) -> None:
    """Import matplotlib and the figure module (about a second) while the core runs."""
    try:
        import matplotlib.backends.backend_agg  # noqa: F401
        import matplotlib.figure  # noqa: F401

        from .. import plotting  # noqa: F401
    except ImportError:
        pass  # reported when the figure is drawn


def cmd_simulate(args: argparse.Namespace) -> int:
    p = params_from_args(args)
    stem = run_stem(args.model, args.f_ex, args.a_ex, args.s0, args.s_pcs)
    resolve_manifold(args, args.a_ex)
    with_manifold = args.manifold and args.model != "beam"
    man_name = f"{manifold_name(args, args.f_ex, args.a_ex)}.csv" if with_manifold else None
    if with_manifold and args.manifold_kind == "pcs":
        check_manifold_args(args)
    if args.format == "parquet":
        from ..trajectory import require_pyarrow

        require_pyarrow()  # the extra named before anything is written
    data_name = f"{stem}.{args.format}"
    png = [f"{stem}.png"] if args.figure else []
    plan_outputs(args, [data_name, f"{stem}.json"] + png + ([man_name] if man_name else []))
    check_disk(Path(args.out) / data_name, args.t_end, p.dt_s, args.record_every)  # before anything is written
    out = Path(args.out)
    written = [out / data_name, out / f"{stem}.json"] + [out / n for n in png]
    started: Dict[str, Any] = {}
    # The manifold is written under a temporary name and renamed with the run's other files.
    man_partial = f".{man_name}.partial-{os.getpid()}" if man_name else None

    def start() -> None:
        """Called by the core once the run's inputs are checked (bad input is named before
        anything is written), before its first step."""
        out_dir(args)
        # One writer per run in a folder (the lock the maps take): a second simulate of the same
        # point into this folder fails here, before it writes anything.
        started["lock"] = _core.ResultsLock(written[1])
        plan_outputs(args, [data_name, f"{stem}.json"] + png + ([man_name] if man_name else []))  # again, locked
        remove_dead_partials(out)  # what killed runs left half-written
        # A first run's sidecar says "incomplete" until the data file is in place (plot refuses it
        # meanwhile); over an earlier run (--force) its files stay as they are until the new ones
        # are complete.
        if not written[0].exists():
            write_json_atomic(written[1], {
                "kind": "simulation", "data": data_name, "format": args.format, "complete": False, "model": args.model,
                "f_ex_hz": args.f_ex, "a_ex_m_s2": args.a_ex, "s0": args.s0, "t_end_s": args.t_end,
                "record_every": args.record_every, "params_toml": p.toml_text()})
        # While the core runs (interpreter released) the manifold runs on the other core and
        # matplotlib is imported: the three overlap on a multi-core machine.
        if args.figure:
            started["preload"] = _Background(_preload_figure)
        if with_manifold:
            started["manifold"] = _Background(functools.partial(run_manifold, name=man_partial), args, p, args.f_ex, args.a_ex)
        started["t0"] = time.perf_counter()

    try:
        return _simulate_locked(args, p, start, started, written, data_name, man_name, man_partial)
    finally:
        if "lock" in started:
            started["lock"].release()


def _simulate_locked(args: argparse.Namespace, p: Any, start: Callable[[], None], started: Dict[str, Any], written: list,
                     data_name: str, man_name: Optional[str], man_partial: Optional[str]) -> int:
    """The run of ``cmd_simulate`` (``start`` takes the folder's lock before anything is written)."""
    out = Path(args.out)

    try:
        # The trajectory streams from the core to disk (temporary name, renamed when complete).
        result = simulate(p, f_ex=args.f_ex, a_ex=args.a_ex, s0=args.s0, t_end=args.t_end, model=args.model,
                          s_pcs=args.s_pcs, record_every=args.record_every, progress=args.progress,
                          out=written[0], overwrite=True, _window=args.window, _on_start=start)
        wall = time.perf_counter() - started["t0"]
        summary = simulation_summary(result, t_end=args.t_end, record_every=args.record_every, wall_s=wall,
                                     window=args.window)
    except BaseException:
        if "manifold" in started:
            started["manifold"].cancel()
        # Interrupted (Ctrl-C, SIGTERM, SIGHUP) or failed: the core has removed the partial data
        # file; a first run's summary stays and says "complete": false (plot and a re-run say the
        # run did not finish), an earlier run's files stay whole; the new manifold goes with the run.
        if man_partial and "lock" in started:
            (out / man_partial).unlink(missing_ok=True)
        raise
    preload, background = started.get("preload"), started.get("manifold")
    summary.update({"data": data_name, "format": args.format, "complete": True})
    manifold = None
    manifold_failed = None
    if background is not None:
        try:
            manifold = background.result()
        except (ValueError, OverflowError, _core.SimulationError) as e:
            # The run itself is complete: its files say so; the manifold is left out, and said.
            manifold_failed = one_line(e)
            (out / man_partial).unlink(missing_ok=True)
            (out / man_name).unlink(missing_ok=True)  # an earlier run's manifold does not belong to this run
            summary["manifold_error"] = manifold_failed
        else:
            os.replace(out / man_partial, out / man_name)
            summary["manifold_csv"] = man_name
            written.insert(2, out / man_name)
    write_json_atomic(written[1], summary)
    if preload is not None:
        preload.result()
        from ..plotting import plot_operating_point

        if not figure(plot_operating_point, result, manifold=manifold, window=args.window, path=written[-1]):
            written.pop()
    print(f"{result.model.upper()} {args.f_ex:g} Hz, {args.a_ex:g} m/s², {args.t_end:g} s: {result.status}; "
          f"final s = {summary['final_s']:.4f}, amplitude/h = {summary['final_amplitude_over_h']:.3f} "
          f"({wall:.1f} s)")
    code = report(result, written)
    if manifold_failed is not None:
        print(f"beamslider: warning: no manifold ({manifold_failed}); the run's files are complete", file=sys.stderr)
        return code or EXIT_FAULT
    return code
