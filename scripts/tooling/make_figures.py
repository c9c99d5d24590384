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


def discover_parts() -> None:
    """The discrepancy guide's picture of a discover's three parts (docs/model.md §9): the problem, a
    search strategy and the rule, with the options that tune them and the report that reads the
    verdict; an SVG written as text (no plotting library, the same bytes on every machine)."""
    boxes = [  # x, y, width, title, lines, fill
        (20, 120, 250, "Problem", ["problem.py, built once:", "measured features and their", "uncertainties; the level;",
                                   "the baseline, its ensemble", "and its test; the candidates"], "#e8f0fb"),
        (310, 120, 260, "Search strategy", ["search/: tiered | full | fast", "(beam, joint by level);",
                                            "search(problem, candidates,", "options) -> fits"], "#eaf6ea"),
        (610, 120, 260, "Rule", ["rule.py: decide(problem, fits)", "-> Verdict: Kind (none, named,", "confounded, unexplained),",
                                 "Because, named set, group,", "reasons, advice"], "#fbefe3"),
        (910, 120, 220, "Report", ["report.json (judgment,", "options), report.md,", "gap.png, the CLI's", "verdict line"],
         "#f3f3f3"),
    ]
    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="1150" height="300" viewBox="0 0 1150 300" '
           'font-family="DejaVu Sans, Arial, sans-serif" font-size="13">',
           '<defs><marker id="a" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="7" markerHeight="7" '
           'orient="auto"><path d="M0,0 L10,5 L0,10 z" fill="#333"/></marker></defs>',
           '<rect x="375" y="14" width="400" height="52" rx="6" fill="#fffbe0" stroke="#b59f00"/>',
           '<text x="575" y="36" text-anchor="middle" font-weight="bold">DiscoverOptions (options.py)</text>',
           '<text x="575" y="55" text-anchor="middle">every tuning value, frozen; discover(options=...)</text>']
    for x, y, w, title, lines, fill in boxes:
        h = 40 + 18 * len(lines)
        out.append(f'<rect x="{x}" y="{y}" width="{w}" height="{h}" rx="8" fill="{fill}" stroke="#555"/>')
        out.append(f'<text x="{x + w / 2:g}" y="{y + 24}" text-anchor="middle" font-weight="bold">{title}</text>')
        out += [f'<text x="{x + 12}" y="{y + 46 + 18 * i}">{s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")}</text>'
                for i, s in enumerate(lines)]
    for x0, x1 in ((270, 310), (570, 610), (870, 910)):
        out.append(f'<line x1="{x0}" y1="175" x2="{x1 - 2}" y2="175" stroke="#333" stroke-width="2" marker-end="url(#a)"/>')
    for x in (145, 440, 740):
        out.append(f'<line x1="575" y1="66" x2="{x}" y2="118" stroke="#b59f00" stroke-dasharray="5,4" marker-end="url(#a)"/>')
    out.append('<text x="440" y="285" text-anchor="middle" fill="#333">a strategy asks the rule only whether to go on '
               '(no set can win; the tier\'s gate)</text>')
    out.append("</svg>")
    path = ROOT / "docs" / "figures" / "discover_parts.svg"
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    print(f"wrote {path.relative_to(ROOT)}")


FIGURES = {
    "signature_move": (signature_move, "docs/figures/signature_move.png: scripts/tooling/make_readme_figures.py (a 60-s run, PCS manifold)"),
    "maps": (maps, "docs/results/operating_map.png, operating_map_s0.4.png, start_position_pair.png: redrawn from the committed map rows"),
    "study": (study, "docs/results/study/map/behaviour_probability.png, study/sobol/sensitivity.png: redrawn from the committed study rows"),
    "enma": (enma, "docs/results/enma/enma.png: beamslider enma --noise-frequency 0.002 --repeats 2 --out docs/results/enma"),
    "discover": (discover, "docs/results/discover/gap.png: beamslider discover --out docs/results/discover"),
    "discover_parts": (discover_parts, "docs/figures/discover_parts.svg: the discrepancy guide's picture of a discover's "
                                       "three parts (drawn as text)"),
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
