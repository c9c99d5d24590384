"""The operating map by the predictor (docs/model.md §8 with §6.3–6.5): the reduced model at every
point of a grid, in the results format of the free-slider maps and written by the same core writer
(core ``superslow::predicted_map``). The predictor uses the maps' format and writer, never the
other way round: :mod:`beamslider.maps` knows no predictor."""

from __future__ import annotations

import dataclasses
import json
import os
import warnings
from pathlib import Path
from typing import Optional, Sequence, Union

from .. import _core
from ..params import Parameters, native, resolve
from ..tables import RowList
from .design_law import BUILTIN_LAW_NOTE, DesignLaw, default_law
from .law import DriftLaw

__all__ = ["predicted_map"]


def predicted_map(
    params: Optional[Parameters] = None,
    *,
    drift: Union[DriftLaw, DesignLaw, None] = None,
    f_ex: Sequence[float],
    a_ex: Sequence[float],
    s0: float = 0.3,
    t_end: float = 120.0,
    s_dn: str = "law",
    d_eff: Optional[float] = None,
    n_modes: int = 5,
    out: Union[str, os.PathLike, None] = None,
    force: bool = False,
    resume: bool = False,
    threads: Optional[int] = None,
) -> RowList:
    """An operating map by the reduced predictor (docs/model.md §8) with a fitted law (b2): one row per
    (f_ex, a_ex) in the results format of the FS maps (``map.jsonl`` version 3; ``status`` is
    ``predicted``, counters are zero, no end state; extra keys ``events``, ``extrapolated``,
    ``s_dn_source``), as a :class:`~beamslider.tables.RowList` (a list of dicts with
    ``.to_pandas()``, ``.to_xarray()`` and ``.table()``).

    ``s_dn='law'`` (the default: the HB manifold's jump-down, else the law's, :meth:`DriftLaw.s_dn`)
    and ``'hb'`` (the HB manifold's own only) are computed by the core (manifold, law, slow flow and classifier
    in Rust, ``threads`` threads, the interpreter released, Ctrl-C stops it) and written by the
    core's map results writer, as ``beamslider-batch map --predictor``: with ``out`` (a folder) the
    rows go to ``out/map.jsonl`` with the predictor in its header; an existing file is refused
    (``FileExistsError``) unless ``force`` (replaced) or ``resume`` (its points are kept; it must
    hold the same law and settings). ``s_dn='none'``: no jump-down (the high branch runs to its
    end). ``drift``: a :class:`DriftLaw`, or a :class:`DesignLaw`
    blended for ``params`` (docs/model.md §6.5; a warning when they lie outside what it covers, and
    every row ``extrapolated``); None: the built-in design law (:func:`beamslider.superslow.default_law`)."""
    p = resolve(params)
    if s_dn not in ("hb", "law", "none"):
        raise ValueError(f"invalid parameter `s_dn` = {s_dn!r}: one of 'hb', 'law', 'none'")
    if drift is not None and not isinstance(drift, (DriftLaw, DesignLaw)):
        raise ValueError("invalid parameter `drift`: a fitted DriftLaw or DesignLaw (beamslider.superslow.load_law)")
    path = None
    if out is not None:
        path = Path(out) / "map.jsonl"
        if path.exists() and not (force or resume):
            raise FileExistsError(f"{path} exists: pass force=True to overwrite or resume=True to continue it")
        if path.exists() and force and not resume:
            path.unlink()
    cfg = _core.MapConfig.of(native(p), f_ex_hz=[float(v) for v in f_ex], a_ex_m_s2=[float(v) for v in a_ex], s0=[float(s0)],
                             duration_s=float(t_end))
    kw = dict(out=None if path is None else str(path), resume=bool(resume), threads=threads, n_modes=int(n_modes), d_eff=d_eff)
    if isinstance(drift, DriftLaw):
        law = drift if s_dn != "hb" else dataclasses.replace(drift, rho_c=0.0)
        rows, _ = _core.predicted_map(cfg, law.core(), s_dn="none" if s_dn == "none" else "law", **kw)
    else:
        rows, why = _core.predicted_map(cfg, (drift or default_law()).core(), s_dn=s_dn, **kw)
        if why:
            note = "; ".join(why)
            warnings.warn(BUILTIN_LAW_NOTE.format(why=note) if drift is None else "design outside the drift law's box: " + note,
                          stacklevel=2)
    return RowList(json.loads(r) for r in rows)

