"""The super-slow manifold options shared by ``simulate``, ``compare`` and ``manifold``
(--manifold-periods/-record/-s) and the manifold run they ask for (docs/model.md §6)."""

from __future__ import annotations

import argparse
from typing import Optional

import numpy as np

from ..params import Parameters
from ..simulate import ManifoldResult, super_slow_manifold
from ._common import UserError, add_common, add_force, axis_values, out_dir, positive
from ._files import DEFAULT_MANIFOLD_RECORD, manifold_file_stem, write_manifold_csv


def add_manifold_options(sp: argparse.ArgumentParser, *, default_on: bool) -> None:
    """--manifold-periods, --manifold-record, --manifold-s (and --no-manifold if ``default_on``)."""
    if default_on:
        sp.add_argument("--no-manifold", dest="manifold", action="store_false",
                        help="skip the PCS manifold of panel (c)")
    sp.add_argument("--manifold-periods", type=positive(int), default=100, metavar="N",
                    help="excitation periods per s-step, i.e. simulated at each slider position (default 100, "
                         "paper 300); part of the manifold's file name")
    sp.add_argument("--manifold-record", type=positive(int), default=DEFAULT_MANIFOLD_RECORD, metavar="N",
                    help="periods averaged at each slider position (default 25)")
    sp.add_argument("--manifold-s", metavar="GRID",
                    help="slider positions: START:STOP:STEP or a comma list (default B/(2L)..0.5 by 0.005)")


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
    add_common(sp)
    add_force(sp)
    add_manifold_options(sp, default_on=True)


def grid(args: argparse.Namespace) -> Optional[np.ndarray]:
    """The slider positions of --manifold-s (None: the default grid)."""
    if args.manifold_s is None:
        return None
    return np.array(axis_values("--manifold-s", args.manifold_s, what="a comma-separated list of s"))


def manifold_name(args: argparse.Namespace, f_ex: float, a_ex: float) -> str:
    """Stem of the manifold files this command line will write."""
    return manifold_file_stem(f_ex, a_ex, args.manifold_periods, args.manifold_record, grid(args))


def check_manifold_args(args: argparse.Namespace) -> None:
    """--manifold-record must not exceed --manifold-periods."""
    if args.manifold_record > args.manifold_periods:
        raise UserError(f"--manifold-record {args.manifold_record}: must not exceed --manifold-periods "
                        f"({args.manifold_periods})")


def run_manifold(args: argparse.Namespace, p: Parameters, f_ex: float, a_ex: float, stop=None) -> ManifoldResult:
    """Compute the manifold of the command line and write its CSV into --out (``stop``: a
    ``threading.Event`` that stops a manifold run in a background thread)."""
    m = super_slow_manifold(p, f_ex=f_ex, a_ex=a_ex, s=grid(args), periods=args.manifold_periods,
                            record=args.manifold_record, progress=args.progress, _stop=stop)
    write_manifold_csv(out_dir(args) / f"{manifold_name(args, f_ex, a_ex)}.csv", m)
    return m
