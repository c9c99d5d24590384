#!/usr/bin/env bash
# The tests.
#
#   bash scripts/test.sh          the fast check: the Rust tests (`cargo test --tests`: the core's
#                                 unit tests, each crate's test binary), then the fast pytest
#                                 suite (not `slow`, `heavy` or `docs`) on one Python (python3)
#   bash scripts/test.sh --full   the full matrix (.ci/run): also builds the core's examples and
#                                 runs its doc tests; pytest on Python 3.9 and 3.13 with the `docs`
#                                 tests (site build, README and guide examples) on both and the
#                                 `heavy` fits on the newest; fails unless both are found
#
# The Rust core is compiled once, in the ci-wheel profile of Cargo.toml (release code generation
# without link-time optimisation), for both the cargo tests and the abi3 wheel (valid for every
# CPython >= 3.9), so the two builds share the compiled dependencies. The core's unit-test harness
# (the core compiled a second time, with cfg(test)) is compiled without optimisation
# (scripts/tooling/rustc_unit_tests_unoptimised.sh, unless RUSTC_WRAPPER is already set). While
# Cargo compiles, a virtual environment per Python (target/test-venvs/, re-used by later runs)
# gets the test dependencies, installed by uv (from PyPI; pip if uv cannot be installed).
# Installs what it needs; a fresh machine needs only the toolchains.
#
#   BEAMSLIDER_TEST_PYTHONS="/path/to/python3.9 /path/to/python3.13"   choose the interpreters
#   BEAMSLIDER_REQUIRE_PYTHONS=1   (--full) fail unless both 3.9 and 3.13 are found
#   BEAMSLIDER_TEST_WORKERS=N      pytest-xdist workers (default 2, the cores of this project's machine)
set -euo pipefail
cd "$(dirname "$0")/.."

FULL=0
for arg in "$@"; do
  case "$arg" in
    --full) FULL=1 ;;
    -h|--help) sed -n '2,23p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "scripts/test.sh: unknown option $arg (--full, --help)" >&2; exit 2 ;;
  esac
done
[ "$FULL" = 1 ] && BEAMSLIDER_REQUIRE_PYTHONS=${BEAMSLIDER_REQUIRE_PYTHONS:-1}
PROFILE=ci-wheel
T0=$(date +%s)
mkdir -p target
CPU_FILE=target/test-sh-times.txt
stamp() {  # wall seconds since the start, and the CPU seconds (user + system) of the finished steps
  times > "$CPU_FILE"  # in this shell, not a subshell: the second line is its children's CPU
  local cpu
  cpu=$(awk 'NR == 2 { n = 0; for (i = 1; i <= 2; i++) { split($i, a, "m"); sub("s", "", a[2]); n += a[1] * 60 + a[2] }
                       printf "%.0f", n }' "$CPU_FILE")
  echo "scripts/test.sh: [$(( $(date +%s) - T0 )) s, ${cpu} s CPU] $*"
}

find_python() {  # newest patch release of Python $1 on PATH or under pyenv
  local v=$1 c found=""
  if command -v "python$v" >/dev/null 2>&1 && "python$v" -c '' >/dev/null 2>&1; then found=$(command -v "python$v"); fi
  for c in "${PYENV_ROOT:-$HOME/.pyenv}/versions/$v".*/bin/python; do
    [ -x "$c" ] && found=$c
  done
  echo "$found"
}

if [ -n "${BEAMSLIDER_TEST_PYTHONS:-}" ]; then
  read -r -a PYTHONS <<<"$BEAMSLIDER_TEST_PYTHONS"
elif [ "$FULL" = 1 ]; then
  PYTHONS=()
  for v in 3.9 3.13; do
    p=$(find_python "$v")
    if [ -n "$p" ]; then
      PYTHONS+=("$p")
    elif [ -n "${BEAMSLIDER_REQUIRE_PYTHONS:-}" ]; then
      echo "scripts/test.sh: Python $v not found (on PATH as python$v or under pyenv)" >&2
      exit 1
    fi
  done
else
  PYTHONS=(python3)
fi

# The test dependencies of the package (pyproject.toml, extra "test") and its build backend, without
# the package itself.
test_requirements() {
  "$1" - <<'PY'
import ast, re
text = open("pyproject.toml", encoding="utf-8").read()
def arrays(section, names=None):  # name = [ ... ] entries of a TOML table (arrays of strings, over lines)
    body = text.split(section, 1)[1].split("\n[", 1)[0].splitlines()
    out, i = {}, 0
    while i < len(body):
        m = re.match(r"^(\w+) = (\[.*)$", body[i])
        i += 1
        if m and (names is None or m.group(1) in names):
            chunk = m.group(2)
            while True:
                try:
                    out[m.group(1)] = ast.literal_eval(chunk)
                    break
                except SyntaxError:
                    chunk += "\n" + body[i]
                    i += 1
    return out
deps = arrays("[project]\n", {"dependencies"})["dependencies"]
extras = arrays("[project.optional-dependencies]")
def expand(reqs):
    for r in reqs:
        m = re.match(r"beamslider\[([\w,]+)\]", r)
        if m:
            for e in m.group(1).split(","):
                yield from expand(extras[e])
        else:
            yield r
build = re.search(r'requires = (\[.*?\])', text.split("[build-system]", 1)[1]).group(1)
print("\n".join(dict.fromkeys([*deps, *expand(extras["test"]), *ast.literal_eval(build)])))
PY
}

# 1. In the background: one virtual environment per Python with the test dependencies.
mkdir -p target/test-venvs
VENV_PIDS=()
for py in "${PYTHONS[@]}"; do
  ver=$("$py" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
  venv=target/test-venvs/py$ver
  (
    [ -x "$venv/bin/python" ] || "$py" -m venv "$venv"
    test_requirements "$venv/bin/python" > "$venv/requirements-test.txt"
    # uv takes ~3 s CPU where pip takes ~40 (pip compiles every module's bytecode at install; uv
    # leaves that to the first import), CPU that the compilers running meanwhile would wait for.
    if "$venv/bin/python" -m pip install --quiet --disable-pip-version-check uv \
       && "$venv/bin/uv" pip install --quiet --python "$venv/bin/python" -r "$venv/requirements-test.txt"; then
      :
    else
      "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$venv/requirements-test.txt"
    fi
  ) > "target/test-venvs/py$ver.log" 2>&1 &
  VENV_PIDS+=($!)
done

# The Rust sources are formatted by the workspace's rustfmt.toml (a second's check, before any build).
if command -v rustfmt > /dev/null 2>&1; then
  cargo fmt --all -- --check > /dev/null || { echo "scripts/test.sh: the Rust sources are not formatted: run cargo fmt --all" >&2; exit 1; }
fi

# 2. The Rust tests, in the wheel's profile: built here, run in step 3 while the wheel builds.
#    `--tests` selects the targets with `test = true`: the core's unit tests and the integration
#    test binaries (one per crate, tests/all/); not the binding's library (`test = false`: it has no
#    Rust tests, pytest tests it, and the wheel's build compiles PyO3 with the build variables of
#    maturin anyway) nor the batch binary's harness (`test = false`: no unit tests; its
#    integration tests run the binary itself). `--bins` or `--lib` would build those harnesses.
CARGO_TEST=(cargo test --workspace --profile "$PROFILE")
# The fast check: not the examples' builds, not doc tests.
[ "$FULL" = 1 ] || CARGO_TEST+=(--tests)
export RUSTC_WRAPPER=${RUSTC_WRAPPER:-$PWD/scripts/tooling/rustc_unit_tests_unoptimised.sh}
"${CARGO_TEST[@]}" --no-run
stamp "cargo test built"
if [ ! -f pyproject.toml ]; then "${CARGO_TEST[@]}"; exit 0; fi

wait_venv() {  # the virtual environment of PYTHONS[$1], once its installation has finished
  local ver venv
  ver=$("${PYTHONS[$1]}" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
  venv=target/test-venvs/py$ver
  if ! wait "${VENV_PIDS[$1]}"; then
    cat "target/test-venvs/py$ver.log" >&2
    echo "scripts/test.sh: installing the test dependencies into $venv failed" >&2
    exit 1
  fi
}

# 3. The Rust tests run (output in target/cargo-test.log) while one abi3 wheel is built by pip
#    through maturin (as `pip install .`) in the same profile: the dependencies and the core are
#    already compiled, and the wheel's build, mostly one chain of crates (PyO3, numpy, the binding),
#    leaves a core free for the tests. Cargo releases the build directory once its tests start
#    running; the wheel's build starts then. The build backend (maturin) was installed into the
#    first test environment with the test dependencies, so pip needs no isolated build
#    environment of its own.
CARGO_LOG=target/cargo-test.log
"${CARGO_TEST[@]}" > "$CARGO_LOG" 2>&1 &
CARGO_PID=$!
cargo_tests_passed() {  # waits for the Rust tests; their summary, or their whole output if they failed
  if wait "$CARGO_PID"; then
    grep -E "^ *(Running|Doc-tests)|^test result:" "$CARGO_LOG"
    stamp "cargo test passed"
  else
    cat "$CARGO_LOG" >&2
    echo "scripts/test.sh: cargo test failed (output above, also in $CARGO_LOG)" >&2
    exit 1
  fi
}
until grep -q "^ *Running " "$CARGO_LOG" 2>/dev/null || ! kill -0 "$CARGO_PID" 2>/dev/null; do sleep 0.2; done
wait_venv 0
WHEELS=target/test-wheels
rm -rf "$WHEELS"
VENV0=target/test-venvs/py$("${PYTHONS[0]}" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
if ! MATURIN_PEP517_ARGS="--profile $PROFILE" "$VENV0/bin/python" -m pip wheel --no-deps --no-build-isolation \
     --disable-pip-version-check --quiet --wheel-dir "$WHEELS" .; then
  wait "$CARGO_PID" || true
  echo "scripts/test.sh: building the wheel failed" >&2
  exit 1
fi
WHEEL=$(ls "$WHEELS"/beamslider-*.whl)
stamp "built $(basename "$WHEEL")"
cargo_tests_passed

# 4. pytest, per Python.
for i in "${!PYTHONS[@]}"; do
  py=${PYTHONS[$i]}
  ver=$("$py" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
  venv=target/test-venvs/py$ver
  [ "$i" = 0 ] || wait_venv "$i"
  # Same version number as an earlier build: replace the package itself.
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps "$WHEEL"
  marks="not slow and not heavy and not docs"
  if [ "$FULL" = 1 ]; then
    marks="not slow and not heavy"
    if [ "$i" = $(( ${#PYTHONS[@]} - 1 )) ]; then marks="not slow"; fi
  fi
  stamp "pytest on Python $ver ($venv), -m '$marks'"
  # Run from a neutral directory so that the installed package (not ./python) is imported.
  # Work stealing: a worker that runs out of tests takes pending ones from the other, so that a
  # few long tests (subprocesses, local Dask clusters) near the end leave no worker idle.
  (cd tests && "../$venv/bin/python" -m pytest -q -p no:cacheprovider -m "$marks" \
     -n "${BEAMSLIDER_TEST_WORKERS:-2}" --dist worksteal --durations=15 .)
done
stamp "all tests passed"
