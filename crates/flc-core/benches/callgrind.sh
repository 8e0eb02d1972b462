#!/usr/bin/env bash
# Instruction counts of the flc-core step functions with valgrind's callgrind (repeatable on
# noisy machines, unlike times). Counts only inside the measured function (--toggle-collect) and
# prints instructions per call; results in docs/benchmarks.md.
#
#   crates/flc-core/benches/callgrind.sh
set -euo pipefail
cd "$(dirname "$0")/../../.."
cargo build --locked -q --release -p flc-core --example instructions
exe=target/release/examples/instructions
tmp="$(mktemp -d)"
count() { # workload, function, calls
  valgrind --tool=callgrind --callgrind-out-file="$tmp/out" --toggle-collect="*instructions::$2*" "$exe" "$1" \
    2> "$tmp/log" > /dev/null
  local ir
  ir=$(sed -n 's/.*Collected : *\([0-9]*\).*/\1/p' "$tmp/log")
  printf "%-14s %10d instructions per call (%d calls, %d in all)\n" "$1" $((ir / $3)) "$3" "$ir"
}
count flc flc_steps 10000
count robust robust_steps 10000
count robust2 robust2_steps 10000
count odo odo_steps 10000
count pid pid_steps 10000
count supervisor supervisor_steps 10000
count pursuit pursuit_steps 10000
count detector900 detector_scans 100
count detector1800 detector_scans 100
count tracker1800 tracker_scans 100
rm -rf "$tmp"
