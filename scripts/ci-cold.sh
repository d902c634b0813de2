#!/usr/bin/env bash
# Runs CI (.ci/run) as a CI machine without a warm cache does: on a fresh
# clone of the committed HEAD, with CI=true and an empty ccache (CCACHE_DIR a
# new directory), then prints each stage's time and the total. Use it before
# submitting a change to CI or to the build. Uncommitted changes are not in
# the clone.
#
# usage: scripts/ci-cold.sh [WORK_DIR]
#   WORK_DIR (default: a new directory under $TMPDIR or /tmp) receives the
#   clone (src/), the cache (ccache/) and the log (ci.log); it is kept.
#   The sample data is found as the tests always find it: PF_DATA_DIR if set,
#   else ../shared/data beside this repository.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=${1:-$(mktemp -d "${TMPDIR:-/tmp}/pf-ci-cold.XXXXXX")}
mkdir -p "$WORK"
if [[ -e $WORK/src ]]; then
  echo "ci-cold: $WORK/src exists; give a new WORK_DIR" >&2
  exit 2
fi
git clone -q "$ROOT" "$WORK/src"
echo "ci-cold: $(git -C "$WORK/src" log -1 --format='%h %s' | cut -c1-100)" >&2
export CCACHE_DIR=$WORK/ccache
mkdir -p "$CCACHE_DIR"
if [[ -z ${PF_DATA_DIR:-} && -d $ROOT/../shared/data ]]; then
  export PF_DATA_DIR=$ROOT/../shared/data
fi

rc=0
(cd "$WORK/src" && CI=true bash .ci/run) >"$WORK/ci.log" 2>&1 || rc=$?
echo "ci-cold: log $WORK/ci.log" >&2
grep '^== CI: ' "$WORK/ci.log" | grep -v "^== CI: make" || true
if [[ $rc -ne 0 ]]; then
  echo "ci-cold: CI FAILED (exit $rc) after the stages above; the end of the log:" >&2
  tail -40 "$WORK/ci.log" >&2
fi
exit $rc
