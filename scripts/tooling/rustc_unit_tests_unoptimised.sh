#!/usr/bin/env bash
# The RUSTC_WRAPPER of scripts/test.sh: compiles the core's unit-test harness (beamslider-core's
# library built with --test) without optimisation, every other crate exactly as Cargo asks.
#
# The unit tests need a second compilation of the whole core (the library with cfg(test)); in the
# ci-wheel profile that is ~95 s CPU at opt-level 3 and ~17 s at 0, and the unit tests still run in
# about a second. A Cargo profile cannot tell the harness from the library (it is one package), and
# a second cargo invocation with a per-package override resolves features for a different package
# set, so it recompiles the dependencies. Cargo does not fingerprint RUSTC_WRAPPER: the library,
# the dependencies and the integration tests are the same artifacts with or without this wrapper,
# and the wheel's build (no wrapper) reuses them. Floating-point results do not depend on the
# optimisation level (Rust does not contract or reassociate).
#
#   RUSTC_WRAPPER=scripts/tooling/rustc_unit_tests_unoptimised.sh cargo test --profile ci-wheel ...
harness=0 core=0
for a in "$@"; do
  case "$a" in
    --test) harness=1 ;;
    beamslider_core) core=1 ;;
  esac
done
if [ "$harness$core" = 11 ]; then
  exec "$@" -C opt-level=0
fi
exec "$@"
