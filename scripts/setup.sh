#!/usr/bin/env bash
# Create .venv beside this repo and install the studio into it (editable), with optional extras.
# Re-installs only when pyproject.toml changes. Usage: scripts/setup.sh [test]
set -euo pipefail
cd "$(dirname "$0")/.."
extras="${1:-}"
python="${PYTHON:-python3}"
# 3.11: mujoco 4 needs it, and the code uses tomllib and datetime.UTC.
if ! "$python" -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
  echo "Biped Studio needs Python 3.11 or newer ($python is $("$python" --version 2>&1)); set PYTHON=python3.11 (or newer)." >&2
  exit 1
fi
if ! "$python" -c 'import ensurepip, venv' 2>/dev/null; then
  echo "Python's venv module is missing: on Debian/Ubuntu, sudo apt-get install python3-venv" >&2
  exit 1
fi
# A venv that no longer runs (its Python was removed, or the checkout moved: its scripts point
# to the old path and the editable install imports the old code) is made anew.
venv_runs() {
  .venv/bin/python -I - "$PWD" >/dev/null 2>&1 <<'PY' || return 1
import pathlib, sys
try:
    import app
except ImportError:  # not installed yet: nothing points elsewhere
    sys.exit(0)
sys.exit(not pathlib.Path(app.__file__).resolve().is_relative_to(pathlib.Path(sys.argv[1]).resolve()))
PY
  local interpreter
  interpreter="$(head -n 1 .venv/bin/pip 2>/dev/null | cut -c3-)"
  [ -z "$interpreter" ] || [ -x "$interpreter" ] || return 1
  # A venv made without pip (python3-venv missing at the time) never installs anything.
  .venv/bin/python -m pip --version >/dev/null 2>&1
}
if [ -e .venv ] && ! venv_runs; then
  echo "The virtual environment in .venv no longer runs this checkout: making it anew…"
  rm -rf .venv
fi
[ -x .venv/bin/python ] || "$python" -m venv .venv
stamp=".venv/.installed-$(sha256sum pyproject.toml | cut -c1-16)-${extras:-base}"
if [ ! -f "$stamp" ]; then
  echo "Installing Biped Studio and its dependencies into .venv (first run takes a few minutes)…"
  .venv/bin/python -m pip install --quiet --upgrade pip
  if [ -n "$extras" ]; then
    .venv/bin/python -m pip install --quiet -e ".[$extras]"
  else
    .venv/bin/python -m pip install --quiet -e .
  fi
  touch "$stamp"
fi
