#!/usr/bin/env bash
# Bounded libFuzzer run: run-fuzz.sh <fuzzer> <seed-dir> <work-dir> [seconds]. Seconds: IMUFORGE_FUZZ_SECONDS,
# else the 4th argument, else 60. The seed directory is only read (new inputs go to <work-dir>/corpus).
# Fails on a crash, a sanitizer report or a violated harness invariant (they all abort the fuzzer).
set -euo pipefail
fuzzer=$1; seeds=$2; work=$3
secs="${IMUFORGE_FUZZ_SECONDS:-${4:-60}}"
mkdir -p "$work/corpus" "$work/artifacts"
cd "$work"
"$fuzzer" -max_total_time="$secs" -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$work/artifacts/" \
  "$work/corpus" "$seeds" 2>&1 | grep -vE '^    #[1-9][0-9]' | tail -40
