"""Bounded-time random-mutation fuzzer of the Python file readers: the measured-file reader
``beamslider.read_measurement``, the parameter TOML reader ``Parameters.from_toml_text`` and the
readers behind ``beamslider plot`` (simulation CSV and manifold CSV of ``beamslider.cli``).

Each input is a valid seed file mutated a few times (bit flips, interesting tokens such as
``nan``, ``1e400``, ``-1``, separators and BOMs, deletions, duplications, truncation). A reader
must return a sane result or raise its documented error (``MeasurementFormatError`` /
``ValueError`` / ``cli.UserError``); anything else — another exception class, non-finite or
inconsistent arrays — is a finding, saved under ``--findings``.

    python3 scripts/tooling/fuzz_readers.py --seconds 60 [--seed 1] [--findings fuzz-findings]
"""

from __future__ import annotations

import argparse
import math
import random
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

import beamslider
from beamslider import MeasurementFormatError, Parameters, cli
from beamslider.measurement import write_measurement

TOKENS = [b"nan", b"inf", b"-inf", b"1e400", b"1e-400", b"5e-324", b"-1", b"0", b"-0.0", b"1_0", b"0x10", b"\t", b" ",
          b",", b";", b"\n", b"\r\n", b"#", b"%", b"\xef\xbb\xbf", b"\x00", b"\xff", b"\"", b"=", b"[", b"]", b"e",
          b"E+", b".", b"1e308", b"99999999999999999999", b"Time VelBeam RelSliderPos\n", b"up", b"down", b"sweep"]


def mutate(rng: random.Random, data: bytes) -> bytes:
    v = bytearray(data)
    for _ in range(1 + rng.randrange(6)):
        pos = rng.randrange(len(v) + 1)
        op = rng.randrange(7)
        if op == 0 and v:
            v[rng.randrange(len(v))] ^= 1 << rng.randrange(8)
        elif op in (1, 2):
            v[pos:pos] = rng.choice(TOKENS)
        elif op == 3 and v:
            del v[pos:pos + 1 + rng.randrange(40)]
        elif op == 4 and v:
            a = rng.randrange(len(v))
            v[pos:pos] = v[a:a + 1 + rng.randrange(80)]
        elif op == 5:
            del v[pos:]
        elif op == 6:
            # replace a number-like run by a token
            end = pos
            while end < len(v) and (chr(v[end]).isdigit() or chr(v[end]) in ".e-+"):
                end += 1
            v[pos:end] = rng.choice(TOKENS)
    return bytes(v)


def check_measurement(path: Path) -> None:
    try:
        m = beamslider.read_measurement(path)
    except MeasurementFormatError as e:
        if str(path) not in str(e):
            raise AssertionError(f"message does not name the file: {e}") from None
        return
    n = len(m.t)
    assert n >= 2 and len(m.velocity) == len(m.s) == len(m.w) == n, "inconsistent lengths"
    assert np.all(np.diff(m.t) > 0), "time not increasing"
    for name in ("t", "velocity", "s", "w"):
        assert np.all(np.isfinite(getattr(m, name))), f"non-finite {name}"


def check_params(path: Path) -> None:
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        return
    try:
        p = Parameters.from_toml_text(text)
    except ValueError:
        return
    assert Parameters.from_toml_text(p.toml_text()) == p, "no TOML round trip"
    assert all(math.isfinite(v) for v in (p.length_m, p.dt_s, p.gap_ratio)), "non-finite accepted"


def check_simulation_csv(path: Path) -> None:
    try:
        cols = cli.read_simulation_csv(path)
    except (cli.UserError, UnicodeDecodeError):  # UnicodeDecodeError is a ValueError: one line in the CLI
        return
    assert len({len(c) for c in cols.values()}) == 1, "columns of different lengths"


def check_manifold_csv(path: Path) -> None:
    try:
        m = cli.read_manifold_csv(path, f_ex=124.0, a_ex=14.0, params=Parameters())
    except (cli.UserError, UnicodeDecodeError):
        return
    assert len(m.up_s) == len(m.up_amplitude) and len(m.down_s) == len(m.down_amplitude)


def seeds(tmp: Path) -> dict:
    t = np.arange(0, 0.02, 1e-4)
    meas = tmp / "seed_meas.txt"
    write_measurement(meas, t, 1e-3 * np.sin(2 * np.pi * 124 * t), 0.3 + 0 * t)
    sim = tmp / "seed_sim.csv"
    r = beamslider.simulate(f_ex=124, a_ex=14, t_end=0.002, record_every=5)
    cli.write_simulation_csv(sim, r)
    man = tmp / "seed_man.csv"
    man.write_text("sweep,s,amplitude_m\nup,0.2,1.0e-04\nup,0.3,2.0e-04\ndown,0.3,2.1e-04\ndown,0.2,1.1e-04\n")
    return {
        "read_measurement": (check_measurement, [meas.read_bytes(), b"% comment\nt;v;s\n0;1;0.3\n0.0001;1;0.3\n0.0002;1;0.3\n"]),
        "params_toml": (check_params, [Parameters().toml_text().encode(), b"n_modes = 3\ndt_s = 1e-5\n"]),
        "simulation_csv": (check_simulation_csv, [sim.read_bytes()]),
        "manifold_csv": (check_manifold_csv, [man.read_bytes()]),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--findings", default="fuzz-findings")
    args = ap.parse_args(argv)
    rng = random.Random(args.seed)
    findings = []
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        targets = seeds(tmp)
        execs = {name: 0 for name in targets}
        path = tmp / "input.txt"
        t0 = time.monotonic()
        while time.monotonic() - t0 < args.seconds and len(findings) < 20:
            name = rng.choice(list(targets))
            check, seed_list = targets[name]
            data = mutate(rng, rng.choice(seed_list))
            path.write_bytes(data)
            execs[name] += 1
            try:
                check(path)
            except Exception as e:  # noqa: BLE001 - everything else is a finding
                out = Path(args.findings)
                out.mkdir(parents=True, exist_ok=True)
                saved = out / f"{name}-{len(findings)}.txt"
                saved.write_bytes(data)
                what = f"{type(e).__name__}: {e}".splitlines()[0][:200]
                findings.append((name, what, saved))
                print(f"finding in {name}: {what} (input saved to {saved})", file=sys.stderr)
                traceback.print_exc(limit=3, file=sys.stderr)
        elapsed = time.monotonic() - t0
    total = sum(execs.values())
    print(f"fuzz_readers.py: {total} executions in {elapsed:.1f} s (seed {args.seed}): "
          + ", ".join(f"{k} {v}" for k, v in execs.items()) + f"; {len(findings)} findings")
    for name, what, saved in findings:
        print(f"  {name}: {what} ({saved})")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
