#!/usr/bin/env bash
# The same scene bytes before and after a change that keeps the method:
#
#   scripts/scene_bytes_check.sh OLD_PF NEW_PF OUT_DIR CLIP.json [CLIP.json ...] [-- FLAGS]
#
# reconstructs each clip with both `pf` programs and the same FLAGS (passed to
# `pf reconstruct`), in turn, and compares the two scene files byte for byte.
# Prints one line per clip and the reconstruction times; exits 0 when every
# pair is identical, 1 otherwise. A `pf` needs pandaset_pickles.py beside it
# only for PandaSet imports, not here.
set -euo pipefail
if [ $# -lt 4 ]; then
  sed -n '2,10p' "$0" >&2
  exit 2
fi
old=$1 new=$2 out=$3
shift 3
clips=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do
  clips+=("$1")
  shift
done
[ $# -gt 0 ] && shift
flags=("$@")
mkdir -p "$out"
status=0
for clip in "${clips[@]}"; do
  name=$(dirname "$clip" | tr -c 'A-Za-z0-9_.\n-' _)  # The clip's folder, as a file name.
  name=${name#_}
  times=()
  for side in old new; do
    pf=$old
    [ $side = new ] && pf=$new
    start=$(date +%s%N)
    "$pf" reconstruct "$clip" --out "$out/$name.$side.pfs" "${flags[@]}" \
      >"$out/$name.$side.log" 2>&1 || {
      echo "$name: $side pf failed (see $out/$name.$side.log)" >&2
      exit 1
    }
    times+=("$((($(date +%s%N) - start) / 1000000)) ms")
  done
  if cmp -s "$out/$name.old.pfs" "$out/$name.new.pfs"; then
    echo "$name: identical ($(stat -c %s "$out/$name.new.pfs") bytes; old ${times[0]}, new ${times[1]})"
  else
    echo "$name: DIFFERENT (old $(stat -c %s "$out/$name.old.pfs") bytes, new $(stat -c %s "$out/$name.new.pfs"))"
    status=1
  fi
done
exit $status
