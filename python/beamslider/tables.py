"""Results as labelled tables (docs/model.md §8): a map is a grid over (f_ex, a_ex, s0), a study and
a design search are tables of samples. :class:`MapTable` (what :func:`beamslider.maps.read_map`
and :func:`beamslider.maps.operating_map` return) is the dict of numpy arrays it always was, with
:meth:`MapTable.to_pandas` (one row per point) and :meth:`MapTable.to_xarray` (a Dataset over the
dimensions ``f_ex_hz``, ``a_ex_m_s2``, ``s0``); :class:`RowList` is a list of rows (dicts) with the
same two conversions, :class:`SampleTable` a dict of columns with ``to_pandas``.

pandas and xarray are optional extras (``pip install 'beamslider[pandas]'``, ``'beamslider[xarray]'``):
a conversion without them raises an ``ImportError`` naming the extra.
"""

from __future__ import annotations

from typing import Any, Dict, List, Sequence

import numpy as np

__all__ = ["BEHAVIOURS", "DIMS", "MapTable", "RowList", "SampleTable", "require_pandas", "require_xarray", "rows_to_table"]


BEHAVIOURS = ("inactivity", "trivial_adaption", "signature_move", "relaxation_oscillation", "self_damping",
              "not_settled", "undetermined")
"""Behaviour names as written in results files (docs/model.md §8), in legend order."""


DIMS = ("f_ex_hz", "a_ex_m_s2", "s0")
"""The dimensions of a map's Dataset."""


def require_pandas(what: str) -> Any:
    """Import pandas, or an ``ImportError`` naming the extra that installs it."""
    try:
        import pandas
    except ImportError:
        raise ImportError(f"{what} needs pandas: pip install 'beamslider[pandas]'") from None
    return pandas


def require_xarray(what: str) -> Any:
    """Import xarray, or an ``ImportError`` naming the extra that installs it."""
    try:
        import xarray
    except ImportError:
        raise ImportError(f"{what} needs xarray: pip install 'beamslider[xarray]'") from None
    return xarray


def _columns(table: Dict[str, np.ndarray]) -> Dict[str, Any]:
    """Columns for a DataFrame: 1-D arrays as they are, a 2-D array (the contact histogram) as a
    column of lists."""
    out: Dict[str, Any] = {}
    for k, v in table.items():
        v = np.asarray(v)
        out[k] = list(map(list, v)) if v.ndim == 2 else v
    return out


class SampleTable(dict):
    """A dict of equally long columns (numpy arrays), one entry per sample, with :meth:`to_pandas`."""

    def to_pandas(self) -> Any:
        """A pandas DataFrame, one row per sample (extra ``pandas``)."""
        pd = require_pandas(f"{type(self).__name__}.to_pandas")
        df = pd.DataFrame(_columns(self))
        if "behaviour" in df:
            df["behaviour"] = pd.Categorical(df["behaviour"], categories=list(BEHAVIOURS))
        return df


class MapTable(SampleTable):
    """The rows of an operating map as a dict of numpy arrays (:func:`beamslider.maps.rows_to_table`),
    one entry per grid point; :meth:`to_pandas` gives a DataFrame (``behaviour`` categorical, in
    the legend order of :data:`beamslider.maps.BEHAVIOURS`) and :meth:`to_xarray` a Dataset over
    the grid."""

    def to_xarray(self) -> Any:
        """An xarray Dataset with the dimensions ``f_ex_hz``, ``a_ex_m_s2`` and ``s0`` (extras
        ``xarray``, which brings pandas): every scalar column of the table is a variable on the grid
        (points not run are NaN, or empty strings); ``behaviour`` holds the names with the
        ordered categories in its ``categories`` attribute, and ``behaviour_code`` the same as
        codes (int8, −1 = not run) with the CF attributes ``flag_values`` / ``flag_meanings``, as
        NetCDF stores categories. Lists (the jump times, the contact histogram) are left out.
        Save it with ``ds.to_netcdf("map.nc")`` or ``ds.to_zarr("map.zarr")``."""
        xr = require_xarray("MapTable.to_xarray")
        keys = [k for k, v in self.items() if np.asarray(v).ndim == 1 and np.asarray(v).dtype != object]
        n = len(self.get("index", []))
        coords = {d: np.array(sorted(set(np.asarray(self[d], dtype=float).tolist())), dtype=float) for d in DIMS}
        shape = tuple(len(coords[d]) for d in DIMS)
        pos = tuple(np.searchsorted(coords[d], np.asarray(self[d], dtype=float)) for d in DIMS)
        data = {}
        for k in keys:
            if k in DIMS:
                continue
            v = np.asarray(self[k])
            if v.dtype.kind in "US":
                grid = np.full(shape, "", dtype=v.dtype if n else "<U1")
            elif v.dtype.kind == "b":
                grid = np.zeros(shape, dtype=bool)
            elif v.dtype.kind in "iu":
                grid = np.full(shape, -1, dtype=np.int64)
            else:
                grid = np.full(shape, np.nan)
            grid[pos] = v
            data[k] = (DIMS, grid)
        codes = np.full(shape, -1, dtype=np.int8)
        names = np.asarray(self.get("behaviour", np.array([], dtype=str)))
        codes[pos] = np.array([BEHAVIOURS.index(b) if b in BEHAVIOURS else -1 for b in names.tolist()], dtype=np.int8)
        data["behaviour_code"] = (DIMS, codes, {"flag_values": np.arange(len(BEHAVIOURS), dtype=np.int8),
                                                "flag_meanings": " ".join(BEHAVIOURS),
                                                "long_name": "behaviour (docs/model.md section 8); -1: not run"})
        ds = xr.Dataset(data, coords=coords)
        if "behaviour" in ds:
            ds["behaviour"].attrs["categories"] = " ".join(BEHAVIOURS)
        if "has_end_state" in ds:  # a boolean that is False where no point was run
            ds["has_end_state"].attrs["note"] = "False where no point was run"
        ds["f_ex_hz"].attrs["units"] = "Hz"
        ds["a_ex_m_s2"].attrs["units"] = "m/s^2"
        ds["s0"].attrs["units"] = "L"
        return ds


class RowList(list):
    """A list of result rows (dicts as in the results file) with the conversions of
    :class:`MapTable` (:meth:`table`, :meth:`to_pandas`, :meth:`to_xarray`)."""

    def table(self) -> MapTable:
        """The rows as a :class:`MapTable`."""
        return rows_to_table(list(self))

    def to_pandas(self) -> Any:
        """A pandas DataFrame, one row per point (see :meth:`MapTable.to_pandas`)."""
        return self.table().to_pandas()

    def to_xarray(self) -> Any:
        """An xarray Dataset over the grid (see :meth:`MapTable.to_xarray`)."""
        return self.table().to_xarray()


def records_frame(records: List[Dict[str, Any]], what: str) -> Any:
    """A DataFrame of JSON records, nested dicts flattened to ``a.b`` columns (extra ``pandas``)."""
    pd = require_pandas(what)
    return pd.json_normalize(records, sep=".")


_SCALARS = ("index", "f_ex_hz", "a_ex_m_s2", "s0", "t_end_s", "s_final", "amplitude_final_h", "amplitude_initial_h",
            "amplitude_max_h", "s_min", "s_max", "net_travel", "travel_to_centre", "turn_s", "turn_t_s",
            "drift_s", "drift_a_h", "wall_time_s")


def _settled(r: Dict[str, Any]) -> bool:
    """A row's ``settled`` flag; a row without it (format version 2, not read by the core) is
    settled when steady, a relaxation oscillation counts as settled (docs/model.md §8)."""
    if "settled" in r:
        return bool(r["settled"])
    if r.get("behaviour") == "not_settled":
        return False
    return bool(r.get("steady")) or r.get("behaviour") == "relaxation_oscillation"


def rows_to_table(rows: Sequence[Dict[str, Any]]) -> MapTable:
    """Map rows (dicts as in the results file) as a :class:`~beamslider.tables.MapTable` (a dict of
    numpy arrays with ``to_pandas()`` and ``to_xarray()``): the scalar features (float; NaN for a
    missing turning point or drift), ``behaviour``, ``reason``, ``status``, ``phase`` (str),
    ``has_end_state`` (bool: the run can be continued by ``extend_to``), ``steady`` and
    ``settled`` (bool: the behaviour is final; false while the run still creeps, docs/model.md
    §8), ``drift_s`` / ``drift_a_h`` (change of s and A over the final drift window),
    ``jump_up_t_s``/``jump_down_t_s`` (object arrays of lists) and the solver counters as
    ``counters_<name>`` (int)."""
    rows = sorted(rows, key=lambda r: r["index"])
    out = MapTable()
    for k in _SCALARS:
        out[k] = np.array([np.nan if r.get(k) is None else r[k] for r in rows], dtype=float)
    out["index"] = out["index"].astype(int)
    for k in ("behaviour", "reason", "status", "phase"):
        out[k] = np.array([r.get(k, "") for r in rows], dtype=object).astype(str) if rows else np.array([], dtype=str)
    out["has_end_state"] = np.array(["end" in r for r in rows], dtype=bool)
    out["steady"] = np.array([bool(r["steady"]) for r in rows], dtype=bool)
    out["settled"] = np.array([_settled(r) for r in rows], dtype=bool)
    for k in ("jump_up_t_s", "jump_down_t_s"):
        arr = np.empty(len(rows), dtype=object)
        for i, r in enumerate(rows):
            arr[i] = list(r[k])
        out[k] = arr
    names = list(rows[0]["counters"]) if rows else []
    for n in names:
        if n == "closed_histogram":
            out["counters_closed_histogram"] = np.array([r["counters"][n] for r in rows], dtype=np.int64)
        else:
            out[f"counters_{n}"] = np.array([r["counters"][n] for r in rows], dtype=np.int64)
    return out
