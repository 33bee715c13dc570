#!/usr/bin/env bash
# One command on a fresh Debian machine: install dependencies, build, run the
# whole test suite, then build and run it again under AddressSanitizer and
# UndefinedBehaviorSanitizer (skip that with --no-sanitize), then fuzz every
# parser for a bounded time (FUZZ_SECONDS per target, default 30; --no-fuzz
# skips it).
set -euo pipefail
cd "$(dirname "$0")/.."
sanitize=1
fuzz=1
for a in "$@"; do
  [ "$a" = "--no-sanitize" ] && sanitize=0
  [ "$a" = "--no-fuzz" ] && fuzz=0
done
bash scripts/install-deps.sh
bash scripts/build.sh build
(cd build && ctest --output-on-failure -j 2 --timeout 900 -LE workflow)
# The batch workflow, locally and on a one-node Slurm cluster on localhost
# (snakemake, slurm-wlm, munge; about 1.5 min).
bash scripts/install-workflow-deps.sh
(cd build && ctest --output-on-failure --timeout 900 -L workflow)
if [ "$sanitize" = 1 ]; then
  # -O1 -g1: the sanitizers need frames, not full debug info; keeps CI's
  # second build within its time.
  bash scripts/build.sh build-asan -DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS_RELEASE=-O1 -g1" \
    -DSHADOWSG_SANITIZE=ON -DSHADOWSG_BUILD_BENCHMARKS=OFF
  # Embree's and OpenMP's own allocations are not ours: leaks are not checked
  # here (LeakSanitizer), addressing and undefined behaviour are. Tests
  # labelled slow (whole solver runs), colmap (the COLMAP subprocess) or workflow ran in
  # the Release pass; under the sanitizers they would take most of CI's hour.
  (cd build-asan && ASAN_OPTIONS=detect_leaks=0 UBSAN_OPTIONS=print_stacktrace=1 \
     ctest --output-on-failure -j 2 --timeout 1800 -LE "slow|colmap|workflow")
fi
if [ "$fuzz" = 1 ]; then
  # libFuzzer (clang, ASan + UBSan) on each parser: 10 targets x 30 s, plus
  # a build of the readers alone (about 2 min on 2 cores).
  bash scripts/fuzz.sh "${FUZZ_SECONDS:-30}"
fi
