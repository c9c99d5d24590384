"""The one rule that scores discover's answers on the benchmark's cases, and the benchmark's figures
(docs/model.md §9.2): right or not per case, coverage of the stated intervals, false alarms, the
confusion table, and whether a wrong answer is discover's miss or a case the data cannot tell."""

from __future__ import annotations

import math
from typing import Any, Dict, Optional, Sequence

import numpy as np

from .cases import KINDS, Case, Plan

CLEARLY_BETTER = 11.0
"""χ² by which the truth must fit a case's data better than a wrong answer for the miss to be
discover's (the selection's price of one parameter among fourteen candidates, docs/model.md §9);
within it the data cannot tell the answer from the truth."""

def score_case(case: Case, answer: Dict[str, Any]) -> Dict[str, Any]:
    """The score of one answer (docs/model.md §9.2): ``right``, the ``outcome`` in words, and per
    named truth whether its stated interval holds it (``covered``).

    Right: nothing hidden → "none"; library effects → "named", exactly the truth's effects, each
    truth inside its stated interval; outside the library → "unexplained" (a stand-in named is
    wrong, a confounded group of stand-ins is counted apart)."""
    v, named = answer["verdict"], answer["named"]
    covered = {e: bool(named[e]["interval"][0] <= x <= named[e]["interval"][1])
               for e, x in case.effects.items() if e in named}
    if case.kind == "nothing":
        right = v == "none"
        outcome = "right" if right else ("false alarm: " + ", ".join(named) if named else f"false alarm ({v})")
    elif case.kind == "outside":
        right = v == "unexplained"
        outcome = ("right" if right else "stand-in named: " + ", ".join(named) if v == "named" else
                   "confounded stand-ins: " + ", ".join(answer["group"]) if v == "confounded" else "not seen (none)")
    else:
        same = set(named) == set(case.effects)
        right = v == "named" and same and all(covered.values())
        if right:
            outcome = "right"
        elif v == "named" and same:
            outcome = "interval misses the truth: " + ", ".join(e for e, ok in covered.items() if not ok)
        elif v == "named":
            wrong = sorted(set(named) - set(case.effects))
            missed = sorted(set(case.effects) - set(named))
            outcome = "named " + ", ".join(named) + (f" (wrong: {', '.join(wrong)})" if wrong else "") + \
                      (f" (missed: {', '.join(missed)})" if missed else "")
        elif v == "confounded":
            outcome = "confounded: " + ", ".join(answer["group"])
        elif v == "unexplained":
            outcome = "unexplained" + (f" (best: {', '.join(answer['best'])})" if answer["best"] else "")
        else:
            outcome = "missed (none)"
    return dict(right=bool(right), outcome=outcome, covered=covered)


def final_score(row: Dict[str, Any]) -> Dict[str, Any]:
    """A row's score after at most one advised run (its first score where no run was advised)."""
    return row.get("advised", {}).get("score", row["score"])


def _rate(k: int, n: int) -> Dict[str, Any]:
    """k of n with the binomial standard error."""
    p = k / n if n else math.nan
    return dict(right=k, of=n, rate=p, stderr=math.sqrt(p * (1 - p) / n) if n else math.nan)


def summarise(rows: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
    """The benchmark's figures (docs/model.md §9.2): per kind the share right on the first answer
    and after at most one advised run (with binomial errors); coverage, the share of named truths
    inside their stated 95 % intervals; false alarms, effects named on nothing-hidden data;
    confounded groups of stand-ins for outside cases; CPU seconds per case; the confusion table
    (what was named for what)."""
    by_kind: Dict[str, Any] = {}
    for kind in KINDS:
        rs = [r for r in rows if r["kind"] == kind]
        if rs:
            by_kind[kind] = dict(first=_rate(sum(r["score"]["right"] for r in rs), len(rs)),
                                 after_advice=_rate(sum(final_score(r)["right"] for r in rs), len(rs)))
    # An outside change the plan's runs do not show (the baseline passes its test on them) asks
    # nothing of discover but "none": counted apart, the outside figure also given over the others.
    unseen = [int(r["index"]) for r in rows if r["kind"] == "outside" and not_visible(r)]
    if "outside" in by_kind:
        seen = [r for r in rows if r["kind"] == "outside" and int(r["index"]) not in unseen]
        by_kind["outside"]["visible"] = _rate(sum(final_score(r)["right"] for r in seen), len(seen))
    cov = [ok for r in rows for ok in final_score(r)["covered"].values()]
    nothing = [r for r in rows if r["kind"] == "nothing"]
    false_alarms = sum(len(r["answer"]["named"]) for r in nothing)
    confusion: Dict[str, Dict[str, int]] = {}
    for r in rows:
        truth = r["outside_kind"] and f"outside: {r['outside_kind']}" or (" + ".join(sorted(r["truth"])) or "nothing")
        ans = r.get("advised", {}).get("answer", r["answer"])
        got = (" + ".join(sorted(ans["named"])) if ans["verdict"] == "named" else
               f"confounded: {' + '.join(sorted(ans['group']))}" if ans["verdict"] == "confounded" else ans["verdict"])
        confusion.setdefault(truth, {}).setdefault(got, 0)
        confusion[truth][got] += 1
    # A wrong final answer is discover's miss where the truth fits its data clearly better (by more
    # than the selection's price of a parameter, about 11 for fourteen candidates), else the data
    # cannot tell the answer from the truth (what the plan resolves: detectability).
    missed, cannot_tell = [], []
    for r in rows:
        s, tf = final_score(r), r.get("advised", {}).get("truth_fit", r.get("truth_fit"))
        a = r.get("advised", {}).get("answer", r["answer"])
        if s["right"] or not tf or not math.isfinite(tf.get("chi2", math.nan)):
            continue
        chi2_answer = answer_chi2(a)
        (missed if chi2_answer - tf["chi2"] > CLEARLY_BETTER else cannot_tell).append(int(r["index"]))
    # Right, or wrong where the data cannot tell (docs/model.md §9.2).
    for kind, d in by_kind.items():
        rs = [r for r in rows if r["kind"] == kind]
        d["right_or_cannot_tell"] = _rate(sum(final_score(r)["right"] or int(r["index"]) in cannot_tell for r in rs),
                                          len(rs))
        # Where they can tell (right, or discover's miss): the share right there; the number of cases
        # where they can, over the kind's cases, bounds any rule that names only what the data prefer.
        tell = [r for r in rs if final_score(r)["right"] or int(r["index"]) in missed]
        d["where_the_data_can_tell"] = _rate(sum(final_score(r)["right"] for r in tell), len(tell))
        d["where_the_data_can_tell"]["cases"] = len(rs)
    # A change the data do not show on top of the others (leaving it out of the truth raises the
    # truth's χ² by less than the selection's price) cannot be named by a rule that keeps nothing-
    # hidden data free of false alarms: the figure over the cases where every change shows.
    for kind, d in by_kind.items():
        rs = [r for r in rows if r["kind"] == kind and each_change_shows(r) is not None]
        if kind != "nothing" and rs:
            shown = [r for r in rs if each_change_shows(r)]
            d["each_change_shows"] = _rate(sum(final_score(r)["right"] for r in shown), len(shown))
            d["each_change_shows"]["cases"] = len(rs)
    cpu = [float(r["cpu_s"]) for r in rows]
    return dict(cases=len(rows), by_kind=by_kind,
                coverage=dict(inside=sum(cov), of=len(cov), rate=(sum(cov) / len(cov)) if cov else math.nan),
                false_alarms=dict(effects_named=false_alarms, cases=len(nothing),
                                  cases_with_alarm=sum(bool(r["answer"]["named"]) or r["answer"]["verdict"] != "none"
                                                       for r in nothing)),
                outside_not_visible=unseen,
                confounded_stand_ins=sum(r["kind"] == "outside" and r["answer"]["verdict"] == "confounded" for r in rows),
                advised_runs=sum("advised" in r for r in rows),
                wrong_where_the_truth_fits_better=missed, wrong_where_the_data_cannot_tell=cannot_tell,
                cpu_s=dict(median=float(np.median(cpu)) if cpu else math.nan, total=float(sum(cpu))),
                confusion=confusion)


def answer_chi2(a: Dict[str, Any]) -> float:
    """The χ² of what an answer offers for the data: a named set's full simulation; for "confounded"
    or "unexplained", the best fit the search made (the row's ``fits``: the data cannot tell the
    truth from a model that fits as well, though the rule named none); else the baseline's."""
    if a["verdict"] == "named":
        return float(a["chi2_after"])
    best = min((float(f["chi2"]) for f in a.get("fits", []) if math.isfinite(float(f["chi2"]))), default=math.inf)
    return min(best, float(a["gap_before"]) ** 2 * int(a["n"]))


def each_change_shows(row: Dict[str, Any]) -> Optional[bool]:
    """Whether the final data show each of a case's hidden changes on top of the others: leaving it
    out of the truth raises the truth's χ² by more than :data:`CLEARLY_BETTER` (docs/model.md §9.2,
    "Visible"); None where the row does not record it or the case hides nothing."""
    tf = row.get("advised", {}).get("truth_fit", row.get("truth_fit")) or {}
    without = tf.get("without")
    if not without or not math.isfinite(tf.get("chi2", math.nan)):
        return None
    return all(math.isfinite(w) and w - tf["chi2"] > CLEARLY_BETTER for w in without.values())


def not_visible(row: Dict[str, Any]) -> bool:
    """Whether a case's hidden change is not visible in its runs: the answer is "none" because the
    baseline passes its test on them (docs/model.md §9.2)."""
    a = row["answer"]
    return a["verdict"] == "none" and a.get("because") == "BASELINE_FITS"


def _pct(d: Dict[str, Any]) -> str:
    if not d["of"]:
        return "—"
    return f"{d['right']}/{d['of']} ({100 * d['rate']:.0f} % ± {100 * d['stderr']:.0f})"


def summary_markdown(summary: Dict[str, Any], rows: Sequence[Dict[str, Any]], *, seed: Any = None,
                     plan: Optional[Plan] = None) -> str:
    """The summary as Markdown: the figures, then one line a case."""
    lines = ["# Discover benchmark", ""]
    if plan is not None:
        pts = "; ".join(f"{f:g} Hz, {a:g} m/s², s0 {s:g}" for f, a, s in plan.operating_points)
        lines += [f"Seed {seed}; plan: {pts}, {plan.duration_s:g} s each; {len(plan.candidates)} candidates. "
                  "Rules and scores: docs/model.md §9.2.", ""]
    lines += ["| kind | right (first answer) | right (after at most one advised run) | right, or the data cannot tell "
              "| right where the data can tell | right where each change shows |", "|---|---|---|---|---|---|"]
    for kind, d in summary["by_kind"].items():
        ceiling = _pct(d["right_or_cannot_tell"]) if "right_or_cannot_tell" in d else "—"
        e = d.get("each_change_shows")
        shows = f"{_pct(e)}; {e['of']} of {e['cases']} cases show each" if e else "—"
        t = d.get("where_the_data_can_tell")
        tell = f"{_pct(t)}; they tell in {t['of']} of {t['cases']} cases" if t else "—"
        lines.append(f"| {kind} | {_pct(d['first'])} | {_pct(d['after_advice'])} | {ceiling} | {tell} | {shows} |")
    c = summary["coverage"]
    fa = summary["false_alarms"]
    lines += ["",
              f"- coverage of the stated 95 % intervals: {c['inside']}/{c['of']} named truths inside"
              + (f" ({100 * c['rate']:.0f} %)" if c["of"] else ""),
              f"- false alarms on nothing-hidden data: {fa['effects_named']} effects named in {fa['cases']} cases "
              f"({fa['cases_with_alarm']} cases not answered 'none')",
              f"- outside the library answered by a confounded group of stand-ins: {summary['confounded_stand_ins']}",
              f"- outside the library not visible in the plan's runs (the baseline passes its test; answered "
              f"'none'): cases {summary.get('outside_not_visible', [])}"
              + (f"; right among the visible ones: {_pct(summary['by_kind']['outside']['visible'])}"
                 if "visible" in summary["by_kind"].get("outside", {}) else ""),
              f"- advised runs taken: {summary['advised_runs']}",
              f"- wrong final answers where the truth fits its data better by more than {CLEARLY_BETTER:g} in χ² "
              f"(discover's misses): cases {summary.get('wrong_where_the_truth_fits_better', [])}; where it does not "
              f"(the data cannot tell): cases {summary.get('wrong_where_the_data_cannot_tell', [])}",
              f"- CPU per case: median {summary['cpu_s']['median']:.0f} s, total {summary['cpu_s']['total']:.0f} s",
              "", "## Confusion (truth → final answer)", "", "| truth | answer | cases |", "|---|---|---|"]
    for truth, got in sorted(summary["confusion"].items()):
        for g, n in sorted(got.items()):
            lines.append(f"| {truth} | {g} | {n} |")
    lines += ["", "## Cases", "", "| # | kind | truth | first answer | after advice | CPU s |", "|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: r["index"]):
        adv = r.get("advised")
        lines.append(f"| {r['index']} | {r['kind']} | {r['label']} | {_answer_text(r['answer'])}: "
                     f"{'**right**' if r['score']['right'] else r['score']['outcome']} | "
                     + (f"{_answer_text(adv['answer'])}: {'**right**' if adv['score']['right'] else adv['score']['outcome']}"
                        if adv else "—") + f" | {r['cpu_s']:.0f} |")
    return "\n".join(lines) + "\n"


def _answer_text(a: Dict[str, Any]) -> str:
    if a["verdict"] == "named":
        return "named " + "; ".join(f"{e} {v['value']:.5g} [{v['interval'][0]:.5g}, {v['interval'][1]:.5g}]"
                                    for e, v in a["named"].items())
    if a["verdict"] == "confounded":
        return "confounded " + ", ".join(a["group"])
    return a["verdict"]
