#!/usr/bin/env bash
# Make AUTO-07p available to polywear's validation code (idempotent).
#
#   scripts/ensure-auto07p.sh [VENV]      (VENV defaults to the repository's .venv)
#
# AUTO-07p comes from PyPI as bifpy, which compiles AUTO-07p's Fortran sources at
# install time: it needs gfortran and GNU make. This script
#   1. installs gfortran (and make) with apt-get, only if missing and only when run
#      as root; otherwise it stops with a message saying what to install;
#   2. pip-installs the bifpy version pinned in pyproject.toml's `auto07p` extra into
#      VENV, only if `import bifpy.auto` fails there;
#   3. checks that the installed bifpy imports and finds its compiled AUTO library.
# Status lines go to stderr. Exit code 0 when AUTO-07p is usable, non-zero otherwise.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${1:-$repo/.venv}"
py="$venv/bin/python"

say() { echo "ensure-auto07p: $*" >&2; }
die() { say "error: $*"; exit 1; }

[ -x "$py" ] || die "no Python at $py (give the virtualenv as the first argument)"

missing=()
command -v gfortran >/dev/null 2>&1 || missing+=(gfortran)
if ! make --version 2>/dev/null | grep -q "GNU Make"; then missing+=(make); fi
if [ ${#missing[@]} -gt 0 ]; then
    if [ "$(id -u)" -ne 0 ]; then
        die "missing ${missing[*]} (needed to build AUTO-07p) and not root: install them, e.g. 'sudo apt-get install ${missing[*]}', then run this again"
    fi
    command -v apt-get >/dev/null 2>&1 || die "missing ${missing[*]} and no apt-get to install them with"
    say "installing ${missing[*]} with apt-get"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >&2 || die "apt-get update failed"
    apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2 \
        || die "apt-get install ${missing[*]} failed"
else
    say "gfortran and GNU make present"
fi

if "$py" -c "import bifpy.auto" >/dev/null 2>&1; then
    say "bifpy already importable in $venv"
else
    requirement="$("$py" - "$repo/pyproject.toml" <<'PY'
import sys, tomllib
with open(sys.argv[1], "rb") as fh:
    print(tomllib.load(fh)["project"]["optional-dependencies"]["auto07p"][0])
PY
)"
    say "pip-installing $requirement into $venv (compiles AUTO-07p, about half a minute)"
    start=$SECONDS
    "$py" -m pip install --quiet "$requirement" >&2 || die "pip install $requirement failed"
    say "installed in $((SECONDS - start)) s"
fi

"$py" - <<'PY' || die "bifpy is installed but its AUTO-07p library does not load"
import importlib.metadata, pathlib, sys
import bifpy.auto._capi as capi
lib = pathlib.Path(capi.__file__).parent / "_lib"
needed = [lib / "main.o", lib / "libbifpy.a"]
if not any(lib.glob("libbifpy.*")) or not all(p.exists() for p in needed):
    sys.exit(f"AUTO-07p build products missing in {lib}")
print(f"ensure-auto07p: bifpy {importlib.metadata.version('bifpy')} ready", file=sys.stderr)
PY
