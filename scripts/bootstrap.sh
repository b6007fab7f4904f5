#!/usr/bin/env bash
# Create or update the project's virtual environment (.venv) and install polywear.
#
#   scripts/bootstrap.sh [EXTRAS]      e.g. scripts/bootstrap.sh test
#
# Idempotent: installs only when pyproject.toml changed or a requested extra is missing.
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

# The stamp records what is installed: pyproject.toml's hash and the extras. pip runs
# only when pyproject.toml changed or an extra is wanted that is not installed yet (then
# with the union of the old and the new extras); otherwise nothing touches the network,
# so `./run.sh` after `./test.sh` neither reinstalls nor needs to be online.
stamp="$venv/.polywear-install"
hash="$(sha256sum < "$repo/pyproject.toml" | cut -c1-16)"
old_hash=""
old_extras=""
if [ -f "$stamp" ]; then
    old_hash="$(sed -n 's/^pyproject=//p' "$stamp")"
    old_extras="$(sed -n 's/^extras=//p' "$stamp")"
    [ -n "$old_hash" ] || old_extras="$(sed -n 's/.* extras=\[\(.*\)\]$/\1/p' "$stamp")"  # older one-line stamp
fi
# union of the installed and the requested extras, sorted, comma-separated
all_extras="$(printf '%s\n' ${old_extras//,/ } ${extras//,/ } | sed '/^$/d' | sort -u | paste -sd, -)"
if [ "$hash" != "$old_hash" ] || [ "$all_extras" != "$old_extras" ]; then
    spec="$repo"
    [ -n "$all_extras" ] && spec="$repo[$all_extras]"
    say "installing polywear${all_extras:+[$all_extras]} into $venv (a minute or two the first time)"
    "$venv/bin/python" -m pip install --quiet -e "$spec" >&2
    printf 'pyproject=%s\nextras=%s\n' "$hash" "$all_extras" > "$stamp"
fi
