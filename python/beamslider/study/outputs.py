"""The files a finished study writes (summary, figures) and the example configuration that
``beamslider study --print-config`` prints."""

from __future__ import annotations

import json
from pathlib import Path
from typing import List, Union


from .config import StudyConfig, Uncertain
from .plots import plot_behaviour_probability, plot_sensitivity
from .statistics import StudyResult


EXAMPLE_CONFIG = StudyConfig(
    uncertain=[Uncertain("friction_coefficient", "uniform", low=0.22, high=0.31),
               Uncertain("natural_frequency_factor", "uniform", low=0.95, high=1.05)],
    method="lhs", samples=16, seed=1)


def write_outputs(result: StudyResult, out: Union[str, Path]) -> List[Path]:
    """Write summary.json, summary.txt, behaviour_probability.png (per s0) and sensitivity.png (per
    operating point) into ``out``; returns the paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "summary.json", out / "summary.txt"]
    paths[0].write_text(json.dumps(result.summary_dict(), indent=1) + "\n", encoding="utf-8")
    paths[1].write_text(result.text(), encoding="utf-8")
    s0s = sorted({p.s0 for p in result.points})
    for s0 in s0s:
        p = out / ("behaviour_probability.png" if len(s0s) == 1 else f"behaviour_probability_s0_{s0:g}.png")
        plot_behaviour_probability(result, s0=s0, path=p)
        paths.append(p)
    n = len(result.points)
    for j in range(n if n <= 12 else 0):
        p = out / ("sensitivity.png" if n == 1 else f"sensitivity_{j}.png")
        plot_sensitivity(result, point=j, path=p)
        paths.append(p)
    return paths
