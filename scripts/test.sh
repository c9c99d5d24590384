#!/usr/bin/env bash
# All tests: the Rust workspace (cargo test), then the Python package with pytest on the oldest
# and the newest supported Python (3.9 and 3.13) where they are found, else on python3.
#
# The extension is built once, as one abi3 wheel (valid for every CPython >= 3.9), and installed
# with its test dependencies into one virtual environment per Python under target/test-venvs/
# (re-used by later runs). Installs what it needs; a fresh machine needs only the toolchains.
# The tests marked `heavy` (the discover fits, ~5 min) run on the last (newest) Python only.
#
#   BEAMSLIDER_TEST_PYTHONS="/path/to/python3.9 /path/to/python3.13"   choose the interpreters
#   BEAMSLIDER_REQUIRE_PYTHONS=1   fail unless both 3.9 and 3.13 are found (set by .ci/run)
#   BEAMSLIDER_TEST_WORKERS=N      pytest-xdist workers (default 2, the cores of this project's machine)
set -euo pipefail
cd "$(dirname "$0")/.."

cargo test --workspace
[ -f pyproject.toml ] || exit 0

find_python() {  # newest patch release of Python $1 on PATH or under pyenv
  local v=$1 c found=""
  if command -v "python$v" >/dev/null 2>&1; then found=$(command -v "python$v"); fi
  for c in "${PYENV_ROOT:-$HOME/.pyenv}/versions/$v".*/bin/python; do
    [ -x "$c" ] && found=$c
  done
  echo "$found"
}

if [ -n "${BEAMSLIDER_TEST_PYTHONS:-}" ]; then
  read -r -a PYTHONS <<<"$BEAMSLIDER_TEST_PYTHONS"
else
  PYTHONS=()
  for v in 3.9 3.13; do
    p=$(find_python "$v")
    if [ -n "$p" ]; then
      PYTHONS+=("$p")
    elif [ -n "${BEAMSLIDER_REQUIRE_PYTHONS:-}" ]; then
      echo "scripts/test.sh: Python $v not found (on PATH as python$v or under pyenv)" >&2
      exit 1
    else
      echo "scripts/test.sh: Python $v not found; testing with the ones found" >&2
    fi
  done
  [ ${#PYTHONS[@]} -gt 0 ] || PYTHONS=(python3)
fi

# One abi3 wheel, built by pip through maturin (as `pip install .`, but with the lighter
# ci-wheel profile of Cargo.toml: no LTO, parallel code generation).
WHEELS=target/test-wheels
rm -rf "$WHEELS"
MATURIN_PEP517_ARGS="--profile ci-wheel" "${PYTHONS[0]}" -m pip wheel --no-deps --disable-pip-version-check --quiet --wheel-dir "$WHEELS" .
WHEEL=$(ls "$WHEELS"/beamslider-*.whl)
echo "scripts/test.sh: built $(basename "$WHEEL")"

for py in "${PYTHONS[@]}"; do
  ver=$("$py" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
  venv=target/test-venvs/py$ver
  [ -x "$venv/bin/python" ] || "$py" -m venv "$venv"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check "$WHEEL[test]"
  # Same version number as an earlier build: replace the package itself.
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps "$WHEEL"
  # The heavy tests (discover fits of synthetic runs: pure Python on the core, about 5 minutes)
  # run on the newest Python only; every other test runs on each.
  marks="not slow"
  [ "$py" = "${PYTHONS[${#PYTHONS[@]}-1]}" ] || marks="not slow and not heavy"
  echo "scripts/test.sh: pytest on Python $ver ($venv), -m '$marks'"
  # Run from a neutral directory so that the installed package (not ./python) is imported.
  # Two pytest-xdist workers (BEAMSLIDER_TEST_WORKERS); the README's examples are one test.
  (cd tests && "../$venv/bin/python" -m pytest -q -p no:cacheprovider -m "$marks" \
     -n "${BEAMSLIDER_TEST_WORKERS:-2}" .)
done
