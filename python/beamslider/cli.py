"""The ``beamslider`` command: simulate, manifold, compare, map, plot, enma, discover, synthesize, study.

Each subcommand writes CSV/JSON results and PNG figures into an output folder (``--out``,
default ``./beamslider-out``). ``simulate``, ``manifold``, ``compare`` and ``plot`` never replace an
existing file without ``--force``, and a refused run creates nothing (not even the folder).
Figures need matplotlib (``pip install "beamslider[plot]"``); without it these commands write
their data and skip the figure with a one-line note (``beamslider plot`` is an error). ``beamslider simulate`` without options runs the paper's
signature-move case (124 Hz, 14 m/s², s₀ = 0.3) for 60 s with the PCS manifold overlaid.
User errors give a one-line message and a non-zero exit status, never a traceback.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import os
import re
import sys
import time
import warnings
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from . import _core
from ._json import json_safe as _json_safe
from ._mpl import PlotDependencyError
from .measurement import Measurement, read_measurement
from .params import Parameters
from .simulate import ManifoldResult, SimulationResult, manifold_grid, simulate, super_slow_manifold

DEFAULT_OUT = "beamslider-out"

EXIT_ERROR = 1
EXIT_FAULT = 3
EXIT_INTERRUPTED = 130

MAX_INT = 2**63 - 1
"""Largest integer option value (counts such as --record-every, --threads)."""

MAX_GRID = 1_000_000
"""Most values of a START:STOP:STEP range on the command line (a tiny step is a typing error)."""


class UserError(Exception):
    """A mistake on the command line or in an input file: reported in one line."""


# --- files ------------------------------------------------------------------------------------


def _fmt(x: float) -> str:
    return f"{x:g}".replace(".", "p")


def run_stem(model: str, f_ex: float, a_ex: float, s0: float, s_pcs: Optional[float] = None) -> str:
    """File name stem of a run, e.g. ``fs_124Hz_14ms2_s0_0p3``."""
    if model == "fs":
        where = f"s0_{_fmt(s0)}"
    elif model == "pcs":
        where = f"s_{_fmt(s0 if s_pcs is None else s_pcs)}"
    else:
        where = "beam"
    return f"{model}_{_fmt(f_ex)}Hz_{_fmt(a_ex)}ms2_{where}"


def simulation_stem(result: SimulationResult) -> str:
    """File name stem of a run, e.g. ``fs_124Hz_14ms2_s0_0p3``."""
    s_pcs = float(result.s[0]) if result.model == "pcs" and len(result.s) else None
    return run_stem(result.model, result.f_ex, result.a_ex, result.s0, s_pcs)


DEFAULT_MANIFOLD_RECORD = 25


def manifold_file_stem(f_ex: float, a_ex: float, periods: int, record: int = DEFAULT_MANIFOLD_RECORD,
                       s: Optional[Sequence[float]] = None) -> str:
    """File name stem of a manifold carrying the settings that change it, e.g.
    ``manifold_124Hz_14ms2_100periods`` (plus ``_avgR`` for a non-default averaging and
    ``_s<hash>`` for a slider grid other than the default)."""
    stem = f"manifold_{_fmt(f_ex)}Hz_{_fmt(a_ex)}ms2_{int(periods)}periods"
    if record != DEFAULT_MANIFOLD_RECORD:
        stem += f"_avg{int(record)}"
    if s is not None:
        digest = hashlib.sha1(",".join(f"{float(v):.12g}" for v in s).encode()).hexdigest()[:8]
        stem += f"_s{digest}"
    return stem


def manifold_stem(m: ManifoldResult, s: Optional[Sequence[float]] = None) -> str:
    """File name stem of a computed manifold (see :func:`manifold_file_stem`); ``s`` = the grid
    asked for, None for the default grid."""
    return manifold_file_stem(m.f_ex, m.a_ex, m.periods, m.record, s)


def write_simulation_csv(path: Path, result: SimulationResult) -> None:
    """Recorded columns under the core's channel names."""
    cols = result.columns()
    data = np.column_stack(list(cols.values()))
    np.savetxt(path, data, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")  # round trip


def read_simulation_csv(path: Path) -> Dict[str, np.ndarray]:
    """The columns of a trajectory file (.npz memory-mapped, or CSV); a UserError naming the file
    when it is not one."""
    if not path.exists():
        raise UserError(f"{path}: no such file")
    if path.suffix == ".npz":
        from .simulate import read_trajectory

        try:
            cols = read_trajectory(path)
        except ValueError as e:
            raise UserError(one_line(e)) from None
        missing = [n for n in ("t_s", "w_4L7_m", "s", "xC_m", "zC_m", "beta_rad") if n not in cols]
        if missing or len(cols["t_s"]) < 2:
            raise UserError(f"{path}: not a beamslider trajectory with two or more rows")
        return cols
    try:
        with open(path, "r", encoding="utf-8") as f:
            header = f.readline().strip().split(",")
    except UnicodeDecodeError:
        raise UserError(f"{path}: not a text CSV file (not UTF-8)") from None
    need = ["t_s", "w_4L7_m", "s", "xC_m", "zC_m", "beta_rad"]
    missing = [n for n in need if n not in header]
    if missing:
        raise UserError(f"{path}: not a beamslider simulation CSV (missing columns {', '.join(missing)})")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # an empty file is reported below
            data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, encoding="utf-8")
    except ValueError as e:
        raise UserError(f"{path}: {one_line(e)}") from None
    if data.shape[0] < 2 or data.shape[1] != len(header):
        raise UserError(f"{path}: need at least two rows of {len(header)} values (found {data.shape[0]} rows of "
                        f"{data.shape[1]})")
    return {n: data[:, i] for i, n in enumerate(header)}


MANIFOLD_HEADER = ["branch", "s", "amplitude_m"]
"""Columns of a manifold CSV, the same as ``beamslider-batch manifold`` writes (docs/model.md §6)."""


def write_manifold_csv(path: Path, m: ManifoldResult) -> None:
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(MANIFOLD_HEADER)
        for branch, ss, aa in (("up", m.up_s, m.up_amplitude), ("down", m.down_s, m.down_amplitude)):
            for s, a in zip(ss, aa):
                w.writerow([branch, f"{s:.6g}", f"{a:.10e}"])


def read_manifold_csv(path: Path, *, f_ex: float, a_ex: float, params: Parameters) -> ManifoldResult:
    up: List[List[float]] = [[], []]
    down: List[List[float]] = [[], []]
    with open(path, "r", encoding="utf-8") as f:
        r = csv.reader(f)
        header = next(r, None)
        # "sweep" is the name older versions of this package wrote for the branch column.
        if header not in (MANIFOLD_HEADER, ["sweep", "s", "amplitude_m"]):
            raise UserError(f"{path}: not a beamslider manifold CSV (header branch,s,amplitude_m)")
        for lineno, row in enumerate(r, start=2):
            try:
                target = {"up": up, "down": down}[row[0]]
                target[0].append(float(row[1]))
                target[1].append(float(row[2]))
            except (KeyError, IndexError, ValueError):
                raise UserError(f"{path}:{lineno}: malformed manifold row {row!r}") from None
    m = re.search(r"_(\d+)periods", Path(path).name)  # the file name carries the periods per s-step
    return ManifoldResult(
        up_s=np.array(up[0]), up_amplitude=np.array(up[1]), down_s=np.array(down[0]),
        down_amplitude=np.array(down[1]), counters={}, f_ex=f_ex, a_ex=a_ex, periods=int(m.group(1)) if m else 0,
        record=0, params=params,
    )


def write_json(path: Path, data: Dict[str, Any]) -> None:
    with open(path, "w", encoding="utf-8") as f:
        json.dump(_json_safe(data), f, indent=2)
        f.write("\n")


def simulation_summary(result: SimulationResult, *, t_end: float, record_every: int, wall_s: float,
                       window: float) -> Dict[str, Any]:
    env = result.display_envelope(window) if len(result.t) > 2 else np.array([np.nan])
    return {
        "kind": "simulation",
        "model": result.model,
        "f_ex_hz": result.f_ex,
        "a_ex_m_s2": result.a_ex,
        "s0": result.s0,
        "s_pcs": float(result.s[0]) if result.model == "pcs" and len(result.s) else None,
        "t_end_s": t_end,
        "record_every": record_every,
        "status": result.status,
        "message": result.message,
        "final_t_s": float(result.t[-1]),
        "final_s": float(result.s[-1]),
        "final_amplitude_m": float(env[-1]),
        "final_amplitude_over_h": float(env[-1] / result.params.thickness_m),
        "wall_time_s": wall_s,
        "counters": result.counters,
        "params_toml": result.params.toml_text(),
    }


# --- subcommands ------------------------------------------------------------------------------


def _params(args: argparse.Namespace) -> Parameters:
    p = Parameters.from_toml(args.params) if args.params else Parameters()
    changes: Dict[str, Any] = {}
    if getattr(args, "dt", None) is not None:
        changes["dt_s"] = args.dt
    if getattr(args, "solver", None) is not None:
        changes["contact_solver"] = args.solver
    if changes:
        p = Parameters(**{**p.to_dict(), **changes})
    return p


def _out(args: argparse.Namespace) -> Path:
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UserError(f"cannot create output folder {out}: {e.strerror or e}") from None
    return out


def _plan_outputs(args: argparse.Namespace, names: Sequence[str]) -> Path:
    """Check, before anything runs, that the output folder can be made and that none of the files
    ``names`` exists (unless ``--force``). Creates nothing: the folder is made when the first file
    is written (:func:`_out`)."""
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
            raise UserError(f"{existing[0]}{more} exists from an earlier run: pass --force to overwrite, "
                            "or choose another folder with --out DIR")
    return out


def _figure(draw, *args: Any, **kwargs: Any) -> bool:
    """Draw a figure; without matplotlib print a one-line note instead and return False."""
    try:
        draw(*args, **kwargs)
        return True
    except PlotDependencyError as e:
        print(f"beamslider: figure skipped: {e}", file=sys.stderr)
        return False


def _grid(args: argparse.Namespace, p: Parameters) -> Optional[np.ndarray]:
    if args.manifold_s is None:
        return None
    text = args.manifold_s.strip()
    try:
        if ":" in text:
            lo, hi, step = (float(v) for v in text.split(":"))
            if not (step > 0 and hi >= lo and (hi - lo) / step < MAX_GRID):
                raise ValueError
            return np.round(np.arange(lo, hi + 0.5 * step, step), 10)
        return np.array([float(v) for v in text.split(",") if v.strip()])
    except ValueError:
        raise UserError(f"--manifold-s {text!r}: give START:STOP:STEP (STOP >= START, at most {MAX_GRID} values) "
                        "or a comma-separated list of s") from None


def _manifold_name(args: argparse.Namespace, p: Parameters, f_ex: float, a_ex: float) -> str:
    """Stem of the manifold files this command line will write."""
    return manifold_file_stem(f_ex, a_ex, args.manifold_periods, args.manifold_record, _grid(args, p))


def _check_manifold_args(args: argparse.Namespace) -> None:
    if args.manifold_record > args.manifold_periods:
        raise UserError(f"--manifold-record {args.manifold_record}: must not exceed --manifold-periods "
                        f"({args.manifold_periods})")


def _manifold(args: argparse.Namespace, p: Parameters, f_ex: float, a_ex: float, out: Path) -> ManifoldResult:
    m = super_slow_manifold(p, f_ex=f_ex, a_ex=a_ex, s=_grid(args, p), periods=args.manifold_periods,
                            record=args.manifold_record, progress=args.progress)
    write_manifold_csv(_out(args) / f"{_manifold_name(args, p, f_ex, a_ex)}.csv", m)
    return m


def _report(result: SimulationResult, written: Sequence[Path]) -> int:
    for path in written:
        print(f"wrote {path}")
    if not result.completed:
        print(f"beamslider: warning: {result.message}", file=sys.stderr)
        return EXIT_FAULT
    return 0


def write_json_atomic(path: Path, data: Dict[str, Any]) -> None:
    """JSON written under a temporary name and renamed: never a half-written summary."""
    tmp = path.with_name(f".{path.name}.partial-{os.getpid()}")
    write_json(tmp, data)
    os.replace(tmp, path)


def cmd_simulate(args: argparse.Namespace) -> int:
    from .plotting import plot_operating_point

    p = _params(args)
    stem = run_stem(args.model, args.f_ex, args.a_ex, args.s0, args.s_pcs)
    with_manifold = args.manifold and args.model != "beam"
    man_name = f"{_manifold_name(args, p, args.f_ex, args.a_ex)}.csv" if with_manifold else None
    # Bad input is named before anything else.
    simulate(p, f_ex=args.f_ex, a_ex=args.a_ex, s0=args.s0, t_end=args.t_end, model=args.model, s_pcs=args.s_pcs,
             record_every=args.record_every, _check_only=True)
    if with_manifold:
        _check_manifold_args(args)
    data_name = f"{stem}.{args.format}"
    out = _plan_outputs(args, [data_name, f"{stem}.json", f"{stem}.png"] + ([man_name] if man_name else []))
    out = _out(args)
    written = [out / data_name, out / f"{stem}.json", out / f"{stem}.png"]
    base = {"kind": "simulation", "data": data_name, "format": args.format, "complete": False,
            "model": args.model, "f_ex_hz": args.f_ex, "a_ex_m_s2": args.a_ex, "s0": args.s0,
            "t_end_s": args.t_end, "record_every": args.record_every, "params_toml": p.toml_text()}
    # The sidecar says "incomplete" until the data file is in place (plot refuses it meanwhile).
    write_json_atomic(written[1], base)
    t0 = time.perf_counter()
    # The trajectory streams from the core to disk (temporary name, renamed when complete).
    result = simulate(p, f_ex=args.f_ex, a_ex=args.a_ex, s0=args.s0, t_end=args.t_end, model=args.model,
                      s_pcs=args.s_pcs, record_every=args.record_every, progress=args.progress,
                      out=written[0], overwrite=True)
    wall = time.perf_counter() - t0
    manifold = None
    summary = simulation_summary(result, t_end=args.t_end, record_every=args.record_every, wall_s=wall,
                                 window=args.window)
    summary.update({"data": data_name, "format": args.format, "complete": True})
    if with_manifold:
        manifold = _manifold(args, p, args.f_ex, args.a_ex, out)
        summary["manifold_csv"] = man_name
        written.insert(2, out / man_name)
    write_json_atomic(written[1], summary)
    if not _figure(plot_operating_point, result, manifold=manifold, window=args.window, path=written[-1]):
        written.pop()
    print(f"{result.model.upper()} {args.f_ex:g} Hz, {args.a_ex:g} m/s², {args.t_end:g} s: {result.status}; "
          f"final s = {summary['final_s']:.4f}, amplitude/h = {summary['final_amplitude_over_h']:.3f} "
          f"({wall:.1f} s)")
    return _report(result, written)


def cmd_manifold(args: argparse.Namespace) -> int:
    from .plotting import plot_manifold

    p = _params(args)
    stem = _manifold_name(args, p, args.f_ex, args.a_ex)
    simulate(p, f_ex=args.f_ex, a_ex=args.a_ex, t_end=1.0, model="beam", _check_only=True)  # names bad input first
    _check_manifold_args(args)
    out = _plan_outputs(args, [f"{stem}.{ext}" for ext in ("csv", "json", "png")])
    t0 = time.perf_counter()
    m = _manifold(args, p, args.f_ex, args.a_ex, out)
    write_json(out / f"{stem}.json", {
        "kind": "manifold", "f_ex_hz": m.f_ex, "a_ex_m_s2": m.a_ex, "periods": m.periods, "record": m.record,
        "up": {"s": m.up_s.tolist(), "amplitude_m": m.up_amplitude.tolist()},
        "down": {"s": m.down_s.tolist(), "amplitude_m": m.down_amplitude.tolist()},
        "counters": m.counters, "wall_time_s": time.perf_counter() - t0, "params_toml": p.toml_text(),
    })
    exts = ["csv", "json"] + (["png"] if _figure(plot_manifold, m, path=out / f"{stem}.png") else [])
    for ext in exts:
        print(f"wrote {out / f'{stem}.{ext}'}")
    return 0


def _measurement(path: str) -> Measurement:
    try:
        return read_measurement(path)
    except FileNotFoundError:
        raise UserError(f"{path}: no such file") from None


def cmd_compare(args: argparse.Namespace) -> int:
    from .plotting import plot_operating_point

    meas = _measurement(args.measurement)
    f_ex = args.f_ex if args.f_ex is not None else meas.f_ex
    a_ex = args.a_ex if args.a_ex is not None else meas.a_ex
    s0 = args.s0 if args.s0 is not None else meas.s0
    if f_ex is None or a_ex is None or s0 is None:
        raise UserError(f"{args.measurement}: the file name does not give f_ex, a_ex and s0 "
                        "(like ..._fex124_ExcLevel14_RelSliderPosStart03.txt): pass --f-ex, --a-ex and --s0")
    if args.s0 is None:
        s0 = float(meas.s[0]) if args.start_from_measured else s0
    t_end = args.t_end if args.t_end is not None else float(meas.t[-1] - meas.t[0])
    p = _params(args)
    name = Path(args.measurement).name
    stem = "compare_" + (name[:-3] if name.lower().endswith(".gz") else Path(name).stem).rsplit(".txt", 1)[0]
    man_name = f"{_manifold_name(args, p, f_ex, a_ex)}.csv" if args.manifold else None
    simulate(p, f_ex=f_ex, a_ex=a_ex, s0=s0, t_end=t_end, record_every=args.record_every, _check_only=True)  # names bad input first
    if args.manifold:
        _check_manifold_args(args)
    out = _plan_outputs(args, [f"{stem}_model.csv", f"{stem}.json", f"{stem}.png"] + ([man_name] if man_name else []))
    t0 = time.perf_counter()
    written = [_out(args) / f"{stem}_model.csv", out / f"{stem}.json", out / f"{stem}.png"]
    result = simulate(p, f_ex=f_ex, a_ex=a_ex, s0=s0, t_end=t_end, record_every=args.record_every,
                      progress=args.progress, out=written[0], overwrite=True)
    wall = time.perf_counter() - t0
    summary = simulation_summary(result, t_end=t_end, record_every=args.record_every, wall_s=wall,
                                 window=args.window)
    menv = meas.envelope(args.window)
    summary.update({
        "kind": "compare",
        "measurement": str(meas.path),
        "measured_final_s": float(meas.s[-1]),
        "measured_final_amplitude_m": float(menv[-1]),
        "measured_final_amplitude_over_h": float(menv[-1] / p.thickness_m),
        "data": written[0].name, "format": "csv", "complete": True,
    })
    manifold = None
    if args.manifold:
        manifold = _manifold(args, p, f_ex, a_ex, out)
        summary["manifold_csv"] = man_name
        written.insert(2, out / man_name)
    write_json_atomic(written[1], summary)
    if not _figure(plot_operating_point, result, manifold=manifold, measurement=meas, window=args.window,
                   path=written[-1]):
        written.pop()
    print(f"model final s = {summary['final_s']:.4f} (measured {summary['measured_final_s']:.4f}), "
          f"amplitude/h = {summary['final_amplitude_over_h']:.3f} "
          f"(measured {summary['measured_final_amplitude_over_h']:.3f})")
    return _report(result, written)


def _read_meta(path: Path) -> Dict[str, Any]:
    """The JSON summary written beside a result; a UserError naming the file when it is not one."""
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise UserError(f"{path}: not valid JSON ({e})") from None
    types = {"kind": str, "params_toml": str, "model": str, "status": str, "message": str, "manifold_csv": str,
             "measurement": str, "f_ex_hz": (int, float), "a_ex_m_s2": (int, float), "s0": (int, float, type(None)),
             "counters": dict}
    bad = [k for k, t in types.items() if isinstance(meta, dict) and k in meta and not isinstance(meta[k], t)]
    if not isinstance(meta, dict) or bad:
        what = f"field {bad[0]!r} has the wrong type" if bad else "not a JSON object"
        raise UserError(f"{path}: not a beamslider result summary ({what})")
    if meta.get("kind") == "manifold" and not all(k in meta for k in ("f_ex_hz", "a_ex_m_s2")):
        raise UserError(f"{path}: manifold summary without f_ex_hz / a_ex_m_s2")
    return meta


def cmd_plot(args: argparse.Namespace) -> int:
    from ._mpl import require_matplotlib
    from .plotting import plot_manifold, plot_operating_point

    if args.result is None and args.measurement is None:
        raise UserError("nothing to plot: give a simulation result (CSV or JSON) and/or --measurement FILE")
    result = None
    manifold = None
    stem = "plot"
    if args.result is not None:
        path = Path(args.result)
        csv_path, json_path = path.with_suffix(".csv"), path.with_suffix(".json")
        meta = _read_meta(json_path) if path.suffix == ".json" or json_path.exists() else {}
        if meta.get("kind") == "manifold":
            p = Parameters.from_toml_text(meta.get("params_toml", ""))
            manifold = read_manifold_csv(csv_path, f_ex=meta["f_ex_hz"], a_ex=meta["a_ex_m_s2"], params=p)
            if isinstance(meta.get("periods"), int):
                manifold.periods = meta["periods"]
            require_matplotlib("beamslider plot")
            out = _plan_outputs(args, [f"{path.stem}.png"])
            target = _out(args) / f"{path.stem}.png"
            plot_manifold(manifold, path=target)
            print(f"wrote {target}")
            return 0
        if meta.get("complete") is False:
            raise UserError(f"{json_path}: the run that writes {meta.get('data', 'this result')} did not finish "
                            "(incomplete result): run it again")
        if isinstance(meta.get("data"), str):
            csv_path = path.with_name(meta["data"])
        elif meta.get("kind") == "compare":
            csv_path = path.with_name(f"{path.stem}_model.csv")
        elif path.suffix == ".npz":
            csv_path = path
        if csv_path.suffix == ".npz" and not meta:
            raise UserError(f"{path}: no summary {json_path.name} beside it: cannot tell whether the run finished")
        p = Parameters.from_toml_text(meta["params_toml"]) if "params_toml" in meta else Parameters()
        cols = read_simulation_csv(csv_path)
        result = SimulationResult(
            t=cols["t_s"], w=cols["w_4L7_m"], s=cols["s"], x_c=cols["xC_m"], z_c=cols["zC_m"], beta=cols["beta_rad"],
            status=meta.get("status", "completed"), message=meta.get("message", ""), counters=meta.get("counters", {}),
            final_state={}, params=p, f_ex=float(meta.get("f_ex_hz", "nan")), a_ex=float(meta.get("a_ex_m_s2", "nan")),
            s0=float(meta["s0"]) if meta.get("s0") is not None else float(cols["s"][0]), model=meta.get("model", "fs"),
        )
        man_csv = args.manifold or (path.with_name(meta["manifold_csv"]) if "manifold_csv" in meta else None)
        if man_csv is not None:
            manifold = read_manifold_csv(Path(man_csv), f_ex=result.f_ex, a_ex=result.a_ex, params=p)
        if args.measurement is None and meta.get("measurement"):
            args.measurement = meta["measurement"]
        stem = path.stem
    meas = _measurement(args.measurement) if args.measurement else None
    if result is None and meas is not None:
        stem = Path(args.measurement).stem
        stem = Path(stem).stem if args.measurement.lower().endswith(".gz") else stem
    require_matplotlib("beamslider plot")
    _plan_outputs(args, [f"{stem}.png"])
    target = _out(args) / f"{stem}.png"
    plot_operating_point(result, manifold=manifold, measurement=meas, window=args.window, path=target)
    print(f"wrote {target}")
    return 0


def _axis_text(name: str, text: str) -> List[float]:
    text = text.strip()
    try:
        if ":" in text:
            lo, hi, step = (float(v) for v in text.split(":"))
            if not (step > 0 and hi >= lo and (hi - lo) / step < MAX_GRID):
                raise ValueError
            n = int(np.floor((hi - lo) / step + 1e-3)) + 1
            return [round(lo + i * step, 9) for i in range(n)]
        vals = [float(v) for v in text.split(",") if v.strip()]
        if not vals:
            raise ValueError
        return vals
    except ValueError:
        raise UserError(f"{name} {text!r}: give START:STOP:STEP (STOP >= START, at most {MAX_GRID} values) "
                        "or a comma-separated list") from None


def cmd_map(args: argparse.Namespace) -> int:
    from .maps import RESULTS_FILE, failures, map_config_toml, plot_operating_map, run_map_config, text_table

    extend = args.extend_to is not None
    if extend and args.resume:
        raise UserError("--extend-to finishes an interrupted extension by itself: leave out --resume")
    if extend and not args.config and all(v is None for v in (args.f_ex, args.a_ex, args.s0, args.t_end, args.params, args.dt)):
        saved = _out(args) / "map.toml"
        if not saved.exists():
            raise UserError(f"--extend-to: no map to extend in {saved.parent} (map.toml missing)")
        args.config = str(saved)
    if args.config:
        try:
            config = Path(args.config).read_text(encoding="utf-8")
        except FileNotFoundError:
            raise UserError(f"{args.config}: no such file") from None
        if any(v is not None for v in (args.f_ex, args.a_ex, args.s0, args.t_end, args.params, args.dt)):
            raise UserError("--config replaces --f-ex/--a-ex/--s0/--t-end/--params/--dt: put them in the TOML file")
    else:
        p = _params(args)
        config = map_config_toml(
            p, f_ex=_axis_text("--f-ex", "100:130:2" if args.f_ex is None else args.f_ex),
            a_ex=_axis_text("--a-ex", "4:16:2" if args.a_ex is None else args.a_ex),
            s0=_axis_text("--s0", "0.3" if args.s0 is None else args.s0),
            t_end=args.t_end if args.t_end is not None else 120.0)
    if extend:
        import re

        m = re.search(r"^duration_s\s*=\s*(\S+)", config, re.M)
        old = float(m.group(1)) if m else 120.0
        if not (args.extend_to > old):
            raise UserError(f"--extend-to {args.extend_to:g}: must exceed the map's t_end ({old:g} s)")
        config = re.sub(r"^duration_s\s*=.*$", f"duration_s = {float(args.extend_to)!r}", config, count=1, flags=re.M) \
            if m else f"duration_s = {float(args.extend_to)!r}\n" + config
    if args.print_config:
        print(config, end="")
        return 0
    out = Path(args.out)  # created by the map itself, after the scheduler (if any) answered
    t0 = time.perf_counter()
    if args.scheduler and args.scheduler_file:
        raise UserError("give --scheduler or --scheduler-file, not both")
    table = run_map_config(config, out=out, resume=args.resume, threads=args.threads, progress=args.progress,
                           extend=extend, scheduler=args.scheduler, scheduler_file=args.scheduler_file,
                           chunk_size=args.chunk_size)
    wall = time.perf_counter() - t0
    txt = text_table(table)
    (out / "map.txt").write_text(txt, encoding="utf-8")
    s0s = sorted(set(table["s0"].tolist()))
    pngs = [out / "map.png"]
    if not _figure(plot_operating_map, table, path=pngs[0], mark_changes=len(s0s) > 1):
        pngs = []
    print(txt, end="")
    print(f"{len(table['index'])} points in {wall:.1f} s")
    for path in [out / RESULTS_FILE, out / "map.toml", out / "map.txt", *pngs]:
        print(f"wrote {path}")
    failed = failures(table)
    if failed:
        print(f"beamslider: {len(failed)} of {len(table['index'])} points failed (the others are done):", file=sys.stderr)
        for line in failed:
            print(f"  {line}", file=sys.stderr)
        return EXIT_FAULT
    return 0


# --- argument parsing -------------------------------------------------------------------------


def _positive(kind):
    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a valid {kind.__name__}") from None
        if not v > 0:
            raise argparse.ArgumentTypeError(f"{text!r} must be > 0")
        if kind is int and v > MAX_INT:
            raise argparse.ArgumentTypeError(f"{text!r} is too large (at most {MAX_INT})")
        if kind is float and not np.isfinite(v):
            raise argparse.ArgumentTypeError(f"{text!r} must be finite")
        return v
    return parse


def _common(sp: argparse.ArgumentParser, *, model_options: bool = True, window: bool = True) -> None:
    sp.add_argument("--out", default=DEFAULT_OUT, metavar="DIR",
                    help=f"output folder for CSV/JSON/PNG (default ./{DEFAULT_OUT})")
    sp.add_argument("--progress", dest="progress", action="store_true", default=None,
                    help="progress bars even when standard error is not a terminal (default: only on a terminal)")
    sp.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bars")
    if window:  # maps and studies classify with the core's fixed 1-s window: no option there
        sp.add_argument("--window", type=_positive(float), default=1.0, metavar="S",
                        help="moving-average window of the envelope [s] (default 1)")
    if model_options:
        sp.add_argument("--params", metavar="TOML", help="parameter file (TOML keys of beamslider.Parameters, listed in docs/model.md §1)")
        sp.add_argument("--dt", type=_positive(float), metavar="S", help="time step [s] (default 2e-5)")
        sp.add_argument("--solver", choices=["fast", "reference"], help="local contact solver (default fast)")


def _force_option(sp: argparse.ArgumentParser) -> None:
    sp.add_argument("--force", action="store_true",
                    help="overwrite files of an earlier run in --out (default: refuse and write nothing)")


def _manifold_options(sp: argparse.ArgumentParser, *, default_on: bool) -> None:
    if default_on:
        sp.add_argument("--no-manifold", dest="manifold", action="store_false",
                        help="skip the PCS manifold of panel (c)")
    sp.add_argument("--manifold-periods", type=_positive(int), default=100, metavar="N",
                    help="excitation periods per s-step, i.e. simulated at each slider position (default 100, "
                         "paper 300); part of the manifold's file name")
    sp.add_argument("--manifold-record", type=_positive(int), default=DEFAULT_MANIFOLD_RECORD, metavar="N",
                    help="periods averaged at each slider position (default 25)")
    sp.add_argument("--manifold-s", metavar="GRID",
                    help="slider positions: START:STOP:STEP or a comma list (default B/(2L)..0.5 by 0.005)")


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="beamslider",
        description="Self-adaptive beam-slider system (Müller, Beck & Krack, MSSP 2023): simulations, "
                    "super-slow manifolds and comparison with measurements.",
    )
    ap.add_argument("--version", action="version", version="beamslider 0.1.0")
    sub = ap.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    sp = sub.add_parser("simulate", help="run one operating point and plot it (default: the signature move)",
                        description="Run one operating point (default: 124 Hz, 14 m/s², s0 = 0.3, 60 s) and "
                                    "write <stem>.csv, <stem>.json and the three-panel figure <stem>.png.")
    sp.add_argument("--f-ex", type=_positive(float), default=124.0, metavar="HZ", help="excitation frequency (124)")
    sp.add_argument("--a-ex", type=float, default=14.0, metavar="M_S2", help="base acceleration amplitude (14)")
    sp.add_argument("--s0", type=float, default=0.3, help="initial slider position x/L (0.3)")
    sp.add_argument("--t-end", type=_positive(float), default=60.0, metavar="S", help="simulated time [s] (60)")
    sp.add_argument("--model", choices=["fs", "pcs", "beam"], default="fs",
                    help="free slider, pseudo-constrained slider or beam only (fs)")
    sp.add_argument("--s-pcs", type=float, metavar="S", help="slider position of the PCS model (default s0)")
    sp.add_argument("--record-every", type=_positive(int), default=10, metavar="K", help="keep every K-th step (10)")
    sp.add_argument("--format", choices=["npz", "csv"], default="npz",
                    help="trajectory file: npz (NumPy, default; np.load or beamslider.read_trajectory) or csv "
                         "(shortest round-trip numbers); streamed to disk as the run goes")
    _common(sp)
    _force_option(sp)
    _manifold_options(sp, default_on=True)
    sp.set_defaults(func=cmd_simulate)

    sp = sub.add_parser("manifold", help="super-slow manifold by PCS continuation",
                        description="Compute the super-slow manifold (upward and downward sweeps, docs/model.md §6) "
                                    "and write manifold_<f>Hz_<a>ms2_<N>periods.csv/.json/.png.")
    sp.add_argument("--f-ex", type=_positive(float), default=124.0, metavar="HZ", help="excitation frequency (124)")
    sp.add_argument("--a-ex", type=float, default=14.0, metavar="M_S2", help="base acceleration amplitude (14)")
    _common(sp)
    _force_option(sp)
    _manifold_options(sp, default_on=False)
    sp.set_defaults(func=cmd_manifold, manifold=True)

    sp = sub.add_parser("compare", help="a measurement file against the model at its operating point",
                        description="Read a measured file of the published data set, simulate the same "
                                    "operating point (from the file name) and overlay both.")
    sp.add_argument("measurement", help="e.g. Time_VelBeam_RelSliderPos__fex124_ExcLevel14_RelSliderPosStart03.txt")
    sp.add_argument("--f-ex", type=_positive(float), metavar="HZ", help="override f_ex from the file name")
    sp.add_argument("--a-ex", type=float, metavar="M_S2", help="override a_ex from the file name")
    sp.add_argument("--s0", type=float, help="override s0 from the file name")
    sp.add_argument("--start-from-measured", action="store_true",
                    help="start the model at the first measured s instead of the nominal s0")
    sp.add_argument("--t-end", type=_positive(float), metavar="S", help="simulated time (default: measured duration)")
    sp.add_argument("--record-every", type=_positive(int), default=10, metavar="K", help="keep every K-th step (10)")
    _common(sp)
    _force_option(sp)
    _manifold_options(sp, default_on=True)
    sp.set_defaults(func=cmd_compare)

    sp = sub.add_parser("map", help="operating map: behaviour over a grid of f_ex, a_ex (and s0), in parallel",
                        description="Classify the behaviour of the free slider (docs/model.md §8) at every point of a grid "
                                    "(default: the paper's map, f_ex 100:130:2 Hz, a_ex 4:16:2 m/s², s0 0.3, 120 s). "
                                    "Each finished point is appended to DIR/map.jsonl at once; --resume skips the points "
                                    "already there (also of a map started by beamslider-batch map). Writes map.toml, "
                                    "map.txt (letter table) and map.png (the categorical map, like the paper's Fig. 11; one panel per s0, "
                                    "points whose behaviour changes with s0 outlined).")
    sp.add_argument("--config", metavar="TOML", help="map configuration as read by beamslider-batch map --config")
    sp.add_argument("--f-ex", metavar="GRID", help="frequencies: START:STOP:STEP or a comma list (100:130:2)")
    sp.add_argument("--a-ex", metavar="GRID", help="levels: START:STOP:STEP or a comma list (4:16:2)")
    sp.add_argument("--s0", metavar="GRID", help="initial slider positions (0.3)")
    sp.add_argument("--t-end", type=_positive(float), metavar="S", help="simulated time per point [s] (120)")
    sp.add_argument("--threads", "-j", type=_positive(int), metavar="N", help="worker threads (default: one per core)")
    sp.add_argument("--resume", action="store_true", help="continue the map in --out, skipping finished points")
    sp.add_argument("--extend-to", type=_positive(float), metavar="T",
                    help="extend the map in --out to T seconds: continue its not-settled points from their saved end "
                         "states (bitwise the T-second runs), keep the settled ones; prints the number re-run")
    sp.add_argument("--print-config", action="store_true", help="print the map configuration (TOML) and exit")
    sp.add_argument("--scheduler", metavar="ADDRESS",
                    help="run the points on a Dask cluster: scheduler address, e.g. tcp://host:8786 (docs/cluster.md)")
    sp.add_argument("--scheduler-file", metavar="FILE", help="run on the Dask cluster of this scheduler file "
                    "(dask scheduler --scheduler-file FILE)")
    sp.add_argument("--chunk-size", type=_positive(int), default=8, metavar="N", help="points per Dask task (8)")
    _common(sp, window=False)
    sp.set_defaults(func=cmd_map)

    sp = sub.add_parser("plot", help="re-plot results written by simulate/compare/manifold, or a measurement",
                        description="Plot a result written earlier (its .csv or .json) and/or a measurement file.")
    sp.add_argument("result", nargs="?", help="a <stem>.csv or <stem>.json written by beamslider")
    sp.add_argument("--manifold", metavar="CSV", help="manifold CSV to overlay")
    sp.add_argument("--measurement", metavar="FILE", help="measured file to overlay")
    _common(sp, model_options=False)
    _force_option(sp)
    sp.set_defaults(func=cmd_plot)

    from . import cli_discover, cli_enma, cli_superslow
    cli_enma.add_parser(sub, _common, _positive)
    cli_superslow.add_parser(sub, _common, _positive)
    cli_discover.add_parsers(sub, _common, _positive)

    from .study import add_cli as add_study_cli  # beamslider study (uncertainty studies, local or Dask)
    add_study_cli(sub, _common)
    return ap


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point of the ``beamslider`` console script."""
    args = build_parser().parse_args(argv)
    warnings.simplefilter("ignore", RuntimeWarning)  # run faults are reported by the commands
    try:
        return args.func(args)
    except KeyboardInterrupt:
        print("beamslider: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (UserError, ValueError, OverflowError, _core.SimulationError) as e:
        print(f"beamslider: error: {one_line(e)}", file=sys.stderr)
        return EXIT_ERROR
    except PlotDependencyError as e:
        print(f"beamslider: error: {e}", file=sys.stderr)
        return EXIT_ERROR
    except OSError as e:
        where = f"{e.filename}: " if getattr(e, "filename", None) else ""
        print(f"beamslider: error: {where}{e.strerror or e}", file=sys.stderr)
        return EXIT_ERROR


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


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
