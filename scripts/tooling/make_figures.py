#!/usr/bin/env python3
"""Regenerate every figure the documentation site shows (the gallery's are drawn by the site's
build itself).

    python scripts/tooling/make_figures.py              # all of them
    python scripts/tooling/make_figures.py --list       # what each is and how it is made
    python scripts/tooling/make_figures.py maps study   # some of them

Figures drawn from committed results (docs/results/: the operating maps' and the studies' rows)
are redrawn from those files in seconds; the others re-run what draws them: the main figure (a
60-s run and the PCS manifold, ~15 s), the ENMA and discover reports (~5 and ~10 s; their report
files are rewritten with the same numbers) and the predictor's validation figures
(`validate_superslow_b.py runs` and `map`, which re-run the FS runs and rewrite their tables;
minutes). Run from the repository root with the package installed with the extra `plot`.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "docs" / "results"


def signature_move() -> None:
    subprocess.run([sys.executable, str(ROOT / "scripts" / "tooling" / "make_readme_figures.py")], check=True)


def maps() -> None:
    from beamslider.maps import plot_operating_map, read_map, t_end_text

    tables = {0.3: read_map(RESULTS / "operating_map.jsonl"), 0.4: read_map(RESULTS / "operating_map_s0.4.jsonl")}
    plot_operating_map(tables[0.3], path=RESULTS / "operating_map.png")
    plot_operating_map(tables[0.4], path=RESULTS / "operating_map_s0.4.png")
    both = {k: np.concatenate([tables[0.3][k], tables[0.4][k]]) for k in tables[0.3]}
    plot_operating_map(both, path=RESULTS / "start_position_pair.png", mark_changes=True,
                       title=f"operating map from $s_0$ = 0.3 and 0.4, {t_end_text(both)} (outlined: "
                             f"behaviour changes with $s_0$)")
    print(f"wrote {RESULTS}/operating_map.png, operating_map_s0.4.png, start_position_pair.png")


def study() -> None:
    from beamslider.study import plot_behaviour_probability, plot_sensitivity, read_study

    res = read_study(RESULTS / "study" / "map")
    plot_behaviour_probability(res, path=RESULTS / "study" / "map" / "behaviour_probability.png")
    plot_sensitivity(read_study(RESULTS / "study" / "sobol"), path=RESULTS / "study" / "sobol" / "sensitivity.png")
    print(f"wrote {RESULTS}/study/map/behaviour_probability.png, study/sobol/sensitivity.png")


def enma() -> None:
    subprocess.run(["beamslider", "enma", "--noise-frequency", "0.002", "--repeats", "2", "--out",
                    str(RESULTS / "enma"), "--no-progress"], check=True)


def discover() -> None:
    subprocess.run(["beamslider", "discover", "--out", str(RESULTS / "discover")], check=True)


def predictor() -> None:
    for stage in ("runs", "map"):
        subprocess.run([sys.executable, str(ROOT / "scripts" / "repro" / "validate_superslow_b.py"), stage], check=True)


FIGURES = {
    "signature_move": (signature_move, "docs/figures/signature_move.png: scripts/tooling/make_readme_figures.py (a 60-s run, PCS manifold)"),
    "maps": (maps, "docs/results/operating_map.png, operating_map_s0.4.png, start_position_pair.png: redrawn from the committed map rows"),
    "study": (study, "docs/results/study/map/behaviour_probability.png, study/sobol/sensitivity.png: redrawn from the committed study rows"),
    "enma": (enma, "docs/results/enma/enma.png: beamslider enma --noise-frequency 0.002 --repeats 2 --out docs/results/enma"),
    "discover": (discover, "docs/results/discover/gap.png: beamslider discover --out docs/results/discover"),
    "predictor": (predictor, "docs/results/superslow/runs_predicted_vs_fs.png, map_predicted_vs_fs.png: "
                             "scripts/repro/validate_superslow_b.py runs, map (minutes)"),
}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", choices=[[], *FIGURES], metavar="NAME", help=f"some of: {', '.join(FIGURES)}")
    ap.add_argument("--list", action="store_true", help="list the figures and how each is made")
    args = ap.parse_args()
    if args.list:
        for name, (_, how) in FIGURES.items():
            print(f"{name:15s} {how}")
        return 0
    for name in args.names or FIGURES:
        FIGURES[name][0]()
    return 0


if __name__ == "__main__":
    sys.exit(main())
