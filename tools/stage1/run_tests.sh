#!/usr/bin/env bash
# Installs what the stage-1 extractor's tests need (numpy, pytest, Pillow; no model packages:
# the tests use stub encoders) and runs them. Exits 0 only when every test passes.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
python3 -m pip install --quiet --disable-pip-version-check numpy pytest pillow
cd "$here"
PYTHONPATH="$here${PYTHONPATH:+:$PYTHONPATH}" exec python3 -m pytest -q -p no:cacheprovider tests "$@"
