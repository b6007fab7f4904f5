#!/usr/bin/env bash
# Run polywear's test suite (sets itself up on first use, AUTO-07p and Chromium included).
#
#   ./test.sh                the whole suite, slow cross-checks included (as CI)
#   ./test.sh PYTEST_ARGS    e.g. ./test.sh -m "not slow" tests/test_params.py
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
"$repo/scripts/bootstrap.sh" test
"$repo/scripts/ensure-auto07p.sh" "$repo/.venv"
"$repo/scripts/ensure-chromium.sh"
cd "$repo"
# One OpenBLAS kernel on every x86-64 machine with AVX2, so that rounding is the same as where
# the suite's tolerances were measured: with the AVX-512 kernels one check moved past its own
# (edges against the full continuation on a cascade car, 2.3e-6 against 1e-6 km/h: docs/fleet.md)
if [ -z "${OPENBLAS_CORETYPE:-}" ] && grep -qw avx2 /proc/cpuinfo 2>/dev/null; then
    export OPENBLAS_CORETYPE=Haswell
fi
exec "$repo/.venv/bin/python" -m pytest "$@"
