#!/usr/bin/env bash
# Bounded-time fuzzing of the file readers (docs/guide/reliability.md):
#   Rust:   TOML parameters, map configuration, map results (JSON lines, --resume)
#           -> crates/beamslider-core/examples/fuzz_readers.rs
#   Python: measured files (beamslider.read_measurement), parameter TOML, the CSV readers of
#           `beamslider plot` -> scripts/tooling/fuzz_readers.py (needs the package installed)
# Usage: bash scripts/tooling/fuzz.sh [SECONDS_PER_FUZZER (default 60)] [SEED (default 1)]
# Prints the executions and the findings of each; exits non-zero when either found something.
# Inputs that trigger a finding are saved under fuzz-findings/.
set -uo pipefail
cd "$(dirname "$0")/../.."
secs="${1:-60}"
seed="${2:-1}"
status=0
cargo run --quiet --release -p beamslider-core --example fuzz_readers -- --seconds "$secs" --seed "$seed" --findings fuzz-findings || status=1
python3 scripts/tooling/fuzz_readers.py --seconds "$secs" --seed "$seed" --findings fuzz-findings || status=1
exit $status
