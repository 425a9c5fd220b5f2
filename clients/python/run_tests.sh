#!/usr/bin/env bash
# Installs the Python client's dependencies and runs its pytest suite against a live
# `splatphys serve --fake` and `splatphys-zenoh` (build them first: cargo build --release -p
# splatphys -p splatphys-zenoh).
# Exits 0 only when every test passes.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
python3 -m pip install --quiet --disable-pip-version-check "iceoryx2==0.10.0" "eclipse-zenoh==1.10.2" "rosbags==0.11.9" numpy pytest
cd "$here"
PYTHONPATH="$here${PYTHONPATH:+:$PYTHONPATH}" exec python3 -m pytest -q tests "$@"
