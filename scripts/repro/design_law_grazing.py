"""The low branch at grazing (docs/model.md §6.3) against the prototype's PCS tables: no fit.

    python scripts/repro/design_law_grazing.py [--out docs/results/design_law] [--own-laws DIR]

For every committed PCS drift table of the prototype (docs/results/superslow/drift/drift_*.jsonl),
and with --own-laws the tables of the held-out designs' own laws (DIR/design_<i>/drift/, written by
`beamslider fit-law --params`, see validate_design_law.py), the low-branch rows of the down sweep (the PCS slider free within its clearance, its impacts
included) against the HB low branch at the same s (the slider rigidly attached) and against the
same branch capped at grazing, min(Â_HB, Â_g), each table at the parameters it was computed
with (its params_toml). Writes grazing.txt under --out.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import numpy as np

from beamslider import Parameters
from beamslider.superslow import features, hb_manifold, read_drift_table

ROOT = Path(__file__).resolve().parents[2]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "results" / "design_law"))
    ap.add_argument("--own-laws", help="folder with design_<i>/drift/drift_*.jsonl: the held-out designs' PCS tables")
    a = ap.parse_args()
    sets = [("prototype", sorted((ROOT / "docs" / "results" / "superslow" / "drift").glob("drift_*.jsonl")))]
    if a.own_laws:
        for d in sorted(Path(a.own_laws).glob("design_*")):
            sets.append((f"held-out {d.name}", sorted((d / "drift").glob("drift_*.jsonl"))))
    lines = ["# low branch: PCS amplitude (down sweep, branch L) against HB (rigidly attached) and HB capped at grazing",
             "# python scripts/repro/design_law_grazing.py" + (" --own-laws DIR" if a.own_laws else "")]
    for name, files in sets:
        lines += _compare(name, files)
    text = "\n".join(lines) + "\n"
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "grazing.txt").write_text(text)
    print(text, end="")


def _compare(title, files):
    lines = [f"## {title}", "table                 rows  PCS range [h]   HB/PCS median  capped/PCS median  capped rows"]
    e_hb, e_cap = [], []
    for f in files:
        t = read_drift_table(f)
        p = Parameters.from_toml_text(t.params_toml) if t.params_toml else Parameters()
        m = hb_manifold(p, f_ex=t.f_ex, a_ex=t.a_ex)
        if len(m.low) == 0:
            continue
        sel = (t.branch == "L") & (t.sweep == "down") & (t.s >= m.low.s.min()) & (t.s <= m.low.s.max())
        if not sel.any():
            continue
        ft = features(m, "L", t.s[sel])
        a_pcs = t.amplitude[sel]
        r_hb = ft["amplitude"] / a_pcs
        r_cap = np.minimum(ft["amplitude"], ft["grazing"]) / a_pcs
        e_hb += list(np.log(r_hb))
        e_cap += list(np.log(r_cap))
        name = re.sub(r"\.jsonl$", "", f.name)
        lines.append(f"{name:<20} {sel.sum():5d}  {a_pcs.min():.3f}-{a_pcs.max():.3f}   {np.median(r_hb):13.2f}  "
                     f"{np.median(r_cap):17.2f}  {int((ft['grazing'] < ft['amplitude']).sum()):11d}")
    e_hb, e_cap = np.array(e_hb), np.array(e_cap)
    if len(e_hb):
        lines.append(f"all {len(e_hb)} rows: RMS log error HB {np.sqrt(np.mean(e_hb ** 2)):.3f}, "
                     f"capped at grazing {np.sqrt(np.mean(e_cap ** 2)):.3f}")
    return lines


if __name__ == "__main__":
    main()
