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
exec "$repo/.venv/bin/python" -m pytest "$@"
