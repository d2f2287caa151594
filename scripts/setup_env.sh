#!/usr/bin/env bash
# Create .venv and install the pinned dependencies and the workspace packages.
# Idempotent: re-runs only when requirements.lock or a package's setup.py changed.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3}"
VENV=.venv
STAMP="$VENV/.setup-stamp"

"$PYTHON" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)' || {
  echo "setup: Python 3.11 or newer is required (found $("$PYTHON" --version 2>&1))" >&2; exit 1; }

if [ ! -x "$VENV/bin/python" ]; then
  if ! "$PYTHON" -m venv "$VENV" 2>/dev/null; then
    # Debian/Ubuntu ship venv separately.
    echo "setup: python venv module missing; installing python3-venv" >&2
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -q && $SUDO apt-get install -y -q python3-venv
    rm -rf "$VENV"; "$PYTHON" -m venv "$VENV"
  fi
fi

want=$(cat requirements.lock src/*/setup.py src/*/package.xml | sha256sum | cut -d' ' -f1)
if [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$want" ]; then exit 0; fi

echo "setup: installing pinned dependencies into $VENV (first run takes a few minutes)"
"$VENV/bin/python" -m pip install -q --upgrade pip >"$VENV/setup.log" 2>&1
"$VENV/bin/python" -m pip install -q -r requirements.lock >>"$VENV/setup.log" 2>&1 || { cat "$VENV/setup.log" >&2; exit 1; }
for pkg in src/*/; do
  "$VENV/bin/python" -m pip install -q --no-deps --no-build-isolation -e "$pkg" >>"$VENV/setup.log" 2>&1 || { cat "$VENV/setup.log" >&2; exit 1; }
done
echo "$want" > "$STAMP"
echo "setup: done"
