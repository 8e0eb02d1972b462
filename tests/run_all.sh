#!/usr/bin/env bash
# The one command that installs what the tests need and runs every test (Rust and Python).
# Used by .ci/run and documented in README.md.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== Rust: no_std build of flc-core (host)"
cargo build --locked -p flc-core --no-default-features
if rustup target list --installed 2>/dev/null | grep -q thumbv7em-none-eabihf; then
  echo "== Rust: cross build of flc-core for thumbv7em-none-eabihf"
  cargo build --locked -p flc-core --no-default-features --target thumbv7em-none-eabihf
  cargo build --locked -p flc-core --no-default-features --features capi --target thumbv7em-none-eabihf
else
  echo "== Rust: thumbv7em-none-eabihf not installed, cross build skipped (host no_std build ran)"
fi

echo "== Rust: clippy"
cargo clippy --locked --workspace --all-targets -- -D warnings

echo "== Rust: the fuzz targets compile against today's core (fuzz/run.sh runs them; docs/firmware.md)"
cargo check --locked --manifest-path fuzz/Cargo.toml --bins

echo "== Rust: flc-core C interface (feature capi): no_std build, clippy, C API == Rust API properties"
cargo build --locked -p flc-core --no-default-features --features capi
cargo clippy --locked -p flc-core --all-targets --features capi -- -D warnings
cargo test --locked -p flc-core --features capi --test capi_properties --test firmware_doc

echo "== Rust: flc-core firmware checks (header up to date, C example == Rust, no panic path, no alloc, stack bounds)"
cargo test --locked -p flc-core --test c_header --test c_api

echo "== Rust: tests"
cargo test --locked

echo "== Rust: golden outputs, byte for byte (release; tests/golden/README.md)"
cargo test --locked --release -p flc-sim --test golden

echo "== Rust: detector acceptance tests (release; docs/detector.md, issue 23)"
cargo test --locked --release -p flc-sim --test detection

echo "== Rust: hostile sizes exit at once, mutated scenario files never hang or panic (release; issue 29)"
# The size tests time the CLI: one at a time, so that they do not compete with each other.
cargo test --locked --release -p flc-sim --test bounds -- --test-threads=1
cargo test --locked --release -p flc-sim --test mutation

echo "== Rust: robust FLC v2 against missed detections (release; issue 24)"
cargo test --locked --release -p flc-sim --test robust_flc2

echo "== Rust: robust FLC, the cut-in grid and the hour of three-lane traffic (release; issue 47)"
# Each is marked slow in debug, so `cargo test` above skips them.
cargo test --locked --release -p flc-sim --test robust_flc --test cut_in_grid --test false_cut_ins

echo "== Rust: the main job's build, so that \`cargo run --release --bin scenario\` starts at once afterwards"
# The release tests above build the dependencies with flc-sim's dev-dependencies' features unified in
# (serde \`alloc\`, serde_json \`float_roundtrip\`, zerocopy \`derive\`: \`cargo tree -e features\`), so
# the binary alone needs its own build of ~22 crates (serde and its dependents: rapier2d, parry2d,
# foxglove, mcap, rand, flc-core, flc-sim), 2 min 48 s on the first \`cargo run\` otherwise.
cargo build --locked --release --bin scenario

echo "== ASAM's quality checker: every .xosc/.xodr the project ships or writes has 0 issues (tools/asam_qc.py)"
# Its own venv: asam-qc-opendrive pins numpy < 2 and Python >= 3.10 (tools/asam_qc-requirements.txt).
QC_VENV="${FLC_QC_VENV:-target/qc-venv}"
python3 -m venv "$QC_VENV"
"$QC_VENV/bin/python" -m pip install --quiet -r tools/asam_qc-requirements.txt
"$QC_VENV/bin/python" tools/asam_qc.py --self-test
"$QC_VENV/bin/python" tools/asam_qc.py

echo "== Python: build the package from source and install it with its test dependencies"
VENV="${FLC_VENV:-target/ci-venv}"
python3 -m venv "$VENV"
"$VENV/bin/python" -m pip install --quiet --upgrade pip
# The `dist` profile without fat LTO: the same code (LTO changes codegen only, and the wheel's
# figures in docs/benchmarks.md are measured with the full profile); a third of the build time.
CARGO_PROFILE_DIST_LTO=false CARGO_PROFILE_DIST_CODEGEN_UNITS=16 "$VENV/bin/python" -m pip install --quiet ".[test]"

echo "== Python: stubs match the built module"
"$VENV/bin/python" -m mypy.stubtest flc._flc --ignore-missing-stub
"$VENV/bin/python" -m mypy python/flc --ignore-missing-imports

echo "== Docs: every generated block equals the code's output (python -m flc docs --check; docs/README.md)"
"$VENV/bin/python" -m flc docs --check

echo "== Python: tests"
"$VENV/bin/python" -m pytest -q tests/python

echo "== Euro NCAP's 2026 rating calculator (installed by the test extra) on one controller's ncap-ccr-2026 runs"
mkdir -p target/ncap
FLC_PYTHON="$VENV/bin/python" cargo run --quiet --release --bin scenario -- suite ncap-ccr-2026 --controllers flc-robust \
  --ncap-workbook target/ncap/flc-robust.xlsx

echo "== Python: the sdist builds and installs in a fresh venv (the way users install from source)"
# Its own target directory: the sdist's files carry old timestamps, so a shared one could hand back
# an extension built from other sources. Fat LTO off for time (the same sources and dependencies;
# the wheels keep the full `dist` profile).
"$VENV/bin/python" -m pip install --quiet "maturin>=1.9.4,<2"
SDIST_DIR="target/sdist"
rm -rf "$SDIST_DIR" target/sdist-venv target/sdist-build
"$VENV/bin/maturin" sdist -o "$SDIST_DIR"
python3 -m venv target/sdist-venv
# With the `plot` extra (the smoke test draws figures from a temporary folder) and `safety` (its
# docs check renders the falsification block, which needs cmaes). `--no-cache-dir`: pip caches the
# wheel it built from a local sdist by its path, and would install an old build of the same path.
SDIST="$(ls "$PWD/$SDIST_DIR"/flc-*.tar.gz)"
CARGO_TARGET_DIR="$PWD/target/sdist-build" CARGO_PROFILE_DIST_LTO=false CARGO_PROFILE_DIST_CODEGEN_UNITS=16 \
  target/sdist-venv/bin/python -m pip install --quiet --no-cache-dir "flc[plot,safety] @ file://$SDIST"
(cd target && sdist-venv/bin/python "$OLDPWD/tests/sdist_smoke.py")
