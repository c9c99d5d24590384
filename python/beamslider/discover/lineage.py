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

RUNS: Dict[str, Tuple[str, str]] = {}
"""Run-making code: new digest -> (the digest it takes over, how the runs were checked equal)."""

JUDGES: Dict[str, Tuple[str, str]] = {}
"""Judging code: new digest -> (the digest it takes over, how the rows were checked equal)."""


def accepted(digest: str, table: Dict[str, Tuple[str, str]]) -> FrozenSet[str]:
    """``digest`` and every digest it takes over, following ``table`` back (:data:`RUNS`, :data:`JUDGES`)."""
    out = {digest}
    while digest in table and table[digest][0] not in out:
        digest = table[digest][0]
        out.add(digest)
    return frozenset(out)
