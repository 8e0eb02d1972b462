#!/usr/bin/env bash
# Builds the fuzz targets with libFuzzer's coverage instrumentation on the STABLE toolchain (the
# flags cargo-fuzz would pass, without the nightly-only sanitizer flags) and runs them.
#
#   fuzz/run.sh TARGET [SECONDS]      one target (detector, flc, pid, supervisor, pursuit, scenario)
#   fuzz/run.sh all [SECONDS]         every target, one after the other (default 60 s each)
#   fuzz/run.sh build                 build only
#
# Corpora grow in fuzz/corpus/TARGET (the scenario corpus is seeded with scenarios/*.toml), crashes
# land in fuzz/artifacts/TARGET/. Reproduce one: fuzz/target/<host>/release/TARGET ARTIFACT.
# The run lengths and results of the documented campaign are in docs/firmware.md.
set -euo pipefail
cd "$(dirname "$0")"

TARGETS=(detector flc pid supervisor pursuit scenario)
what="${1:-all}"
seconds="${2:-60}"
host="$(rustc -vV | sed -n 's/^host: //p')"

export RUSTFLAGS="--cfg fuzzing -Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares -Cdebug-assertions -Coverflow-checks ${RUSTFLAGS:-}"
# --target keeps the instrumentation away from build scripts and proc macros.
cargo build --release --target "$host" --bins
[ "$what" = build ] && exit 0

run_one() {
  local t="$1"
  mkdir -p "corpus/$t" "artifacts/$t"
  if [ "$t" = scenario ]; then cp -n ../scenarios/*.toml "corpus/$t/" 2>/dev/null || true; fi
  echo "== fuzz $t for ${seconds}s"
  "target/$host/release/$t" "corpus/$t" -max_total_time="$seconds" -print_final_stats=1 \
    -artifact_prefix="artifacts/$t/" -max_len=65536 -rss_limit_mb=4096
}

if [ "$what" = all ]; then
  for t in "${TARGETS[@]}"; do run_one "$t"; done
else
  run_one "$what"
fi
