"""The super-slow manifold options shared by ``simulate``, ``compare`` and ``manifold``
(--manifold hb|pcs|none, --manifold-periods/-record/-s) and the manifold run they ask for: the
harmonic-balance manifold by default (docs/model.md §6.4), the PCS one of docs/model.md §6 on request."""

from __future__ import annotations

import argparse
from typing import Any, Optional

import numpy as np

from ..params import Parameters
from ..simulate import ManifoldResult, super_slow_manifold
from ._common import UserError, add_common, axis_values, out_dir, positive
from ._files import (DEFAULT_MANIFOLD_RECORD, hb_manifold_file_stem, manifold_file_stem, write_hb_manifold_csv,
                     write_manifold_csv)


MANIFOLD_KINDS = ("hb", "pcs", "none")
"""What ``simulate`` and ``compare`` overlay on panel (c): the harmonic-balance manifold (docs/model.md §6.4
layer (a), milliseconds; the default), the PCS manifold by continuation (docs/model.md §6; about as
much CPU as the run itself), or nothing."""

PCS_DEFAULTS = {"manifold_periods": 100, "manifold_record": DEFAULT_MANIFOLD_RECORD, "manifold_s": None}


def add_manifold_options(sp: argparse.ArgumentParser, *, default_on: bool) -> None:
    """--manifold-periods, --manifold-record, --manifold-s (and, if ``default_on``, --manifold
    hb|pcs|none and --no-manifold; then the PCS options default to None until
    :func:`resolve_manifold` fills them in)."""
    if default_on:
        sp.add_argument("--manifold", dest="manifold_kind", choices=MANIFOLD_KINDS, default=None,
                        help="manifold overlaid on panel (c): hb = harmonic balance, N = 5 modes, slider rigidly "
                             "attached (milliseconds; the default), pcs = PCS continuation (docs/model.md §6; as long "
                             "as a run; implied by --manifold-periods/-record/-s), none")
        sp.add_argument("--no-manifold", dest="manifold_kind", action="store_const", const="none",
                        help="no manifold (the same as --manifold none)")
    sp.add_argument("--manifold-periods", type=positive(int), default=None if default_on else 100, metavar="N",
                    help="PCS manifold: excitation periods per s-step, i.e. simulated at each slider position "
                         "(default 100, paper 300); part of the manifold's file name")
    sp.add_argument("--manifold-record", type=positive(int), default=None if default_on else DEFAULT_MANIFOLD_RECORD,
                    metavar="N", help="PCS manifold: periods averaged at each slider position (default 25)")
    sp.add_argument("--manifold-s", metavar="GRID",
                    help="PCS manifold: slider positions: START:STOP:STEP or a comma list (default B/(2L)..0.5 by 0.005)")


def resolve_manifold(args: argparse.Namespace, a_ex: float) -> str:
    """The manifold kind of a ``simulate``/``compare`` command line (sets ``args.manifold_kind``,
    ``args.manifold`` and the PCS options' defaults): explicit --manifold, else ``pcs`` when a PCS
    option is given, else ``hb`` (``none`` for a_ex ≤ 0, where there is no forced response)."""
    given = [f"--{k.replace('_', '-')}" for k in PCS_DEFAULTS if getattr(args, k, None) is not None]
    kind = args.manifold_kind
    if kind is None:
        kind = "pcs" if given else ("hb" if a_ex > 0 else "none")
    elif given and kind != "pcs":
        raise UserError(f"{given[0]}: a PCS manifold option, but --manifold {kind} (use --manifold pcs)")
    if kind == "hb" and not a_ex > 0:
        raise UserError(f"--manifold hb: needs a_ex > 0 (got {a_ex:g})")
    for k, v in PCS_DEFAULTS.items():
        if getattr(args, k, None) is None:
            setattr(args, k, v)
    args.manifold_kind = kind
    args.manifold = kind != "none"
    return kind


def add_operating_point(sp: argparse.ArgumentParser, *, positive_level: bool = False) -> None:
    """--f-ex and --a-ex with the signature move's values as defaults (``positive_level``: a_ex > 0
    required, for the harmonic-balance and predictor commands)."""
    sp.add_argument("--f-ex", type=positive(float), default=124.0, metavar="HZ", help="excitation frequency (124)")
    sp.add_argument("--a-ex", type=positive(float) if positive_level else float, default=14.0, metavar="M_S2",
                    help="base acceleration amplitude (14)")


def add_run_options(sp: argparse.ArgumentParser) -> None:
    """What ``simulate`` and ``compare`` share after their own options: --record-every, the common
    options, --force and the manifold options (on by default)."""
    sp.add_argument("--record-every", type=positive(int), default=10, metavar="K", help="keep every K-th step (10)")
    add_common(sp, force=True)
    add_manifold_options(sp, default_on=True)


def grid(args: argparse.Namespace) -> Optional[np.ndarray]:
    """The slider positions of --manifold-s (None: the default grid)."""
    if args.manifold_s is None:
        return None
    return np.array(axis_values("--manifold-s", args.manifold_s, what="a comma-separated list of s"))


def manifold_name(args: argparse.Namespace, f_ex: float, a_ex: float) -> str:
    """Stem of the manifold files this command line will write."""
    if getattr(args, "manifold_kind", "pcs") == "hb":
        return hb_manifold_file_stem(f_ex, a_ex)
    return manifold_file_stem(f_ex, a_ex, args.manifold_periods, args.manifold_record, grid(args))


def check_manifold_args(args: argparse.Namespace) -> None:
    """--manifold-record must not exceed --manifold-periods."""
    if args.manifold_record > args.manifold_periods:
        raise UserError(f"--manifold-record {args.manifold_record}: must not exceed --manifold-periods "
                        f"({args.manifold_periods})")


def run_manifold(args: argparse.Namespace, p: Parameters, f_ex: float, a_ex: float, stop=None,
                 name: Optional[str] = None) -> Any:
    """Compute the manifold of the command line and write its CSV into --out (``stop``: a
    ``threading.Event`` that stops a PCS manifold run in a background thread; ``name``: the file's
    name, default the manifold's own). Returns the :class:`~beamslider.superslow.HbManifold`
    (``--manifold hb``) or the :class:`ManifoldResult`."""
    name = name or f"{manifold_name(args, f_ex, a_ex)}.csv"
    if getattr(args, "manifold_kind", "pcs") == "hb":
        from ..superslow import hb_manifold

        m = hb_manifold(p, f_ex=f_ex, a_ex=a_ex)
        write_hb_manifold_csv(out_dir(args) / name, m)
        return m
    m = super_slow_manifold(p, f_ex=f_ex, a_ex=a_ex, s=grid(args), periods=args.manifold_periods,
                            record=args.manifold_record, progress=args.progress, _stop=stop)
    write_manifold_csv(out_dir(args) / name, m)
    return m
