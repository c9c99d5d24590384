#!/usr/bin/env bash
# Times the README's test command from a clean clone and writes the figures where they are quoted:
# docs/results/timing/test_command.txt and the README's block between the timing markers.
#
#   bash scripts/tooling/time_test_command.sh [--rebuild]
#
# Clones HEAD of this repository into a temporary folder, runs `bash scripts/test.sh` there under
# /usr/bin/time (wall and CPU time; the load average before and after says whether the machine
# was idle), then, with --rebuild, the contributor's loop: `maturin develop --release` into the
# clone's test venv, a one-line change in the core (a comment appended to
# crates/beamslider-core/src/lib.rs) and `maturin develop --release` again, timed.
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$(pwd)
REBUILD=0
[ "${1:-}" = "--rebuild" ] && REBUILD=1
WORK=$(mktemp -d "${TMPDIR:-/tmp}/beamslider-timing.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
git clone -q "$ROOT" "$WORK/clone"
COMMIT=$(git -C "$WORK/clone" rev-parse --short HEAD)
CPU=$(grep -m1 "model name" /proc/cpuinfo | sed 's/.*: //')
CORES=$(nproc)
LOAD0=$(cut -d' ' -f1-3 /proc/loadavg)
( cd "$WORK/clone" && /usr/bin/time -f "%e %U %S" -o "$WORK/time" bash scripts/test.sh > "$WORK/log" 2>&1 ) || {
  tail -50 "$WORK/log" >&2; echo "time_test_command.sh: the test command failed" >&2; exit 1; }
LOAD1=$(cut -d' ' -f1-3 /proc/loadavg)
read -r WALL USER SYS < "$WORK/time"
PASSED=$(grep -Eo "[0-9]+ passed(, [0-9]+ (failed|skipped|xfailed|xpassed|errors?))*" "$WORK/log" | tail -1)  # the whole count: passed, skipped, ...
fmt() { printf '%d min %02d s' $(( ${1%.*} / 60 )) $(( ${1%.*} % 60 )); }
CPU_S=$(python3 -c "print(round($USER + $SYS))")
LINE="$(fmt "$WALL") wall, ${CPU_S} s CPU, on $CORES cores ($CPU); load average $LOAD0 before, $LOAD1 after; commit $COMMIT; pytest: $PASSED"
write_results() {  # the figures so far: docs/results/timing/test_command.txt and the README
  mkdir -p docs/results/timing
  {
    echo "bash scripts/test.sh from a clean clone (scripts/tooling/time_test_command.sh$( [ "$REBUILD" = 1 ] && echo " --rebuild"))"
    echo "$LINE"
    [ -n "$REB" ] && echo "$REB"
    echo "stage times (wall seconds since the start; CPU seconds, user + system, of the steps finished by then):"
    grep "scripts/test.sh: \[" "$WORK/log" || true
  } > docs/results/timing/test_command.txt
  cat docs/results/timing/test_command.txt
  python3 - "$LINE" "$REB" <<'PY'
import re, sys
line, reb = sys.argv[1], sys.argv[2]
text = open("README.md", encoding="utf-8").read()
body = f"From a clean clone: **{line}**" + (f"; {reb}" if reb else "") + \
       " ([docs/results/timing/test_command.txt](docs/results/timing/test_command.txt))."
new = re.sub(r"(<!-- timing:begin[^\n]*-->\n).*?(\n<!-- timing:end -->)", lambda m: m.group(1) + body + m.group(2),
             text, flags=re.S)
open("README.md", "w", encoding="utf-8").write(new)
PY
}
REB=""
write_results
if [ "$REBUILD" = 1 ]; then
  cd "$WORK/clone"
  VENV=$(ls -d target/test-venvs/py* | head -1)
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check "maturin>=1.9.4,<2"
  VIRTUAL_ENV=$PWD/$VENV PATH=$PWD/$VENV/bin:$PATH "$VENV/bin/maturin" develop --release -q > /dev/null 2>&1
  echo "// one-line change (timing of the contributor's loop)" >> crates/beamslider-core/src/lib.rs
  /usr/bin/time -f "%e %U %S" -o "$WORK/time2" env VIRTUAL_ENV=$PWD/$VENV PATH=$PWD/$VENV/bin:$PATH \
    "$VENV/bin/maturin" develop --release -q > /dev/null 2>&1
  read -r W2 U2 S2 < "$WORK/time2"
  REB="rebuild after a one-line change in the core (maturin develop --release): $(fmt "$W2") wall, $(python3 -c "print(round($U2 + $S2))") s CPU; load average $(cut -d' ' -f1-3 /proc/loadavg) after"
  cd "$ROOT"
fi
if [ "$REBUILD" = 1 ]; then write_results; fi
