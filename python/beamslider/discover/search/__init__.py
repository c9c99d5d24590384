"""The search strategies of the slider-level naming (docs/model.md §9.1, "Cost"): which candidate
sets are fitted and how; the rule that judges the fits is :mod:`..rule`."""
