"""Property-based fuzzing (hypothesis) of the input-file readers a user hands to beamslider: drift
laws and design laws (``beamslider.superslow.load_law``), map configurations (the core's
``map_config``) and map results (``beamslider.maps.read_map``), study configurations
(``StudyConfig.from_toml``) and design configurations (``DesignConfig.from_toml``).

Each case starts from a valid seed file in scripts/tooling/fuzz_seeds/ and changes it: keys
deleted, values replaced by other kinds (numbers huge, tiny, negative, non-finite, strings, lists,
tables), unknown keys added, or the text itself mutated (bytes flipped, cut, repeated). A reader
must return or raise a ``ValueError`` on one line that names the file; another exception class,
a Rust panic or a case slower than ``--case-timeout`` seconds is a finding (saved under
``--findings``). Deterministic for a given ``--seed``.

    python scripts/tooling/fuzz_inputs.py --examples 10000 [--seed 1] [--only law,map_config]

tests/test_hardening.py runs the same properties with a few hundred cases each.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable, Dict, List

SEEDS = Path(__file__).resolve().parent / "fuzz_seeds"


class CaseTimeout(Exception):
    """A reader took longer than the case timeout (a hang)."""


def _values(st):
    """Replacement values: every kind a JSON or TOML file can hold, the awkward numbers first."""
    nums = st.sampled_from([0, -1, 1, 2**31, 2**63 - 1, -(2**63), 10**30, 1e300, -1e300, 5e-324, 1e-300,
                            float("nan"), float("inf"), float("-inf"), 0.5, 100000000, True, False])
    scalars = st.one_of(nums, st.integers(), st.floats(), st.text(max_size=12))
    return st.one_of(scalars, st.lists(scalars, max_size=4), st.dictionaries(st.text(max_size=6), scalars, max_size=3))


def _paths(obj: Any, prefix=()) -> List[tuple]:
    out = [prefix]
    if isinstance(obj, dict):
        for k, v in obj.items():
            out.extend(_paths(v, prefix + (k,)))
    elif isinstance(obj, list):
        for i, v in enumerate(obj[:6]):
            out.extend(_paths(v, prefix + (i,)))
    return out


def _mutate_tree(data, obj: Any, st) -> Any:
    obj = json.loads(json.dumps(obj))
    for _ in range(data.draw(st.integers(1, 4), label="ops")):
        paths = [p for p in _paths(obj) if p]
        if not paths:
            break
        path = data.draw(st.sampled_from(paths), label="path")
        parent = obj
        for k in path[:-1]:
            parent = parent[k]
        op = data.draw(st.sampled_from(["delete", "replace", "add"]), label="op")
        if op == "delete":
            del parent[path[-1]]
        elif op == "replace":
            parent[path[-1]] = data.draw(_values(st), label="value")
        elif isinstance(parent, dict):
            parent[data.draw(st.text(min_size=1, max_size=8), label="key")] = data.draw(_values(st), label="value")
        else:
            parent.append(data.draw(_values(st), label="value"))
    return obj


def _mutate_bytes(data, text: bytes, st) -> bytes:
    v = bytearray(text)
    for _ in range(data.draw(st.integers(1, 4), label="byte ops")):
        pos = data.draw(st.integers(0, len(v)), label="pos")
        op = data.draw(st.integers(0, 3), label="byte op")
        if op == 0 and v:
            v[min(pos, len(v) - 1)] ^= 1 << data.draw(st.integers(0, 7))
        elif op == 1:
            del v[pos:]
        elif op == 2:
            v[pos:pos] = data.draw(st.sampled_from([b"nan", b"1e400", b"-1", b"\xff", b"\x00", b"[", b"{", b"\"",
                                                     b"=", b"\n", b"[[x]]\n", b"1" * 400, b"[" * 3000]))
        else:
            v[pos:pos] = v[max(0, pos - 50):pos]
    return bytes(v)


def _toml_dump(obj: Any) -> bytes:
    from beamslider import _toml

    try:
        return _toml.dumps(obj).encode()
    except (TypeError, ValueError):  # tomli-w cannot write it (e.g. an empty key): a text mutation instead
        return b""


def targets() -> Dict[str, tuple]:
    """name -> (seed text, parse the seed, serialise a tree, read a file and check what it gave)."""
    import beamslider
    from beamslider import _core, _toml
    from beamslider.design.config import DesignConfig
    from beamslider.maps import read_map
    from beamslider.study import StudyConfig
    from beamslider.superslow import load_law

    def read_map_config(path: Path) -> None:
        try:
            text = path.read_bytes().decode("utf-8")
        except UnicodeDecodeError:
            return
        _core.MapConfig(text)

    def read_results(path: Path) -> None:
        read_map(path)

    def jsonl_load(text: bytes) -> Any:
        return [json.loads(ln) for ln in text.decode().splitlines() if ln.strip()]

    def jsonl_dump(rows: Any) -> bytes:
        if not isinstance(rows, list):
            return json.dumps(rows).encode() + b"\n"
        return b"".join(json.dumps(r).encode() + b"\n" for r in rows)

    read_json = lambda t: json.loads(t)  # noqa: E731
    dump_json = lambda o: json.dumps(o).encode()  # noqa: E731
    read_toml = lambda t: _toml.loads(t.decode())  # noqa: E731
    del beamslider
    return {
        "law": ((SEEDS / "law.json").read_bytes(), read_json, dump_json, load_law),
        "design_law": ((SEEDS / "design_law.json").read_bytes(), read_json, dump_json, load_law),
        "map_config": ((SEEDS / "map.toml").read_bytes(), read_toml, _toml_dump, read_map_config),
        "map_results": ((SEEDS / "map.jsonl").read_bytes(), jsonl_load, jsonl_dump, read_results),
        "study": ((SEEDS / "study.toml").read_bytes(), read_toml, _toml_dump, StudyConfig.from_toml),
        "design": ((SEEDS / "design.toml").read_bytes(), read_toml, _toml_dump, DesignConfig.from_toml),
    }


def check_case(name: str, reader: Callable[[Path], Any], path: Path, case_timeout: float) -> None:
    """Run ``reader(path)``: a ValueError on one line naming the file, or a result; else raise."""
    def alarm(*_):
        raise CaseTimeout(f"{name}: no answer within {case_timeout:g} s")

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, case_timeout)
    try:
        reader(path)
    except ValueError as e:
        msg = str(e)
        if name not in ("map_config",) and str(path) not in msg and path.name not in msg:
            raise AssertionError(f"{name}: the message does not name the file: {msg[:200]}") from None
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def fuzz(name: str, examples: int, seed: int, tmp: Path, case_timeout: float = 20.0,
         on_finding: Callable[[bytes, BaseException], None] = None) -> int:
    """Run ``examples`` cases against reader ``name``; returns the count run (raises on a finding
    when ``on_finding`` is None)."""
    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import seed as hseed
    from hypothesis import strategies as st

    text, parse, dump, reader = targets()[name]
    tree = parse(text)
    path = tmp / f"input-{name}{''.join(Path(str(SEEDS / name)).suffixes) or '.txt'}"
    count = [0]

    @hseed(seed)
    @settings(max_examples=examples, deadline=None, database=None, derandomize=False,
              suppress_health_check=list(HealthCheck), phases=(Phase.generate,))
    @given(st.data())
    def case(data):
        if data.draw(st.booleans(), label="tree"):
            blob = dump(_mutate_tree(data, tree, st)) or text
        else:
            blob = _mutate_bytes(data, text, st)
        path.write_bytes(blob)
        count[0] += 1
        try:
            check_case(name, reader, path, case_timeout)
        except BaseException as e:  # noqa: BLE001 - everything else (a panic too) is a finding
            if isinstance(e, KeyboardInterrupt) or on_finding is None:
                raise
            on_finding(blob, e)

    case()
    return count[0]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", type=int, default=10000, help="cases per reader (10000)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--only", default="", help="comma list of readers (default: all)")
    ap.add_argument("--case-timeout", type=float, default=20.0)
    ap.add_argument("--findings", default="fuzz-findings")
    args = ap.parse_args(argv)
    names = [n for n in args.only.split(",") if n] or list(targets())
    findings: List[tuple] = []
    counts = {}
    with tempfile.TemporaryDirectory() as d:
        for name in names:
            t0 = time.monotonic()

            def found(blob: bytes, e: BaseException, name=name) -> None:
                out = Path(args.findings)
                out.mkdir(parents=True, exist_ok=True)
                saved = out / f"{name}-{len(findings)}.bin"
                saved.write_bytes(blob)
                what = f"{type(e).__name__}: {e}".splitlines()[0][:200] if str(e) else type(e).__name__
                findings.append((name, what, saved))
                print(f"finding in {name}: {what} (input saved to {saved})", file=sys.stderr)

            counts[name] = fuzz(name, args.examples, args.seed, Path(d), args.case_timeout, found)
            print(f"{name}: {counts[name]} cases in {time.monotonic() - t0:.1f} s", flush=True)
    print(f"fuzz_inputs.py (seed {args.seed}): " + ", ".join(f"{k} {v}" for k, v in counts.items())
          + f"; {len(findings)} findings")
    return 1 if findings else 0


if __name__ == "__main__":
    os.environ.setdefault("MPLBACKEND", "Agg")
    sys.exit(main())
