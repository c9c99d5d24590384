"""Benchmark of one `beamslider discover` with all candidates on the sample measured data: the wall
time and the CPU time of all threads (median of a few repeats, each a fresh subprocess) and the
verdict.

    python scripts/bench/bench_discover.py [--repeat 3] [--measured examples/data/*.txt.gz]
                                           [--effects LIST]

Each repeat runs `python -m beamslider discover --measured FILES --out TMP --force` (all
candidates: the slider level's physical effects, the contact spacing and the measurement chain;
no `--effects` given) in a subprocess and measures its wall time and the CPU time of the child
(user + system of all its threads, `os.wait4`). The load average is printed before and after: the
machine may be shared, and the wall time on an idle 2-core machine is then about CPU / 2. The
verdict is the first line of the report (`report.md`) and `verdict` of `report.json`.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def load() -> str:
    return "load average " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def one(files, effects) -> tuple:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        argv = [sys.executable, "-m", "beamslider", "discover", "--measured", *files, "--out", str(out), "--force"]
        if effects:
            argv += ["--effects", effects]
        t0 = time.perf_counter()
        p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        _, status, usage = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
        stdout, stderr = p.stdout.read(), p.stderr.read()  # type: ignore[union-attr]
        if os.waitstatus_to_exitcode(status) != 0:
            raise SystemExit(f"discover failed:\n{stderr}")
        rep = json.loads((out / "report.json").read_text())
        named = ", ".join(f"{e} {v['value']:.5g} in [{v['interval'][0]:.5g}, {v['interval'][1]:.5g}]"
                          for e, v in rep.get("parameters", {}).items()) or "-"
        del stdout
        return wall, usage.ru_utime + usage.ru_stime, rep["verdict"], named


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--measured", nargs="+", default=None,
                    help="measured files (default: examples/data/*.txt.gz)")
    ap.add_argument("--effects", default="", help="comma-separated candidates (default: all)")
    args = ap.parse_args()
    files = args.measured or sorted(glob.glob(str(Path(__file__).resolve().parents[2] / "examples/data/*.txt.gz")))
    if not files:
        print("error: no measured files", file=sys.stderr)
        return 1
    print(f"discover of {len(files)} file(s), {os.cpu_count()} cores, {load()}", flush=True)
    walls, cpus = [], []
    for i in range(args.repeat):
        wall, cpu, verdict, named = one(files, args.effects)
        walls.append(wall)
        cpus.append(cpu)
        print(f"  repeat {i + 1}: wall {wall:.1f} s, CPU {cpu:.1f} s, verdict {verdict}: {named} ({load()})", flush=True)
    print(f"median of {args.repeat}: wall {statistics.median(walls):.1f} s, CPU {statistics.median(cpus):.1f} s "
          f"(idle {os.cpu_count()}-core wall about CPU / {os.cpu_count()} = "
          f"{statistics.median(cpus) / (os.cpu_count() or 1):.1f} s); verdict {verdict}: {named}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
