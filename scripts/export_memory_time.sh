#!/bin/bash
# Time and peak resident memory of the Unreal and Unity exports of large maps, for
# docs/benchmarks.md and the memory model of `terrascape.memory`.
#
#     bash scripts/export_memory_time.sh [FOLDER [OLD_SRC [RUNS]]]
#
# In FOLDER (default: a new temporary folder): an 8193² fBm map (seed 3) and its crops to
# 8129² and 7000²; the RUNS (default "unreal unity unreal-resample"): `export unreal` of
# the 8129² map (its size: no resampling), `export unity --tiles 2` of the 8193² map, and
# `export unreal --fit resample` of the 7000² map (to 8129²). Prints one line per run: exit
# code, seconds, peak RSS (/usr/bin/time). With OLD_SRC (the src folder
# of another checkout, e.g. a `git worktree`), each export is also run with that code first
# on the path, interleaved, and the first two exports' files are compared byte for byte.
# Needs about 6 GB free (more with old code).
set -euo pipefail
T="$(cd "$(dirname "$0")/.." && pwd)/.venv/bin/terrascape"
PY="$(cd "$(dirname "$0")/.." && pwd)/.venv/bin/python"
cd "${1:-$(mktemp -d)}"
OLD=${2:-}
RUNS=${3:-"unreal unity unreal-resample"}
[ -f m8193.npy ] || "$T" generate fbm --size 8193 --seed 3 -o m8193.npy -q
for side in 8129 7000; do
  [ -f "m$side.npy" ] || "$PY" -c "import numpy as np; h = np.load('m8193.npy', mmap_mode='r'); \
np.save('m$side.npy', np.ascontiguousarray(h[:$side, :$side]))"
done
labels="new"
[ -n "$OLD" ] && labels="old new"
while read -r tag args; do
  [[ " $RUNS " == *" $tag "* ]] || continue
  for label in $labels; do
    path=""
    [ "$label" = old ] && path=$OLD
    rm -rf "$tag-$label"
    # shellcheck disable=SC2086
    PYTHONPATH=$path /usr/bin/time -f "$tag ($label): exit %x, %e s, %M KiB (user %U s, system %S s)" \
        "$T" export $args -o "$tag-$label" -q --max-memory 100% 2>&1 | tail -1 || true
  done
  if [ "$labels" = "old new" ] && [ "$tag" != unreal-resample ]; then
    diff -rq "$tag-old" "$tag-new" > /dev/null && echo "  same files, byte for byte" \
        || echo "  FILES DIFFER"
  fi
done << 'RUNS'
unreal unreal m8129.npy
unity unity m8193.npy --tiles 2
unreal-resample unreal m7000.npy --fit resample
RUNS
