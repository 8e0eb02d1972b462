#!/usr/bin/env bash
# Builds the fuzz targets with libFuzzer's coverage instrumentation on the STABLE toolchain (the
# flags cargo-fuzz would pass, without the nightly-only sanitizer flags) and runs them.
#
#   fuzz/run.sh TARGET [SECONDS]      one target (detector, flc, robust, pid, supervisor, pursuit, scenario, osc, run)
#   fuzz/run.sh all [SECONDS]         every target, one after the other (default 60 s each)
#   fuzz/run.sh build                 build only
#
# Corpora grow in fuzz/corpus/TARGET (the scenario corpus is seeded with scenarios/*.toml, the osc
# corpus with the repository's *.xosc and *.xodr files and a few expressions), crashes
# land in fuzz/artifacts/TARGET/. Reproduce one: fuzz/target/<host>/release/TARGET ARTIFACT
# (binaries go to $CARGO_TARGET_DIR instead of fuzz/target when that is set).
# The run lengths and results of the documented campaign are in docs/firmware.md.
set -euo pipefail
cd "$(dirname "$0")"

TARGETS=(detector flc robust pid supervisor pursuit scenario osc run)
what="${1:-all}"
seconds="${2:-60}"
host="$(rustc -vV | sed -n 's/^host: //p')"

export RUSTFLAGS="--cfg fuzzing -Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
-Cllvm-args=-sanitizer-coverage-trace-compares -Cdebug-assertions -Coverflow-checks ${RUSTFLAGS:-}"
# --target keeps the instrumentation away from build scripts and proc macros.
cargo build --release --target "$host" --bins
bin="${CARGO_TARGET_DIR:-target}/$host/release"
[ "$what" = build ] && exit 0

# Seeds of the osc target: the repository's OpenSCENARIO and OpenDRIVE files (if any) and a few expressions.
seed_osc() {
  local dir="$1" i=0
  find .. -path ../fuzz -prune -o -path ../target -prune -o \( -name '*.xosc' -o -name '*.xodr' \) -print 2>/dev/null | while read -r f; do
    cp -n "$f" "$dir/$(basename "$f")" 2>/dev/null || true
  done
  for e in '1 + 2 * 3' '-$a + 1' 'not $t and $a > 2 or false' 'max(min($a, 2), pow(2, 0.5))' 'round(2.5) % 2' '${$a / 3.6}'; do
    i=$((i + 1)); [ -e "$dir/expr$i" ] || printf '%s' "$e" > "$dir/expr$i"
  done
  [ -e "$dir/distribution.xosc" ] || cat > "$dir/distribution.xosc" <<'XML'
<OpenSCENARIO><ParameterValueDistribution><ScenarioFile filepath="s.xosc"/><Deterministic>
<DeterministicSingleParameterDistribution parameterName="A"><DistributionSet><Element value="1"/><Element value="${2*3}"/></DistributionSet></DeterministicSingleParameterDistribution>
<DeterministicSingleParameterDistribution parameterName="B"><DistributionRange stepWidth="0.1"><Range lowerLimit="0" upperLimit="0.3"/></DistributionRange></DeterministicSingleParameterDistribution>
<DeterministicMultiParameterDistribution><ValueSetDistribution><ParameterValueSet><ParameterAssignment parameterRef="C" value="x"/></ParameterValueSet></ValueSetDistribution></DeterministicMultiParameterDistribution>
</Deterministic></ParameterValueDistribution></OpenSCENARIO>
XML
}

run_one() {
  local t="$1"
  mkdir -p "corpus/$t" "artifacts/$t"
  if [ "$t" = scenario ] || [ "$t" = run ]; then cp -n ../scenarios/*.toml "corpus/$t/" 2>/dev/null || true; fi
  if [ "$t" = osc ]; then seed_osc "corpus/$t"; fi
  # Whole runs (issue 29): an input that takes more than 10 s or 2 GiB is a failure.
  local limits=(-rss_limit_mb=4096)
  if [ "$t" = run ]; then limits=(-rss_limit_mb=2048 -timeout=10); fi
  echo "== fuzz $t for ${seconds}s"
  "$bin/$t" "corpus/$t" -max_total_time="$seconds" -print_final_stats=1 \
    -artifact_prefix="artifacts/$t/" -max_len=65536 "${limits[@]}"
}

if [ "$what" = all ]; then
  for t in "${TARGETS[@]}"; do run_one "$t"; done
else
  run_one "$what"
fi
