#!/usr/bin/env bash
# Run polywear's main job on the built-in defaults (sets itself up on first use).
#
#   ./run.sh                 full analysis of the defaults, written to ./out/
#   ./run.sh ARGS...         any polywear command, e.g. ./run.sh bifurcation --json
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
"$repo/scripts/bootstrap.sh"
if [ $# -eq 0 ]; then
    exec "$repo/.venv/bin/polywear" report --out "$repo/out"
fi
exec "$repo/.venv/bin/polywear" "$@"
