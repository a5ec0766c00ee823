#!/usr/bin/env bash
# Every test: the Rust workspace's (`cargo test`), then the Python package's: its wheel built with maturin into a
# fresh virtual environment (with numpy, pytest and OpenEXR from PyPI, and matplotlib and pyoidn for the notebooks in
# examples/, which pytest runs), and pytest on python/tests against the command line built here. Prints one closing line per part. Needs cargo and python3 with venv and pip.
#
#   scripts/test.sh                 # what CI runs (.ci/run) and the README's test command
#   scripts/test.sh --rust-only     # the cargo tests alone
set -euo pipefail
cd "$(dirname "$0")/.."
log=$(mktemp)
venv_dir=$(mktemp -d)
trap 'rm -rf "$log" "$venv_dir"' EXIT

cargo test --workspace --profile quick-release 2>&1 | tee "$log"
# One closing line over every test binary (cargo prints one result line per binary).
awk '/^test result:/ { p += $4; f += $6 } END { printf "total (Rust): %d passed, %d failed\n", p, f }' "$log"
[[ "${1:-}" == "--rust-only" ]] && exit 0

echo "== the Python package: a wheel into a fresh virtual environment, then pytest"
# The command line the Python tests compare against: the cargo tests built it (the prismatic crate's integration
# tests need it). A separate `cargo build -p prismatic` would resolve features for that crate alone, without what
# the workspace's dev-dependencies enable (render's `internals`), and compile render and the binary again.
[[ -x target/quick-release/prismatic ]] || { echo "target/quick-release/prismatic was not built" >&2; exit 1; }
python3 -m venv "$venv_dir/venv"
py="$venv_dir/venv/bin/python"
"$py" -m pip install -q --disable-pip-version-check "maturin>=1.5,<2" numpy pytest matplotlib pyoidn OpenEXR
# The workspace's quick-release profile and the features the cargo tests' build unified (render's `internals`, from
# dev-dependencies), so the crates it built are reused: only PyO3 (with `extension-module`) and the package compile.
(cd python && "$py" -m maturin build -q --profile quick-release --features render/internals --out "$venv_dir/dist")
"$py" -m pip install -q --disable-pip-version-check "$venv_dir"/dist/prismatic-*.whl
PRISMATIC_BIN="$PWD/target/quick-release/prismatic" "$py" -m pytest -q -p no:cacheprovider python/tests
