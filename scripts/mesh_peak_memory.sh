#!/bin/bash
# Peak resident memory of `terrascape mesh` per output format and mesher, for the memory
# model of `terrascape.memory` (PEAK_BYTES_PER_SAMPLE "mesh", "mesh glb";
# PEAK_BYTES_PER_TRIANGLE).
#
#     bash scripts/mesh_peak_memory.sh [FOLDER]
#
# In FOLDER (default: a new temporary folder): a 4097² fBm map (seed 2) and a 65² one; per
# format (.ply, .obj, .glb) the 65² map at error 0, then the 4097² map with each mesher at a
# 50 m error (a few thousand triangles) and at error 0 (33.5 million triangles). Prints one
# line per run ending in its peak RSS in KiB (/usr/bin/time -f %M). Needs about 8 GB free.
set -euo pipefail
T="$(cd "$(dirname "$0")/.." && pwd)/.venv/bin/terrascape"
cd "${1:-$(mktemp -d)}"
[ -f b.tif ] || "$T" generate fbm -o b.tif --size 4097 --seed 2 -q
[ -f s.tif ] || "$T" generate fbm -o s.tif --size 65 --seed 2 -q
for fmt in ply obj glb; do
  echo "65² $fmt error 0: $( { /usr/bin/time -f %M "$T" mesh s.tif -o "s.$fmt" --max-error 0 \
      --force -q --max-memory 100% >/dev/null; } 2>&1 | tail -1) KiB"
  for mesher in rtin greedy; do
    for err in 50 0; do
      run=$( { /usr/bin/time -f %M "$T" mesh b.tif -o "b.$fmt" --mesher "$mesher" \
          --max-error "$err" --force -q --max-memory 100%; } 2>&1 )
      echo "4097² $fmt $mesher error $err: $(echo "$run" | head -1 | cut -d: -f2 | cut -d';' -f1)," \
           "$(echo "$run" | tail -1) KiB"
    done
  done
done
