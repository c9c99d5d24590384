"""Type stubs of the compiled core binding (private; use the ``beamslider`` package)."""

from os import PathLike
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

class SimulationError(Exception):
    """A simulation failed numerically."""

ParamDict = Dict[str, Union[float, int, str]]
Progress = Optional[Callable[[float, float], Any]]

def default_params() -> ParamDict: ...
def params_from_toml(text: str) -> ParamDict: ...
def read_params_file(path: Union[str, PathLike[str]]) -> ParamDict: ...
def canonical_toml(text: str) -> str: ...
def natural_frequencies(params_toml: str) -> List[float]: ...
def simulate(
    params_toml: str,
    *,
    f_ex_hz: float,
    a_ex_m_s2: float,
    s0: float,
    t_end_s: float,
    model: str,
    s_pcs: Optional[float] = None,
    record_every: int = 10,
    progress: Progress = None,
) -> Dict[str, Any]: ...
def physical_manifold_grid(params_toml: str) -> List[float]: ...
def super_slow_manifold(
    params_toml: str,
    *,
    f_ex_hz: float,
    a_ex_m_s2: float,
    s_values: Sequence[float],
    periods: int = 100,
    record_periods: int = 25,
    progress: Progress = None,
) -> Dict[str, Any]: ...
def hilbert_envelope(x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
def moving_average(x: npt.NDArray[np.float64], window: int) -> npt.NDArray[np.float64]: ...
def envelope(x: npt.NDArray[np.float64], dt_s: float, window_s: float) -> npt.NDArray[np.float64]: ...
def classify(
    s: npt.NDArray[np.float64],
    amplitude_h: npt.NDArray[np.float64],
    dt_s: float,
    *,
    t0_s: float = 0.0,
    criteria_toml: Optional[str] = None,
) -> str: ...
def super_slow_signals(
    w: npt.NDArray[np.float64], s: npt.NDArray[np.float64], dt_s: float, thickness_m: float, window_s: float
) -> Tuple[float, float, npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def default_map_config() -> str: ...
def map_config(text: str) -> Tuple[str, List[float], List[float], List[float]]: ...
def read_map_results(path: Union[str, PathLike[str]]) -> Tuple[Optional[str], List[str], bool]: ...
def check_map(
    config_toml: str, *, out: Optional[Union[str, PathLike[str]]] = None, resume: bool = False, extend: bool = False
) -> None: ...
def run_map(
    config_toml: str,
    *,
    out: Optional[Union[str, PathLike[str]]] = None,
    resume: bool = False,
    threads: Optional[int] = None,
    progress: Optional[Callable[[int, int], Any]] = None,
    extend: bool = False,
) -> Tuple[List[str], int]: ...
def hb_manifold(
    params_toml: str,
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
) -> Dict[str, Any]: ...
def hb_closed_form_n1(
    params_toml: str,
    *,
    f_ex_hz: float,
    a_ex_m_s2: float,
    s_values: Sequence[float],
    d_eff: Optional[float] = None,
    omega1_factor: float = 1.0,
) -> Dict[str, Any]: ...
def hb_backbone(
    params_toml: str, amplitude_h: Sequence[float], s: Sequence[float], omega1_factor: float = 1.0
) -> List[float]: ...
def virtual_enma(params_toml: str, options_json: str, progress: Progress = None) -> str: ...
def beam_properties(params_toml: str, x_over_l: Sequence[float] = ...) -> Dict[str, Any]: ...

RESULTS_FORMAT_VERSION: int
MAX_AXIS_VALUES: int

def range_values(field: str, start: float, stop: float, step: float) -> List[float]: ...
def map_settings_json(config_toml: str) -> str: ...
def run_study_chunk(
    config_toml: str,
    points: Sequence[Tuple[int, str, float, float, float, float]],
    *,
    threads: Optional[int] = None,
    on_rows: Optional[Callable[[List[str]], Any]] = None,
) -> List[str]: ...
def read_results_file(path: Union[str, PathLike[str]]) -> Tuple[Optional[str], List[str], int, bool]: ...

class StudyResults:
    """The results of a study (core ``study::StudyResults``): appended, flushed, resumable."""

    def __init__(
        self,
        path: Optional[Union[str, PathLike[str]]],
        config_toml: str,
        study_json: str,
        points: Sequence[Tuple[int, float, float, float, int, int, str]],
        *,
        resume: bool = False,
    ) -> None: ...
    def add(self, rows: Sequence[str]) -> None: ...
    def __contains__(self, index: int) -> bool: ...
    def __len__(self) -> int: ...
    def rows(self) -> List[str]: ...
    def close(self) -> None: ...
