#!/usr/bin/env bash
# The whole test suite from a clean checkout: the Rust tests, then the Python package
# (crates/photostereo-py) built into a virtual environment made here and its pytest
# tests, Dask included. Nothing is skipped silently: a wheel that does not build, a
# dependency that cannot be installed or a pytest run that collects no test fails, and
# the last line counts the Rust tests skipped (`skipped tests: N`).
#
#   scripts/test-all.sh            # everything
#   PHOTOSTEREO_VENV=DIR ...       # the venv to use (default .venv-test, made if missing)
set -euo pipefail
cd "$(dirname "$0")/.."

# A Rust test skipped for want of ../shared or Chromium prints `SKIP <test>: <why>` and
# leaves one marker file here (crates/photostereo/tests/common/shared.rs); the log ends with
# their count, pass or fail. (.ci/run makes such a skip a failure instead.)
if [ -z "${PHOTOSTEREO_SKIP_DIR:-}" ]; then
  PHOTOSTEREO_SKIP_DIR="$(mktemp -d)"
  export PHOTOSTEREO_SKIP_DIR
  skip_summary() {
    local n
    n=$(find "$PHOTOSTEREO_SKIP_DIR" -type f | wc -l)
    echo "skipped tests: $n"
    if [ "$n" -gt 0 ]; then
      cat "$PHOTOSTEREO_SKIP_DIR"/*
    fi
    rm -rf "$PHOTOSTEREO_SKIP_DIR"
  }
  trap skip_summary EXIT
fi

cargo test --release
# the CLI renders the Python tests' data (cargo test built it already; this is a no-op then)
cargo build --release -p photostereo-cli

venv="${PHOTOSTEREO_VENV:-.venv-test}"
python="${PYTHON:-python3}"
if [ ! -x "$venv/bin/python" ]; then
  "$python" -m venv "$venv"
fi
venv="$(cd "$venv" && pwd)"
t0=$(date +%s)
# builds the abi3 wheel with maturin (release) and installs it with numpy, dask, pytest
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
  "./crates/photostereo-py[dask,test]"
echo "python package built and installed in $(( $(date +%s) - t0 )) s"
"$venv/bin/python" -c "import photostereo, dask.distributed; print('photostereo', photostereo.__version__)"

# pytest exits 5 when it collects nothing: that fails here too
export PHOTOSTEREO_BIN="$PWD/target/release/photostereo"
cd crates/photostereo-py/tests
"$venv/bin/python" -m pytest -q -p no:cacheprovider .
