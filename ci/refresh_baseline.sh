#!/usr/bin/env bash
# Refresh ci/fast_baseline after an intended change of results: run the fast profile in a scratch
# clone of HEAD (the workspace is left alone) and copy the pipeline's metrics files.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
git clone -q "$root" "$tmp/repo"
cd "$tmp/repo"
export PATH="$root/.venv/bin:$PATH" DVC_NO_ANALYTICS=1 PYTHONPATH="$tmp/repo"   # the clone's code, not the workspace's
export GIT_AUTHOR_NAME="${GIT_AUTHOR_NAME:-hev-sizing}" GIT_AUTHOR_EMAIL="${GIT_AUTHOR_EMAIL:-dev@hev-sizing.invalid}"
export GIT_COMMITTER_NAME="$GIT_AUTHOR_NAME" GIT_COMMITTER_EMAIL="$GIT_AUTHOR_EMAIL"
dvc exp run $(hev profile fast)
for f in cycles components baselines doe surrogate_metrics optimise_oracle optimise_nsga3 optimise_moead optimise_moga \
  optimise_parego optimise_nehvi pareto validation headline bound; do
  cp "reports/$f.json" "$root/ci/fast_baseline/$f.json"
done
echo "ci/fast_baseline refreshed from $(git -C "$root" rev-parse --short HEAD)"
