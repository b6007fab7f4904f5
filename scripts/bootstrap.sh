#!/usr/bin/env bash
# Create or update the project's virtual environment (.venv) and install polywear.
#
#   scripts/bootstrap.sh [EXTRAS]      e.g. scripts/bootstrap.sh test
#
# Idempotent: reinstalls only when pyproject.toml or the requested extras changed.
# Needs Python >= 3.11 as $PYTHON (default: python3). Status lines go to stderr.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$repo/.venv"
extras="${1:-}"
python="${PYTHON:-python3}"

say() { echo "bootstrap: $*" >&2; }

if [ ! -x "$venv/bin/python" ]; then
    "$python" -c 'import sys; sys.exit(sys.version_info < (3, 11))' \
        || { say "error: $python is $("$python" --version 2>&1); polywear needs Python >= 3.11 (set PYTHON=...)"; exit 1; }
    say "creating $venv"
    "$python" -m venv "$venv"
    "$venv/bin/python" -m pip install --quiet --upgrade pip >&2
fi

stamp="$venv/.polywear-install"
want="$(cat "$repo/pyproject.toml" | sha256sum | cut -c1-16) extras=[$extras]"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
    spec="$repo"
    [ -n "$extras" ] && spec="$repo[$extras]"
    say "installing polywear${extras:+[$extras]} into $venv (first time: a minute or two)"
    "$venv/bin/python" -m pip install --quiet -e "$spec" >&2
    echo "$want" > "$stamp"
fi
