"""The result types of a discover: one fitted candidate set (:class:`CandidateFit`), the typed
verdict of the rule (:class:`Verdict`: :class:`Kind` and :class:`Because`) and the outcome
(:class:`Discovery`, what ``report.json`` holds); docs/model.md §9."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Any, Dict, List, Optional, Tuple

from .._json import json_safe as _json_safe
from ..params import Parameters


@dataclass
class CandidateFit:
    """One candidate set fitted to the measured features."""

    effects: Tuple[str, ...]
    values: Dict[str, float]
    stderrs: Dict[str, float]
    chi2: float
    dof: int
    adequate: bool
    bic: float
    predicted: Dict[str, float] = field(default_factory=dict)
    """Slider level: the features of the fitted model, mean of its ensemble of runs."""
    model_spread: Dict[str, float] = field(default_factory=dict)
    """Slider level: their spread over the ensemble (``DiscoverOptions.ensemble_s0_shifts``)."""
    intervals: Dict[str, Tuple[float, float]] = field(default_factory=dict)
    """Slider level: the :data:`INTERVAL_LEVEL` interval of each parameter (one effect: its
    profile scan's Δχ² = z² interval; several: the joint fit's Wald interval)."""
    roughness: Dict[str, float] = field(default_factory=dict)
    """Slider level: scatter of the single-run χ² about a parabola near the minimum
    (:func:`chi2_roughness`); the interval's threshold is χ²_min + 1 + 2·roughness."""
    screened: bool = False
    """Slider level: only the coarse scan was made (:data:`.search.sets.SCREEN_MARGIN`)."""
    linearised: bool = False
    """Screened by the linearised model's prediction only (the fast path, :mod:`.search.linearised`)."""


class Kind(str, Enum):
    """The verdict (docs/model.md §9, "Naming rule"); a string, so that ``d.verdict == "named"``."""

    NONE = "none"
    """The baseline fits the data, or only a negligible change is needed."""
    NAMED = "named"
    """An effect set passed the naming rule and was added."""
    CONFOUNDED = "confounded"
    """Candidates that fit equally by moving the features alike: the data resolve a combination."""
    UNEXPLAINED = "unexplained"
    """The baseline does not fit and no candidate set passes."""

    def __str__(self) -> str:  # printed and formatted as its value, "named", on every Python
        return self.value

    def __format__(self, spec: str) -> str:
        return format(self.value, spec)


class Because(str, Enum):
    """The branch of the rule that gave the verdict (docs/model.md §9, "Naming rule")."""

    BASELINE_FITS = "the baseline fits"
    NEGLIGIBLE_CHANGE = "an adequate set needs only a negligible change"
    NAMED = "a set passes the naming rule"
    CONFOUNDED = "candidates fit alike"
    OUTSIDE_CANDIDATES = "the best set fits as well as effects not among the candidates"
    NOT_RESOLVED = "the best relevant candidate is not resolved"
    NO_SET_PASSES = "no set passes the naming rule"
    POOR_FIT = "the best set does not fit as right models do"


@dataclass
class After:
    """The full simulation of a model (docs/model.md §9, "after"): its features (those it lacks
    filled at :func:`.stats.missing_z` uncertainties), behaviours, spread and runs in the data's modes."""

    features: Dict[str, float]
    behaviours: Dict[str, str]
    spread: Dict[str, float]
    counts: Dict[str, int]


@dataclass
class Verdict:
    """What the rule decided from the fits (:func:`.rule.decide`): the report, the figures and the
    command line read this, not the strings of ``report.json``."""

    kind: Kind
    because: Because
    named: Optional[CandidateFit] = None
    """The named set (``NAMED``)."""
    alternatives: List[Tuple[str, ...]] = field(default_factory=list)
    """Sets of the named set's size that fit within Δχ² = 2 of it."""
    reasons: Dict[Tuple[str, ...], List[Any]] = field(default_factory=dict)
    """Per fitted set (its effects), the reasons it is not named (:class:`.rule.Reason`, with their kind)."""
    group: Dict[str, Any] = field(default_factory=dict)
    """``CONFOUNDED`` or ``OUTSIDE_CANDIDATES``: the group, the sets, the combination the data resolve."""
    unresolved: Optional[CandidateFit] = None
    """``NOT_RESOLVED``: the best relevant candidate whose interval contains the baseline."""
    negligible: List[CandidateFit] = field(default_factory=list)
    """Adequate sets with only negligible changes, best first (``NEGLIGIBLE_CHANGE``: the first)."""
    best_rejected: Optional[CandidateFit] = None
    """``NO_SET_PASSES``: the set to show as the best candidate (a resolved relevant change first)."""
    advice: Dict[str, Any] = field(default_factory=dict)
    """The separability tool's advice for the group or the unresolved candidate (empty: none)."""
    after: Optional[After] = None
    """The full simulation of the named set (``NAMED``)."""
    poor_fit: Dict[str, Any] = field(default_factory=dict)
    """``POOR_FIT``: the best set's full simulation, its χ², gap and the goodness-of-fit bound."""
    filler: str = ""
    """What a rejected set with no reason of its own says (a simpler or better set was named, or confounded)."""

    def why_not(self, f: CandidateFit) -> List[Any]:
        """The reasons ``f`` is not named, as the report lists them."""
        return self.reasons.get(f.effects) or [self.filler]

    def to_json(self) -> Dict[str, Any]:
        def effects(f: Optional[CandidateFit]) -> Optional[List[str]]:
            return None if f is None else list(f.effects)

        return dict(kind=self.kind.value, because=self.because.name, named=effects(self.named),
                    group=list(self.group.get("group", [])), unresolved=effects(self.unresolved),
                    negligible=effects(self.negligible[0]) if self.negligible else None,
                    best_rejected=effects(self.best_rejected),
                    reasons=[dict(effects=list(k), kinds=[getattr(r.kind, "name", None) for r in v if hasattr(r, "kind")])
                             for k, v in self.reasons.items()],
                    advice=self.advice.get("text"), **({"poor_fit": self.poor_fit} if self.poor_fit else {}))


@dataclass
class Discovery:
    """Outcome of :func:`discover` (see :func:`write_report`)."""

    level: str
    named_effects: List[str]
    parameters: Dict[str, Dict[str, Any]]
    features: Dict[str, Dict[str, Any]]
    gap_before: float
    gap_after: float
    chi2_before: float
    candidates: List[CandidateFit]
    criterion: str
    baseline: Parameters
    updated: Parameters
    behaviours: Dict[str, Dict[str, str]] = field(default_factory=dict)
    alternatives: List[Tuple[str, ...]] = field(default_factory=list)
    data: Any = None
    runtime_s: float = 0.0
    verdict: Kind = Kind.NONE
    """``named`` (an effect set passed the naming rule), ``unexplained`` (the baseline does not fit
    and no candidate set passes), ``confounded`` (candidates that fit equally by moving the
    features alike: :attr:`confounded`), ``none`` (the baseline fits the data, or only a negligible
    change is needed): :class:`Kind`, a string; the whole verdict is :attr:`judgment`."""
    rejected: List[Dict[str, Any]] = field(default_factory=list)
    """Fitted candidate sets not named, each with the reasons."""
    features_off: List[Dict[str, Any]] = field(default_factory=list)
    """Features still off after the update (|z| > 2), largest first."""
    gap_ratio: float = 0.3
    gap_excess_before: float = 0.0
    """Gap beyond the noise before: sqrt(max(χ²₀ − n, 0)/n) (:data:`GAP_EXCESS_MEASURE`)."""
    gap_excess_after: float = 0.0
    """The same after the update: sqrt(max(χ² − (n − k), 0)/n)."""
    modes: Dict[str, Dict[str, Any]] = field(default_factory=dict)
    """Slider level, per operating point: the data's mode (:func:`.models.run_mode`: ends high,
    has a turning point) and how many of the baseline's and the updated model's ensemble runs end
    in it (:data:`MODE_CONDITIONING`)."""

    confounded: Dict[str, Any] = field(default_factory=dict)
    """Verdict ``confounded``: the ``group`` of candidates that fit equally by moving the features
    alike, the ``combination`` the data resolve, and the ``advice`` (a run that would separate
    them, :func:`.advice.advise`)."""
    unresolved: Dict[str, Any] = field(default_factory=dict)
    """Verdict ``unexplained`` with a relevant best candidate whose interval contains the baseline:
    the candidate, its fit, and the ``advice`` (a run that would resolve it)."""

    guided_pairs: List[Dict[str, Any]] = field(default_factory=list)
    """Slider level: the pairs fitted because the linearised model predicts them to fit best
    (:func:`.separability.rank_pairs`), with that prediction."""

    joint_refinement: List[Dict[str, Any]] = field(default_factory=list)
    """Slider level, where the sets were staged: per set its coordinate pass's χ², the χ² a
    Gauss–Newton step from there is predicted to reach (:func:`.refine.step_chi2`), whether it was
    refined jointly (:func:`.refine.sets_to_refine`) and its final χ²."""

    paths: Dict[str, Any] = field(default_factory=dict)
    """Slider level: the slider's path (t, s) of the ``baseline``'s and the ``updated`` model's run
    from s0 at each operating point of the data (by its tag), as their measurement chains record it
    (:func:`.models.slider_paths`; None for a failed run): the report's figure. Not in the JSON."""

    judgment: Optional[Verdict] = None
    """The typed verdict (:func:`.rule.decide`) that the report, the figures and the CLI read."""

    options: Any = None
    """The :class:`.options.DiscoverOptions` that made it."""

    def to_json(self) -> Dict[str, Any]:
        return _json_safe(dict(
            verdict=Kind(self.verdict).value, confounded=self.confounded, unresolved=self.unresolved,
            guided_pairs=self.guided_pairs, joint_refinement=self.joint_refinement, level=self.level, named_effects=self.named_effects, parameters=self.parameters,
            rejected=self.rejected, features_off=self.features_off, gap_ratio=self.gap_ratio,
            gap_before=self.gap_before, gap_after=self.gap_after, gap_measure=GAP_MEASURE,
            gap_excess_before=self.gap_excess_before, gap_excess_after=self.gap_excess_after,
            gap_excess_measure=GAP_EXCESS_MEASURE,
            chi2_before=self.chi2_before, criterion=self.criterion, features=self.features,
            behaviours=self.behaviours, alternatives=[list(a) for a in self.alternatives],
            candidates=[dict(effects=list(c.effects), values=c.values, stderrs=c.stderrs, chi2=c.chi2, dof=c.dof,
                             adequate=c.adequate, bic=c.bic, intervals=c.intervals, chi2_roughness=c.roughness)
                        for c in self.candidates],
            modes=self.modes, baseline=self.baseline.to_dict(), updated=self.updated.to_dict(), runtime_s=self.runtime_s,
            **({} if self.judgment is None else {"judgment": self.judgment.to_json()}),
            **({} if self.options is None else {"options": self.options.to_json()})))


GAP_MEASURE = ("RMS over the features of (model - measured) / uncertainty (measurement and, slider level, "
               "the model's spread over its ensemble of runs), sqrt(chi2 / n); slider level, chi2 includes the "
               "mode terms (end-state features compared within the data's mode)")


GAP_EXCESS_MEASURE = ("gap beyond the noise: sqrt(max(chi2 - E[chi2], 0) / n), E[chi2] = n for the baseline "
                      "and n - k for a model with k fitted parameters; the naming rule compares these")
