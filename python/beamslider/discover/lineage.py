"""Code versions whose kept results a later version takes over (docs/model.md §9.1, "Kept runs";
§9.2, "Files"). A kept run is reused only by the code that made it, and a benchmark's row only by
the judge that judged it; a change of the code that leaves them bitwise the same (a move, a rename,
a value made an option with its old default) would otherwise make every run again and judge every
row again. Such a change is entered here with the check that showed it (the runs remade by the new
code, the rows judged again: ``scripts/repro/discover_lineage.py``), and the new code takes over what
the old one kept. This file is in neither digest (:func:`.runstore.code_fingerprint`,
:func:`.benchmark.judge_fingerprint`), so that an entry does not change what it vouches for."""

from __future__ import annotations

from typing import Dict, FrozenSet, Tuple

RUNS: Dict[str, Tuple[str, str]] = {
    "d5ab6f2c52f505de": ("fdbb207e40a04d47", "the ensemble's shifts, the modes' levels and the features' reading made "
                         "options (DiscoverOptions): 60 runs of a benchmark of seed 1 and 30 of seed 2 made again, "
                         "bitwise (scripts/repro/discover_lineage.py runs --sample 60 --seed 1; --sample 30 --seed 2)"),
}
"""Run-making code: new digest -> (the digest it takes over, how the runs were checked equal)."""

JUDGES: Dict[str, Tuple[str, str]] = {
    "0d5ae9acb6841a68": ("6f5a7318c22c5c58", "the same change: 11 rows of the benchmark of seed 1 (cases 3, 5, 6, 8, 9, 15, "
                         "18, 22, 23, 26, 28: every kind, every verdict, an advised run) judged again, bitwise, no run "
                         "made anew (scripts/repro/discover_lineage.py judge)"),
    "a8b7c93db4a2c2bd": ("0d5ae9acb6841a68", "four docstrings of options.py reworded, no code: 4 rows of the benchmark of "
                         "seed 1 (cases 3, 5, 6, 26) judged again, bitwise, no run made anew "
                         "(scripts/repro/discover_lineage.py judge)"),
}
"""Judging code: new digest -> (the digest it takes over, how the rows were checked equal)."""


def accepted(digest: str, table: Dict[str, Tuple[str, str]]) -> FrozenSet[str]:
    """``digest`` and every digest it takes over, following ``table`` back (:data:`RUNS`, :data:`JUDGES`)."""
    out = {digest}
    while digest in table and table[digest][0] not in out:
        digest = table[digest][0]
        out.add(digest)
    return frozenset(out)
