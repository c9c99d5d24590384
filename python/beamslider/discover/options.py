"""The tuning values of a discover in one frozen type, :class:`DiscoverOptions` (docs/model.md §9,
§9.1): the naming rule's levels, the search's margins and counts, the fits' grids, the advice's
grid, and how the runs are read (the ensemble's starts, the modes, the features' smoothing and
floors). ``discover(options=...)`` takes one (or a mapping of some of its fields; an unknown key is
refused), and ``report.json`` records the values that made it (``options``)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Dict, Mapping, Tuple, Union

@dataclass(frozen=True)
class DiscoverOptions:
    """Every tuning value of :func:`beamslider.discover.discover`, each with its meaning and the
    section of docs/model.md that states it. The defaults are the values the validation table
    (docs/validation/discover.md) was made with."""

    # --- the naming rule (docs/model.md §9, §9.1 "Resolved") --------------------------------------
    significance: float = 0.01
    """Level of the tests: the baseline's χ² and |z| bounds, adequacy χ² ≤ χ²₁₋α(n − k), and the
    forward selection's likelihood-ratio thresholds (α / m, Bonferroni over m candidates) (§9)."""
    interval_level: float = 0.95
    """Confidence level of the interval that must exclude a parameter's baseline value before it is
    named: the profile's Δχ² = z² interval of one effect, the Wald interval ± z·se of a set (§9.1,
    "Resolved")."""
    gap_ratio: float = 0.3
    """A named set leaves at most this share of the gap beyond the noise, sqrt(max(χ² − E[χ²], 0)/n),
    in the fit and in the full simulation of the updated model; else "unexplained" (§9)."""
    mode_conditioning: bool = True
    """Slider level: the end-state features are compared only with model runs in the data's mode
    and the mode's rarity is a χ² term (§9; user guide "Modes"); False: one Gaussian over all runs."""
    gof_scale: float = 1.38
    """The goodness of fit of right models (§9.1, "Goodness of fit"): on data the baseline made
    itself, its χ² over n features is distributed as c·χ²(ν), ν = ``gof_dof_share``·n (the features
    are correlated and their uncertainties cautious); c and the share fitted by moments to 120
    nothing-hidden cases of the default plan (scripts/repro/discover_null_calibration.py --seed 201
    and --seed 202, 60 each: mean χ² 7.33, n 16–17). At the slider level the baseline fits only
    with χ² ≤ c·χ²₁₋α(share·n), and a named set's full simulation must show χ² ≤
    c·χ²₁₋α(share·(n − k)); inf: no such test (docs/validation/discover.md, "Judged at random")."""
    gof_dof_share: float = 0.318
    """The ν/n of :attr:`gof_scale`'s calibration (§9.1, "Goodness of fit")."""
    poor_single_alpha: float = 0.1
    """A single fitted in full whose ensemble's χ² lies above the (1 − this) quantile of right
    models' (:attr:`gof_scale`) is refined on ensemble means, as sets are: single runs' scatter can
    settle its scan beside the valley (§9.1, "Sets of effects"). A search effort, not a verdict's
    threshold; 0: never."""
    confound_cos: float = 0.95
    """|cos θ| between two fits' feature changes from which they move the features alike: two
    sets of effects fitting within the selection's threshold of each other and moving the features
    alike are a confounded group (§9, "confounded"; single effects need not move them alike)."""
    confirm_singles: int = 2
    """Single effects fitted in full to confirm the linearised model: against a named set (a
    confounded group) and among the effects left out of the candidates (§9.1, "Outside the
    candidates")."""

    # --- the search (docs/model.md §9.1 "Cost", "Sets of effects") ---------------------------------
    screen_from: int = 3
    """Slider level, more candidates than this: the single candidates are screened (the tier, or
    the full search's coarse scans); with fewer each is fitted in full (§9.1, "Cost")."""
    screen_refine: int = 1
    """Refinement levels of the full search's coarse scan: the grid, one level of 7 points spanning
    ± one grid step about its best point, and the ensembles at the two picks; the level sees a valley
    narrower than the grid step (friction 0.185 hidden: χ² 198 at the grid point 0.2, 1.8 at 0.1833)
    (§9.1, "Cost")."""
    screen_margin: float = 20.0
    """A coarsely scanned single candidate is fitted in full if its χ² is within this of the best
    coarse χ² (the refinement lowered a grid's minimum by at most about 13 in the table's runs; not a
    bound) (§9.1, "Cost")."""
    screen_keep: int = 3
    """At least this many single candidates (the best coarse ones) are fitted in full (§9.1, "Cost")."""
    tier_margin: float = 20.0
    """The tier: a candidate predicted, times the tier's scale, within this of the best fitted χ² is
    fitted in full; a fitted χ² this far above its prediction sends the answer to the full search
    (§9.1, "Cost")."""
    tier_least: int = 2
    """The tier: at least this many single candidates fitted in full, so that the leading one is
    checked against its nearest predicted rival (§9.1, "Confounded"; friction was named as a
    centre-of-mass offset where the tier fitted the offset alone) (§9.1, "Cost")."""
    tier_keep: int = 4
    """The tier: at most this many single candidates fitted in full before the answer goes to the
    full search (the natural frequencies × 1.03 hidden: the fourth, the contact spacing, settles it)
    (§9.1, "Cost")."""
    tier_shared: int = 3
    """The tier's fits in full, first by prediction, that the full search keeps; a later one enters
    as its coarse scan does, so the full search's verdict is that of a tier of this many (§9.1, "Cost")."""
    fast_keep: int = 3
    """``search="fast"``: the single candidates fitted in full, the best predicted (§9.1, "Fast path")."""
    linear_steps: float = 5.0
    """The linearised model's moves, ± this many relevance thresholds: the tier's and the fast path's
    predictions and the joint refinement's predicted step (§9.1, "Cost", "Sets of effects")."""
    rank_from: int = 3
    """Slider level, more candidates than this: the pairs are ranked by the linearised model (the
    pairs extending the two best singles, those predicted best overall) (§9.1, "Sets of effects")."""
    extending_pairs: int = 3
    """Of the pairs that extend one of the two best single candidates, those fitted: the ones the
    linearised model predicts to fit best (§9.1, "Sets of effects")."""
    guided_pairs: int = 3
    """Pairs fitted beyond those: the ones the linearised model predicts to fit best overall, so that
    two effects that each fit badly alone are still tried together (§9.1, "Sets of effects")."""
    joint_sets: int = 3
    """With more sets to fit than this, all get the coordinate pass and at least this many the joint
    refinement, with every set predicted to come within the selection's threshold (§9.1, "Cost")."""

    # --- the fits (docs/model.md §9.1 "One effect", "Sets of effects") -----------------------------
    grid_points: int = 9
    """Points of a single effect's scan over its search range (§9.1, "One effect")."""
    refine_levels: int = 2
    """Refinement levels of 7 points about the best point of a full fit, the step shrinking 3× per
    level (§9.1, "One effect")."""
    joint_refinement: bool = True
    """Sets of two or more slider-level effects: after the coordinate pass, Gauss–Newton steps on
    ensemble means confirmed by runs; False: the coordinate pass alone (§9.1, "Sets of effects")."""
    gauss_newton_steps: int = 4
    """Gauss–Newton steps at most of a joint refinement (§9.1, "Sets of effects")."""
    min_gain: float = 0.5
    """A Gauss–Newton step is taken only if it lowers χ² by more than this (§9.1, "Sets of effects")."""
    rough_rescan: float = 50.0
    """One effect: a fit that ends at the baseline value while its last level's single-run χ² scatter
    by more than this about a parabola is rescored on ensembles (§9.1, "One effect")."""

    # --- the advice (docs/model.md §9, "unexplained", "confounded") --------------------------------
    advice_grid: Tuple[Tuple[float, float, float], ...] = tuple(
        (f, a, s0) for s0 in (0.3, 0.15)
        for f, a in ((104.0, 14.0), (110.0, 10.0), (116.0, 10.0), (120.0, 6.0), (124.0, 6.0), (124.0, 14.0), (126.0, 10.0)))
    """Operating points (f_ex Hz, a_ex m/s², s0) among which the advice looks for the run that would
    resolve an unresolved candidate or separate a confounded group (those measured are left out):
    seven points of the paper's map from s0 = 0.3 and the same from 0.15; empty: no advice (§9)."""
    weak_separation: float = 2.0
    """Distance (uncertainties) between two fitted models' features at one run below which the
    advice says that no run of its grid separates them (§9, "confounded")."""
    clamp_clearance: float = 0.01
    """The advice skips a point where a run ends with a contact point of the slider closer than this
    (fraction of L) to a clamping (§9, "unexplained")."""

    # --- the runs and their features (docs/model.md §9, "Ensembles, modes and features") ----------
    ensemble_s0_shifts: Tuple[float, ...] = (0.0, -0.002, -0.001, 0.001, 0.002)
    """Shifts of s0 of the runs of a model's ensemble, the unshifted first (perturbations the data
    cannot resolve). After 60 s the final state at (124 Hz, 14 m/s²) and (126, 10) depends on them as
    much as on a change of μ by 2e-4 (measured: docs/results/discover/sensitivity.md) (§9,
    "Ensembles, modes and features")."""
    high_final_h: float = 0.3
    """Final amplitude [h] from which a run ends on the high branch (its mode; the classifier's
    ``high_h``, §8) (§9, "Ensembles, modes and features")."""
    mode_min_dof: int = 4
    """Least degrees of freedom of a mode feature's spread estimated from the runs in the data's mode;
    with fewer, the spread over all runs (an upper bound). Measured: at restitution 0.425 the three
    of five runs that end low at (126 Hz, 10 m/s²) agree on speed_late within 4.6e-5 1/s, while seven
    scan runs nearby scatter by 6e-4; that spread made a χ² of 98 out of one of 24 (§9, "Ensembles,
    modes and features")."""
    turning_smooth_s: float = 0.1
    """Window [s] of the centred moving average of s before a run's turning point is taken (the
    extreme of noisy samples is biased outwards (+3.6e-3 with the synthesiser's noise 1e-3)) (§9,
    "Ensembles, modes and features"). Measured and model runs alike; a run read otherwise is kept
    apart (§9.1, "Kept runs")."""
    recorded_segments: int = 4
    """Segments of a run whose spectral peaks give the recorded excitation frequency and its scatter
    (§9, "Ensembles, modes and features"; :func:`.features.recorded_frequency`). A run read otherwise
    is kept apart (§9.1, "Kept runs")."""
    feature_floors: Tuple[Tuple[str, str, float], ...] = (
        ("f0_hz", "rel", 1e-4), ("b_star", "rel", 2e-3), ("damping_0", "abs", 1e-6), ("damping_2", "abs", 2e-6),
        ("shape_L6", "abs", 2e-4), ("shape_L3", "abs", 2e-4), ("speed_early", "abs", 2e-4),
        ("speed_late", "abs", 2e-4), ("s_turning", "abs", 2e-3), ("s_final", "abs", 2e-3),
        ("amplitude_final_h", "rel", 0.02), ("f_recorded", "rel", 1e-4))
    """Resolution floors of the features' uncertainties, (feature, "rel" or "abs", floor): what a
    noise-free data set can still resolve given the estimators and the time step (§9, "Ensembles,
    modes and features"). A run read otherwise is kept apart (§9.1, "Kept runs")."""

    def __post_init__(self) -> None:
        def check(name: str, ok: bool, what: str) -> None:
            if not ok:
                raise ValueError(f"invalid option {name} = {getattr(self, name)!r}: {what}")

        for name in ("significance", "interval_level"):
            v = getattr(self, name)
            check(name, isinstance(v, (int, float)) and 0 < v < 1, "must be in (0, 1)")
        v = self.gap_ratio
        check("gap_ratio", isinstance(v, (int, float)) and 0 < v <= 1, "must be in (0, 1]")
        for name in ("mode_conditioning", "joint_refinement"):
            check(name, isinstance(getattr(self, name), bool), "must be True or False")
        check("gof_scale", isinstance(self.gof_scale, (int, float)) and not isinstance(self.gof_scale, bool)
              and self.gof_scale > 0, "must be a number > 0 (inf: no goodness-of-fit test)")
        check("poor_single_alpha", isinstance(self.poor_single_alpha, (int, float))
              and not isinstance(self.poor_single_alpha, bool) and 0 <= self.poor_single_alpha < 1, "must be in [0, 1)")
        for name in ("confound_cos", "gof_dof_share"):
            v = getattr(self, name)
            check(name, isinstance(v, (int, float)) and 0 < v <= 1, "must be in (0, 1]")
        for name in ("confirm_singles", "screen_from", "rank_from", "screen_refine", "screen_keep", "tier_least", "tier_keep", "tier_shared",
                     "fast_keep", "extending_pairs", "guided_pairs", "joint_sets", "gauss_newton_steps",
                     "refine_levels"):
            v = getattr(self, name)
            check(name, isinstance(v, int) and not isinstance(v, bool) and v >= 0, "must be an integer >= 0")
        check("grid_points", isinstance(self.grid_points, int) and self.grid_points >= 3, "must be an integer >= 3")
        check("tier_keep", self.tier_keep >= 1, "must be an integer >= 1")
        for name in ("screen_margin", "tier_margin", "min_gain", "rough_rescan", "weak_separation"):
            v = getattr(self, name)  # a margin or a threshold: inf turns its test off
            check(name, isinstance(v, (int, float)) and not isinstance(v, bool) and not math.isnan(v) and v >= 0,
                  "must be a number >= 0 (inf: never)")
        for name in ("clamp_clearance", "linear_steps"):
            v = getattr(self, name)
            check(name, isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v >= 0,
                  "must be a finite number >= 0")
        check("linear_steps", self.linear_steps > 0, "must be > 0")
        try:
            grid = tuple(tuple(float(x) for x in g) for g in self.advice_grid)
        except (TypeError, ValueError):
            grid = None
        check("advice_grid", grid is not None and all(len(g) == 3 and all(math.isfinite(x) for x in g) for g in grid),
              "give (f_ex, a_ex, s0) triples of finite numbers")
        object.__setattr__(self, "advice_grid", grid)
        try:
            shifts = tuple(float(x) for x in self.ensemble_s0_shifts)
        except (TypeError, ValueError):
            shifts = ()
        check("ensemble_s0_shifts", len(shifts) >= 2 and shifts[0] == 0.0 and len(set(shifts)) == len(shifts)
              and all(math.isfinite(x) and abs(x) < 0.1 for x in shifts),
              "give the unshifted run (0.0) first, then at least one other distinct shift of s0, each |shift| < 0.1")
        object.__setattr__(self, "ensemble_s0_shifts", shifts)
        for name in ("high_final_h", "turning_smooth_s"):
            v = getattr(self, name)
            check(name, isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0,
                  "must be a finite number > 0")
        check("mode_min_dof", isinstance(self.mode_min_dof, int) and not isinstance(self.mode_min_dof, bool)
              and self.mode_min_dof >= 1, "must be an integer >= 1")
        check("recorded_segments", isinstance(self.recorded_segments, int)
              and not isinstance(self.recorded_segments, bool) and self.recorded_segments >= 2,
              "must be an integer >= 2")
        try:
            floors = tuple((str(n), str(k), float(v)) for n, k, v in self.feature_floors)
        except (TypeError, ValueError):
            floors = None
        check("feature_floors", floors is not None and all(k in ("rel", "abs") and math.isfinite(v) and v >= 0
                                                           for _, k, v in floors),
              'give (feature, "rel" or "abs", floor >= 0) triples')
        object.__setattr__(self, "feature_floors", floors)

    def floor(self, name: str, value: float) -> float:
        """The resolution floor of feature ``name`` (``<feature>@<tag>``) at ``value``
        (:attr:`feature_floors`; 0 for a feature without one)."""
        base = name.split("@")[0]
        for n, kind, v in self.feature_floors:
            if n == base:
                return v * abs(value) if kind == "rel" else v
        return 0.0

    def reading_key(self) -> Tuple[Any, ...]:
        """What a run's stored features depend on beyond its inputs, for the key of a kept run: empty
        with the default reading (the keys of the runs kept before these were options), else the
        smoothing, segments and floors (docs/model.md §9.1, "Kept runs")."""
        fields = (self.turning_smooth_s, self.recorded_segments, self.feature_floors)
        if fields == (DEFAULT.turning_smooth_s, DEFAULT.recorded_segments, DEFAULT.feature_floors):
            return ()
        return (("reading", self.turning_smooth_s, self.recorded_segments, self.feature_floors),)

    @classmethod
    def of(cls, given: Union[None, "DiscoverOptions", Mapping[str, Any]] = None, **changes: Any) -> "DiscoverOptions":
        """``given`` (None: the defaults; a mapping: those fields changed, an unknown key refused)
        with ``changes`` applied (None values ignored)."""
        if given is None:
            base = cls()
        elif isinstance(given, cls):
            base = given
        elif isinstance(given, Mapping):
            base = cls()._changed(dict(given))
        else:
            raise TypeError(f"options: give a DiscoverOptions or a mapping of its fields, not {type(given).__name__}")
        return base._changed({k: v for k, v in changes.items() if v is not None})

    def _changed(self, values: Dict[str, Any]) -> "DiscoverOptions":
        known = [f.name for f in dataclasses.fields(self)]
        unknown = [k for k in values if k not in known]
        if unknown:
            raise ValueError(f"unknown option {unknown[0]!r}: known are {', '.join(known)}")
        return dataclasses.replace(self, **values) if values else self

    def to_json(self) -> Dict[str, Any]:
        """The values, as JSON (tuples as lists)."""
        out: Dict[str, Any] = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        for name in ("advice_grid", "feature_floors"):
            out[name] = [list(g) for g in getattr(self, name)]
        out["ensemble_s0_shifts"] = list(self.ensemble_s0_shifts)
        return out


DEFAULT = DiscoverOptions()
"""The defaults."""
