#!/usr/bin/env bash
# Refresh requirements.lock: every dependency of pyproject.toml (with the dev extra) pinned to one version
# with the sha256 of each of its distribution files, for Python 3.11 on this platform (torch stays on its
# CPU build, pinned in pyproject.toml). Resolved with pip-tools in a throwaway venv; commit the result.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
python3.11 -m venv "$tmp/venv"
"$tmp/venv/bin/pip" install --quiet pip-tools
cd "$root"
"$tmp/venv/bin/pip-compile" --quiet --generate-hashes --allow-unsafe --extra dev --strip-extras \
  --no-emit-index-url --no-emit-find-links -o requirements.lock pyproject.toml
echo "requirements.lock refreshed: $(grep -c '^[A-Za-z0-9]' requirements.lock) pinned packages"
