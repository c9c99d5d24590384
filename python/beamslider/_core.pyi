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
