"""Extensions of the documentation site's build (docs/conf.py)."""
