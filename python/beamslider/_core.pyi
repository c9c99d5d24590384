"""Type stubs of the compiled core binding (private; use the ``beamslider`` package)."""

from os import PathLike
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

class SimulationError(Exception):
    """A simulation failed numerically."""

ParamDict = Dict[str, Union[float, int, str]]
Progress = Optional[Callable[[float, float], Any]]

class Params:
    """Validated model parameters (core ``params::Valid``); immutable."""

    def __init__(self, **values: Union[float, int, str]) -> None: ...
    @staticmethod
    def from_toml_file(path: Union[str, PathLike[str]], **overrides: Union[float, int, str]) -> "Params":
        """Read a TOML parameter file (missing keys: defaults), replace the fields ``overrides`` names
        (a command line's ``--dt``), then validate once."""
    @staticmethod
    def from_toml_text(text: str) -> "Params": ...
    def to_dict(self) -> ParamDict: ...
    def toml_text(self) -> str: ...
    @staticmethod
    def fields() -> List[Tuple[str, str, str, str, str]]: ...

def _validation_count() -> int: ...
def simulate(
    params: Params,
    *,
    f_ex_hz: float,
    a_ex_m_s2: float,
    s0: float,
    t_end_s: float,
    model: str,
    s_pcs: Optional[float] = None,
    record_every: int = 10,
    progress: Progress = None,
    out: Optional[str] = None,
    window_s: float = 1.0,
    columns: int = 2000,
    on_start: Optional[Callable[[], Any]] = None,
    check_only: bool = False,
) -> Optional[Dict[str, Any]]:
    """Integrate the FS / PCS / beam-only model (docs/model.md §5–6).

    Returns a dict with the recorded columns (numpy arrays keyed by ``t_s``, ``w_4L7_m``, ``s``,
    ``xC_m``, ``zC_m``, ``beta_rad``), ``status``, ``message``, ``counters``, ``final_state`` (dicts
    of the core's structs) and ``rows``. With ``out`` (a ``.npz`` or ``.csv`` path) the rows are
    streamed into that file instead (temporary name, renamed when the run ends; an interrupted run
    leaves nothing) and ``overview`` = ((t, w) or None, (t, s) or None: min/max decimation to
    ``columns`` pixel columns; super-slow (t0 [s], bin spacing [s], s per bin, amplitude/h per bin;
    ``window_s`` moving average) or None). ``on_start()`` is called once the inputs are checked,
    before the first step. ``check_only``: check the inputs as the run does before its first step,
    run nothing and return None.
    """
def recorded_rows(t_end_s: float, dt_s: float, record_every: int) -> int: ...
def physical_manifold_grid(params: Params) -> List[float]:
    """Default slider positions of the physical manifold sweep (docs/model.md §6): the reference
    grid s = 0, 0.005, …, 0.5 from the first s whose contact points lie on the beam.
    """
def super_slow_manifold(
    params: Params,
    *,
    f_ex_hz: float,
    a_ex_m_s2: float,
    s_values: Sequence[float],
    periods: int = 100,
    record_periods: int = 25,
    progress: Progress = None,
) -> Dict[str, Any]:
    """Super-slow manifold by PCS continuation (docs/model.md §6): the core's ``Manifold`` as a
    dict; ``progress(points_done, points_total)`` is called after every s.
    """
def moving_average(x: npt.NDArray[np.float64], window: int) -> npt.NDArray[np.float64]: ...
def envelope(
    x: npt.NDArray[np.float64], dt_s: float, window_s: float, *, block: Optional[int] = None, margin: int = 0
) -> npt.NDArray[np.float64]:
    """Envelope of docs/model.md §7: ``window_s`` moving average of |analytic signal| of samples
    spaced ``dt_s``; with ``block``, the analytic signal by overlapping FFT blocks (``margin``
    samples each side).
    """
def plain_numbers(text: str) -> Optional[npt.NDArray[np.float64]]:
    """The numbers of a measured file's text, separated by whitespace, commas or semicolons, in
    order (correctly rounded, as ``float``); None if a token is not a number."""
def classify(
    s: npt.NDArray[np.float64],
    amplitude_h: npt.NDArray[np.float64],
    dt_s: float,
    *,
    t0_s: float = 0.0,
    criteria: Optional[Dict[str, float]] = None,
) -> Dict[str, Any]:
    """Behaviour classification (docs/model.md §8) of super-slow signals sampled every ``dt_s``
    (slider position ``s``, amplitude ``amplitude_h``); ``criteria``: thresholds by the keys of the
    core's ``Criteria`` (missing keys take defaults). Returns the core's ``Classification`` as a dict.
    """
def super_slow_signals(
    w: npt.NDArray[np.float64], s: npt.NDArray[np.float64], dt_s: float, thickness_m: float, window_s: float
) -> Tuple[float, float, npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The super-slow signals a map point is classified from (core ``signal::envelope_stream``,
    docs/model.md §7) of w(4L/7) [m] and s sampled every ``dt_s``: (t0 of the first 0.2-s bin [s],
    bin spacing [s], s per bin, A per bin: ``window_s`` moving average of |analytic signal| / h).
    """
class MapConfig:
    """A map configuration (core ``MapConfig``), parsed and checked once."""

    def __init__(self, text: str) -> None: ...
    @staticmethod
    def default() -> "MapConfig": ...
    @staticmethod
    def of(params: Params, *, f_ex_hz: List[float], a_ex_m_s2: List[float], s0: List[float], duration_s: float,
           record_every: int = 20, dt_s: Optional[float] = None, criteria: Optional[Dict[str, float]] = None) -> "MapConfig":
        """A configuration from its parts, without TOML: the parameters ``params``, the grid's axes
        as lists, the duration [s], the recording interval, Δt [s] (None: the parameters') and the
        criteria (thresholds of the core's ``Criteria`` by name; None: defaults).
        """
    def toml(self) -> str: ...
    def with_duration(self, duration_s: float) -> "MapConfig":
        """This configuration for another duration (``--extend-to``), checked."""
    @property
    def duration_s(self) -> float: ...
    @property
    def axes(self) -> Tuple[List[float], List[float], List[float]]: ...
    def check(self, *, out: Optional[Union[str, PathLike[str]]] = None, resume: bool = False, extend: bool = False) -> None:
        """Check the map before anything is written: Δt and the results file ``out`` (exists without
        ``resume``, other settings; with ``extend``: the map to extend to the configuration's
        duration). Raises what ``MapRun`` would raise.
        """
class MapRun:
    def __init__(self, config: MapConfig, *, out: Optional[Union[str, PathLike[str]]] = None, resume: bool = False,
                 extend: bool = False) -> None: ...
    @property
    def done(self) -> int: ...
    def jobs(self) -> List[Tuple[int, Optional[str]]]: ...
    def append(self, rows: List[str]) -> int:
        """Append rows (JSON texts of ``run_map_chunk``) computed elsewhere; rows of points already in
        the results are skipped. Returns the number appended.
        """
    def run_local(self, *, threads: Optional[int] = None, progress: Optional[Callable[[int, int], Any]] = None) -> None:
        """Run the remaining jobs here on ``threads`` threads (default one per core), the interpreter
        released; ``progress(done, total)`` from the calling thread; Ctrl-C cancels (finished points
        stay in the file) and raises KeyboardInterrupt.
        """
    def finish(self) -> Tuple[List[str], int]:
        """Close the results (release the lock) and return (rows of the grid as JSON texts sorted by
        index, the number of continued points). KeyboardInterrupt when points are missing.
        """
    def close(self) -> None: ...
def run_map_chunk(config: MapConfig, jobs: List[Tuple[int, Optional[str]]], *, threads: int = 1) -> List[str]:
    """A Dask task of a map: run ``jobs`` (see ``MapRun.jobs``) of the map ``config`` on ``threads``
    rayon threads with the interpreter released; returns the rows as JSON texts sorted by grid
    index. Each row is bitwise the row the local runner writes (but ``wall_time_s``).
    """
class ResultsLock:
    def __init__(self, path: Union[str, PathLike[str]]) -> None:
        """The one-writer lock of a results file (``<path>.lock``), taken at once or
        ``BlockingIOError`` naming the folder and the holder's PID. ``release()`` or the end of a
        ``with`` block frees it (as does the end of the process).
        """
    def release(self) -> None: ...
    def __enter__(self) -> "ResultsLock": ...
    def __exit__(self, *args: Any) -> bool: ...
def hb_manifold(
    params: Params,
    *,
    f_ex_hz: float,
    a_ex_m_s2: float,
    n_modes: int = 5,
    harmonics: int = 1,
    d_eff: Optional[float] = None,
    omega1_factor: float = 1.0,
    s_values: Optional[Sequence[float]] = None,
    max_steps: int = 20000,
    max_step: float = 0.05,
    sample_on_grid: bool = False,
) -> Dict[str, Any]:
    """HB super-slow manifold (docs/model.md §6.4): the core's ``HbManifold`` as a dict (its
    fields); the keyword options are the fields of the core's ``HbOptions`` (``s_values`` for ``s``).
    """
def hb_closed_form_n1(
    params: Params,
    *,
    f_ex_hz: float,
    a_ex_m_s2: float,
    s_values: Sequence[float],
    d_eff: Optional[float] = None,
    omega1_factor: float = 1.0,
) -> Dict[str, Any]: ...
def hb_backbone(
    params: Params, amplitude_h: Sequence[float], s: Sequence[float], omega1_factor: float = 1.0
) -> List[float]: ...
def virtual_enma(params: Params, *, progress: Progress = None, **options: Any) -> Dict[str, Any]:
    """Virtual ENMA of the beam of ``params``; ``options`` are the fields of the core's
    ``EnmaOptions`` (missing ones take defaults). Returns the core's ``EnmaResult`` as a dict.
    """
def beam_properties(params: Params, x_over_l: Sequence[float] = ...) -> Dict[str, Any]:
    """Modal data of the linear beam (core ``Model::beam_properties``, docs/model.md §2 and §9) as
    a dict; ``phi`` holds φₘ at ``x_over_l`` (N rows).
    """
def backbone_omega2(omega2: float, b: float, amplitude: List[float], m1: float) -> List[float]:
    """Squared backbone frequencies (ω² + ¾ b a²)/M₁ at the amplitudes a (core ``enma::backbone_omega2``)."""

def plausibility_findings(params: Params) -> List[Tuple[str, float, str]]:
    """Every implausible value of ``params`` (core ``plausibility::findings``, docs/model.md §1
    "Units and plausibility") as (field, value, why), also when the override
    (``PLAUSIBILITY_OVERRIDE_ENV``) lets them through validation.
    """

PLAUSIBILITY_OVERRIDE_ENV: str
RESULTS_FORMAT_VERSION: int
MAX_AXIS_VALUES: int

def range_values(field: str, start: float, stop: float, step: float) -> List[float]:
    """The values of an inclusive range START:STOP:STEP (core ``map::Axis``: STOP included when
    within STEP/1000 of the grid, values rounded to 1e-9, at most a million); errors name ``field``.
    """
def run_study_chunk(
    config: MapConfig,
    points: Sequence[Tuple[int, Params, float, float, float, float]],
    *,
    threads: Optional[int] = None,
    on_rows: Optional[Callable[[List[str]], Any]] = None,
) -> List[str]:
    """Run a chunk of study points in parallel (``threads`` workers, default one per core) with the
    interpreter released. ``config`` is a map configuration (record_every, dt_s, criteria; its grid
    and parameters are not used); each point brings its own validated parameters (not validated
    again unless the configuration's ``dt_s`` changes their step), operating point and duration. Returns the rows as JSON texts (map row format, ``index`` = the point's index),
    sorted by index. ``on_rows(list_of_json)`` gets the rows finished since the last call (at most
    every 50 ms); Ctrl-C or an exception in ``on_rows`` cancels the chunk.
    """
def read_results_file(path: Union[str, PathLike[str]]) -> Tuple[Optional[str], List[str], int, bool]:
    """Read a results file (map or study): (header as JSON text or None, rows as JSON texts with
    all their keys, byte length of the complete part, whether the last line was truncated).
    """

class StudyResults:
    """The results of a study (core ``study::StudyResults``): appended, flushed, resumable."""

    def __init__(
        self,
        path: Optional[Union[str, PathLike[str]]],
        config: MapConfig,
        study: Dict[str, Any],
        points: Sequence[Dict[str, Any]],
        *,
        resume: bool = False,
    ) -> None:
        """The results of a study: the file ``path`` (None: in memory only), opened for the map
        configuration ``config``, the study configuration ``study`` (header) and the points
        ``points`` (a list of dicts: index, f_ex_hz, a_ex_m_s2, s0, sample, point, params);
        ``resume`` keeps the rows of an existing file of the same study.
        """
    def add(self, rows: Sequence[str]) -> None: ...
    def __contains__(self, index: int) -> bool: ...
    def __len__(self) -> int: ...
    def rows(self) -> List[str]: ...
    def close(self) -> None: ...
Branch = Tuple[Sequence[float], Sequence[float], Sequence[float]]

S_DN_MIN: float
LAW_MAX_K: int

class DriftLaw:
    """A drift law (core ``superslow::law::DriftLaw``), its file checked once (the core's reader)."""

    def __init__(self, law: Union[str, Dict[str, Any]]) -> None:
        """From a law file's content (a dict) or its JSON text."""
    def evaluate(self, *, high: bool, x: Sequence[Sequence[float]], lift_off: Sequence[float]) -> Tuple[List[float], List[bool]]: ...
    def monostable(self, x: Sequence[float]) -> bool: ...
def law_s_dn(s: Sequence[float], amplitude_h: Sequence[float], *, f_ex_hz: float, a_ex_m_s2: float, rho_c: float, s_p: float,
             thickness_m: float) -> Optional[float]: ...
def hb_features(
    params: Params, *, f_ex_hz: float, a_ex_m_s2: float, high: bool, s: Sequence[float], n_modes: int = 5, d_eff: Optional[float] = None
) -> List[Dict[str, float]]:
    """The features of docs/model.md §6.3 at ``s`` on one branch of the HB manifold (core
    ``law::features_at``): one dict per position."""
def predict(
    params: Params, *, f_ex_hz: float, a_ex_m_s2: float, s0: float, t_end_s: float, law: Optional[DriftLaw] = None,
    table: Optional[Tuple[Branch, Branch, Optional[float], Optional[float]]] = None, s_dn: str = "law", source: str = "hb",
    n_modes: int = 5, d_eff: Optional[float] = None, v_dead: float = 0.0, build_up_s: Optional[float] = None,
    build_up_drift: bool = True, robustness: bool = True
) -> Dict[str, Any]:
    """One operating point by the reduced model (docs/model.md §6.3, core ``predict::predict``), its
    drift a law (``DriftLaw``) or a PCS table ((low, high, s_up, s_dn)): the core's
    ``PointPrediction`` as a dict; the keyword options are the core's ``PredictArgs``.
    """
def predicted_map(
    config: MapConfig, law: Union[DriftLaw, DesignLaw], *, out: Union[str, PathLike[str], None] = None, resume: bool = False,
    threads: Optional[int] = None, n_modes: int = 5, d_eff: Optional[float] = None, s_dn: str = "law", progress: Progress = None
) -> Tuple[List[str], List[str]]:
    """A map predicted by the core (``map --predictor``; interpreter released, Ctrl-C stops it,
    ``progress(done, total)``) with a drift law or a design law (blended for the configuration's
    parameters; ``s_dn="hb"`` drops its learnt jump-down); the keyword options are the core's
    ``PredictArgs``. Returns (rows as JSON texts, why the design lies outside the design law).
    """

# Formats of the core (crates/beamslider-py/src/formats.rs).
_MapColumns = Tuple[List[float], List[float], List[float], List[float], List[str], List[str], List[bool]]

def manifold_csv(up_s: List[float], up_amplitude_m: List[float], down_s: List[float], down_amplitude_m: List[float]) -> str: ...
def map_text_table(columns: _MapColumns) -> Tuple[str, str]:
    """The letter table of a map and its "t_end = … s" text, from its columns (s0, f_ex, a_ex,
    t_end, status, behaviour, settled).
    """
def read_json_lines(path: Union[str, PathLike[str]], key: str, version: int) -> Tuple[List[str], int, bool]:
    """The complete lines of a JSON-lines results file whose header has ``key`` = ``version``, the
    byte length of the complete part and whether a torn last line was left out.
    """
def append_json_lines(path: Union[str, PathLike[str]], lines: List[str], good_len: Optional[int] = ...) -> None: ...

def design_coordinates(params: Params, base: Params) -> List[float]: ...

class DesignLaw:
    """A design law (core ``superslow::design_law::DesignLaw``), its file checked once."""

    def __init__(self, law: Union[str, Dict[str, Any]], source: str) -> None:
        """From a design-law file's JSON text or content (a dict); ``source`` names it in errors."""
    def law_for(self, params: Params) -> Tuple[Dict[str, Any], List[str]]:
        """The blended drift law of design ``params`` (a law file's content) and why the design
        lies outside the law."""

def run_free_slider_batch(
    jobs: Sequence[Tuple[Params, float, float, float, float]],
    *,
    record_every: int = 5,
    keep_every: int = 5,
    window_s: float = 1.0,
    detrend_s: Optional[float] = None,
    threads: Optional[int] = None,
    on_done: Optional[Callable[[int], Any]] = None,
) -> List[Dict[str, Any]]:
    """Free-slider jobs ``(params, f_ex_hz, a_ex_m_s2, s0, duration_s)`` reduced in the core.

    The core's ``signal::reduced`` keeps t, s and A = envelope(w, ``window_s``)/h every
    ``keep_every``-th of the samples recorded every ``record_every`` steps (with ``detrend_s``, w
    minus its moving average first); the jobs run in parallel on ``threads`` workers with the
    interpreter released. Returns one dict per job, in job order: ``t``, ``s``, ``amplitude_h``,
    ``status``, or ``error`` (the exception the job's core error converts to: ``ValueError``,
    ``SimulationError``, ...) and ``error_kind`` ("invalid" for a ``ValueError``, else "numerical"). ``on_done(n)`` gets the
    runs finished since the last call; Ctrl-C or an exception in it cancels the batch.
    """
def drift_table_pcs(
    params: Params,
    *,
    f_ex_hz: float,
    a_ex_m_s2: float,
    out: Optional[Union[str, PathLike[str]]] = None,
    resume: bool = False,
    progress: Progress = None,
    **options: Any,
) -> Tuple[Dict[str, Any], List[Dict[str, Any]], int]:
    """Drift table V(s, branch) from the PCS model (docs/model.md §6.4).

    ``options``: fields of the core's ``DriftOptions``. Returns (header, rows in production order,
    rows computed now) as dicts. Rows are appended to ``out`` as produced; ``resume``
    continues an existing file with the same settings. ``progress(done, total)`` is called from
    the calling thread; Ctrl-C stops both sweeps (rows written so far stay in the file) and raises
    KeyboardInterrupt.
    """
def read_drift_table(path: Union[str, PathLike[str]]) -> Tuple[Dict[str, Any], List[Dict[str, Any]]]:
    """Read a drift-table file (the core's one reader): (header, rows as dicts; a truncated last
    line is dropped)."""
