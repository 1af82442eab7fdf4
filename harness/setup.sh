#!/usr/bin/env bash
# Build the release binary and library, and install the harness's Python environment in .venv
# (fmpy, fmutool, pytest, numpy, matplotlib from harness/requirements.txt). Idempotent: pip runs
# only when requirements.txt changed since the last install.
set -euo pipefail
cd "$(dirname "$0")/.."

cargo build --release

if [ ! -x .venv/bin/python ]; then
  if ! python3 -m venv .venv; then
    # Debian splits venv support out of python3.
    apt-get update -qq && apt-get install -y -qq python3-venv
    rm -rf .venv
    python3 -m venv .venv
  fi
fi
if ! cmp -s harness/requirements.txt .venv/.requirements.installed; then
  .venv/bin/python -m pip install --quiet --disable-pip-version-check -r harness/requirements.txt
  cp harness/requirements.txt .venv/.requirements.installed
fi
