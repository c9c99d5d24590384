"""Snapshot of results that a refactor must not change (issue "one home for each formula").

    python scripts/tooling/refactor_snapshot.py take  OUT.npz     # with the installed beamslider
    python scripts/tooling/refactor_snapshot.py compare A.npz B.npz

`take` records, with the installed package: the golden set-ups (reference solver, 0.2 s, free
slider at (124 Hz, 14 m/s², s0 = 0.3) and PCS at s = 0.25), the four representative runs of the
paper (120 s, s0 = 0.3), a 16-point map (4 x 4, 20 s), a small study (8 samples of mu and the
natural-frequency factor, 5 s) and a virtual ENMA. Map and study rows are stored without their wall
times. `compare` prints, per item, "bitwise" or the largest relative difference.
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

WALL = ("wall_s", "wall_time_s", "elapsed_s")


def _rows_array(rows):
    """Map/study rows as canonical JSON text without wall-clock fields."""
    clean = []
    for r in rows:
        clean.append({k: v for k, v in sorted(r.items()) if k not in WALL})
    return np.array([json.dumps(r, sort_keys=True, allow_nan=True) for r in clean])


def take(out: str) -> None:
    import beamslider as bs

    data = {}
    ref = bs.Parameters(contact_solver="reference")
    for name, kw in {
        "golden_fs": dict(model="fs", s0=0.3),
        "golden_pcs": dict(model="pcs", s0=0.25),
    }.items():
        r = bs.simulate(ref, f_ex=124, a_ex=14, t_end=0.2, record_every=1, **kw)
        for ch in ("t", "w", "s", "z_c", "beta"):
            data[f"{name}.{ch}"] = np.asarray(getattr(r, ch))
    for f, a in ((124, 14), (104, 14), (126, 10), (124, 6)):
        r = bs.simulate(f_ex=f, a_ex=a, s0=0.3, t_end=120)
        key = f"run_{f}_{a}"
        for ch in ("t", "w", "s", "z_c", "beta"):
            data[f"{key}.{ch}"] = np.asarray(getattr(r, ch))
        data[f"{key}.counters"] = np.array(json.dumps(r.counters, sort_keys=True))
        data[f"{key}.status"] = np.array(str(r.status))
    with tempfile.TemporaryDirectory() as tmp:
        bs.operating_map(f_ex=[104, 112, 120, 128], a_ex=[6, 10, 14, 16], s0=0.3, t_end=20.0,
                         out=Path(tmp) / "map")
        rows = [json.loads(l) for l in (Path(tmp) / "map" / "map.jsonl").read_text().splitlines()[1:] if l.strip()]
        data["map16.rows"] = _rows_array(rows)
        from beamslider import study

        cfg = study.StudyConfig.from_dict({
            "duration_s": 5.0,
            "grid": {"f_ex_hz": [124.0], "a_ex_m_s2": [14.0], "s0": 0.3},
            "study": {"method": "lhs", "samples": 8, "seed": 3},
            "uncertain": {"friction_coefficient": {"distribution": "uniform", "low": 0.22, "high": 0.31},
                          "natural_frequency_factor": {"distribution": "uniform", "low": 0.95, "high": 1.05}},
        })
        study.run_study(cfg, out=Path(tmp) / "study")
        lines = (Path(tmp) / "study" / "study.jsonl").read_text().splitlines()
        data["study8.rows"] = _rows_array([json.loads(l) for l in lines[1:] if l.strip()])
    e = bs.enma.virtual(levels_m_s2=[2.0, 6.0, 10.0])
    for k in ("amplitude_h", "frequency_hz", "damping_ratio", "shape"):
        data[f"enma.{k}"] = np.asarray(getattr(e, k))
    np.savez(out, **data)
    print(f"{out}: {len(data)} items")


def compare(a: str, b: str) -> int:
    A, B = np.load(a), np.load(b)
    bad = 0
    for k in sorted(set(A.files) | set(B.files)):
        if k not in A.files or k not in B.files:
            print(f"{k:32s} only in {'A' if k in A.files else 'B'}")
            bad += 1
            continue
        x, y = A[k], B[k]
        if k.endswith(".rows"):  # rows are appended in completion order: compare by index
            key = lambda r: json.loads(str(r)).get("index", 0)
            x, y = np.array(sorted(x, key=key)), np.array(sorted(y, key=key))
        if x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes():
            print(f"{k:32s} bitwise")
        elif x.dtype.kind == "f" and x.shape == y.shape:
            scale = max(float(np.nanmax(np.abs(x))), 1e-300)
            d = float(np.nanmax(np.abs(x - y))) / scale
            print(f"{k:32s} max rel diff {d:.3e}")
            bad += d > 1e-12
        else:
            print(f"{k:32s} DIFFERENT")
            bad += 1
    print("all equal (bitwise or within 1e-12)" if bad == 0 else f"{bad} items differ")
    return 1 if bad else 0


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "take":
        take(sys.argv[2])
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(sys.argv[2], sys.argv[3]))
    else:
        print(__doc__)
        sys.exit(2)
