#!/usr/bin/env bash
# Make headless Chromium available for the report test (tests/test_report_browser.py).
#
#   scripts/ensure-chromium.sh
#
# Installs Debian's `chromium` package with apt-get, only if no Chromium is on PATH and
# only when run as root; otherwise it says what to install and exits 0 (the browser
# test is then skipped with that reason, the rest of the suite does not need it).
# Status lines go to stderr.
set -euo pipefail

say() { echo "ensure-chromium: $*" >&2; }

for name in chromium chromium-browser google-chrome google-chrome-stable; do
    if command -v "$name" >/dev/null 2>&1; then
        say "$name present"
        exit 0
    fi
done
if [ "$(id -u)" -ne 0 ] || ! command -v apt-get >/dev/null 2>&1; then
    say "no Chromium and not root with apt-get: the report browser test will be skipped (install it, e.g. 'sudo apt-get install chromium')"
    exit 0
fi
say "installing chromium with apt-get (a minute or two)"
export DEBIAN_FRONTEND=noninteractive
if apt-get update -qq >&2 && apt-get install -y -qq --no-install-recommends chromium >&2; then
    say "chromium installed"
else
    say "apt-get install chromium failed: the report browser test will be skipped"
fi
