#!/usr/bin/env bash
# All tests: the Rust workspace (cargo test), then the Python package (built from source by
# pip/maturin) with pytest. Installs what it needs; a fresh machine needs only the toolchains.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --workspace
if [ -f pyproject.toml ]; then
  python3 -m pip install --quiet --disable-pip-version-check ".[test]"
  # Run from a neutral directory so that the installed package (not ./python) is imported.
  (cd tests && python3 -m pytest -q -p no:cacheprovider .)
fi
