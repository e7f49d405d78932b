#!/usr/bin/env bash
# Builds and runs every test of every preset: the two cross targets under qemu, the host build, and the
# host build under ASan/UBSan. Prints one closing line "N passed, N failed" over all of them.
set -uo pipefail
cd "$(dirname "$0")/.."
presets=(cortex-m4f cortex-m3 host host-sanitize)
total_pass=0; total_fail=0; failed_presets=()
for p in "${presets[@]}"; do
  echo "=== workflow preset: $p ==="
  log="build/ci-$p.log"
  mkdir -p build
  cmake --workflow --preset "$p" 2>&1 | tee "$log"
  rc=${PIPESTATUS[0]}
  line=$(grep -E "tests passed, [0-9]+ tests failed out of [0-9]+" "$log" | tail -1)
  if [ -n "$line" ]; then
    n_total=$(sed -E 's/.*out of ([0-9]+).*/\1/' <<<"$line")
    n_fail=$(sed -E 's/.* ([0-9]+) tests failed.*/\1/' <<<"$line")
    total_pass=$((total_pass + n_total - n_fail)); total_fail=$((total_fail + n_fail))
  fi
  if [ "$rc" -ne 0 ]; then
    failed_presets+=("$p")
    [ -z "$line" ] && total_fail=$((total_fail + 1))   # configure or build failed: count it
  fi
done
echo
[ ${#failed_presets[@]} -gt 0 ] && echo "failed presets: ${failed_presets[*]}"
echo "total: ${total_pass} passed, ${total_fail} failed"
[ ${#failed_presets[@]} -eq 0 ]
