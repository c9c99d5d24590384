#!/usr/bin/env python3
"""Whether the rescan of a rough one-effect fit (docs/model.md §9.1, "One effect": DiscoverOptions.rough_rescan)
or the full search's keeping of the tier's fits ("Cost") acts on a case of the discover table: the
case's data as `discover_table.py` makes them (60-s runs at the reference points plus the case's advised
run, seed 3, the truth runs S0_OFFSET off), one discover with the case's candidates, the search
watched. Where neither has acted when the pairs begin, it stops there: the rest of the search is the
version's before them, on the same fits, so the table's row stands. Where one has acted, the case runs
to the end, its verdict is printed and its report.json written to JSON_DIR/CASE.json.

Usage:  python3 scripts/repro/discover_rescan_check.py CASE S0_OFFSET JSON_DIR
"""
import json, sys, tempfile, time
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parent))
from beamslider import discover as dc
from beamslider.discover import problem, refine
from beamslider.discover.options import DEFAULT
from beamslider.discover.search import common, tiered
from discover_table import CASES, OPS, P, case_runs, truth_values

if len(sys.argv) != 4 or sys.argv[1] not in CASES:
    sys.exit(__doc__.split("Usage:")[1].strip() + "\nCASE: one of " + ", ".join(CASES))
case, off, jdir = sys.argv[1], float(sys.argv[2]), sys.argv[3]
label, spec, effects = CASES[case]
with tempfile.TemporaryDirectory() as tmp:
    runs = case_runs(case, OPS, 60.0, off, tmp)
Path(jdir).mkdir(parents=True, exist_ok=True)
trig = []
# The rescan refines one effect on ensembles (sets refine two or more): it ran (taken or not).
orig_rj = refine.refine_jointly
def rj(effs, u, *a, **k):
    if len(effs) == 1:
        trig.append(f"rescan {effs[0].name} (ran)")
    return orig_rj(effs, u, *a, **k)
refine.refine_jointly = rj
tier = {}
orig_ts = tiered.tiered_singles
def ts(cands, pred, fit, n, *a, **k):
    fits, ok = orig_ts(cands, pred, fit, n, *a, **k)
    tier.update({f.effects[0]: f.chi2 for f in fits if not f.screened})
    return fits, ok
tiered.tiered_singles = ts
coarse = {}
orig_pf = problem.profile_fit
def pf(effs, *a, refine=None, **k):
    f = orig_pf(effs, *a, refine=refine, **k)
    if len(effs) == 1 and refine == DEFAULT.screen_refine:
        coarse[effs[0].name] = f.chi2
    return f
problem.profile_fit = pf
def kept():
    if not coarse:
        return []
    best = sorted(coarse.values())
    cut = max(best[0] + DEFAULT.screen_margin, best[min(DEFAULT.screen_keep, len(best)) - 1])
    return [f"tier-kept {n}: coarse {coarse[n]:.1f} > cut {cut:.1f}, tier fit {c2:.1f}"
            for n, c2 in tier.items() if n in coarse and coarse[n] > cut]
class Stop(Exception):
    pass
orig_ptf = common.pairs_to_fit
def ptf(*a, **k):
    if not trig and not kept():
        raise Stop
    return orig_ptf(*a, **k)
common.pairs_to_fit = ptf
t0, c0 = time.perf_counter(), time.process_time()
try:
    d = dc.discover(measured=runs, baseline=P, effects=effects, max_effects=2)
    named = "; ".join(f"{e} {dc.fmt_value(d.parameters[e]['value'])} ± {dc.fmt_value(d.parameters[e]['stderr'])} "
                      f"[{dc.fmt_value(d.parameters[e]['interval'][0])}, "
                      f"{dc.fmt_value(d.parameters[e]['interval'][1])}]"
                      for e in d.named_effects) or "-"
    print(f"FINISHED {case} ({label}, s0 + {off}): {d.verdict} | {named} | truth {truth_values(spec)} | "
          f"gap {d.gap_before:.3g} -> {d.gap_after:.3g}")
    print("   ", dc.verdict_line(d))
    open(f"{jdir}/{case}.json", "w").write(json.dumps(d.to_json(), indent=1))
except Stop:
    print(f"STOPPED {case} at the pairs: nothing acted, the old code's search from here on the same fits")
for t in trig + kept():
    print("TRIGGER", case, t)
print("tier fits", {k: round(v, 1) for k, v in tier.items()}, "coarse scans", bool(coarse))
print(f"cpu {time.process_time() - c0:.0f} s, wall {time.perf_counter() - t0:.0f} s")
