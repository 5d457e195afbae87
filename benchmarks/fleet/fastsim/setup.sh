#!/usr/bin/env bash
# Create the isolated FASTSim 2.1.5 environment at benchmarks/fleet/fastsim/.venv.
#
# FASTSim lives in its own virtual environment, never in the project's .venv or
# requirements.lock (its pins, e.g. numpy<2.1, would fight the project's).
# Idempotent: if the venv already imports fastsim 2.1.5 and was built from the
# current requirements.txt (sha256 stamp), nothing is done.
#
# Usage: bash benchmarks/fleet/fastsim/setup.sh   [PYTHON=python3.11]
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
venv="$here/.venv"
req="$here/requirements.txt"
stamp="$venv/.requirements.sha256"
python="${PYTHON:-python3.11}"

want="$(sha256sum "$req" | cut -d' ' -f1)"

if [[ -x "$venv/bin/python" && -f "$stamp" && "$(cat "$stamp")" == "$want" ]] &&
    "$venv/bin/python" -c 'import fastsim, sys; sys.exit(fastsim.__version__ != "2.1.5")' 2>/dev/null; then
    echo "fastsim venv OK: $venv"
    exit 0
fi

if ! "$python" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
    echo "error: $python is not Python 3.11 (requirements.txt is pinned for 3.11)" >&2
    exit 1
fi

rm -rf "$venv"
"$python" -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --require-hashes -r "$req"
"$venv/bin/python" -c 'import logging; logging.disable(logging.WARNING); import fastsim; assert fastsim.__version__ == "2.1.5", fastsim.__version__'
echo "$want" >"$stamp"
echo "fastsim venv created: $venv"
