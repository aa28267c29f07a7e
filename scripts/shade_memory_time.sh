#!/bin/bash
# Time and peak resident memory of `terrascape shade` per lighting model, for the memory
# model of `terrascape.memory` (PEAK_BYTES_PER_SAMPLE "shade", "shade daylight").
#
#     bash scripts/shade_memory_time.sh [FOLDER [SIZES [OLD_SRC]]]
#
# In FOLDER (default: a new temporary folder): fBm maps (seed 3) of 65² and of each of SIZES
# (default "2049 4097"); each shaded with the daylight model (grey and --color) and with
# --lighting classic. Prints one line per run: seconds, peak RSS (/usr/bin/time) and bytes a
# sample over the 65² run of the same kind. With OLD_SRC (the src folder of another checkout,
# e.g. a `git worktree`), each daylight run is repeated with that code first on the path,
# interleaved, and the two PNGs are compared byte for byte. An 8193² map needs about 2 GB
# (11 GB with code from before the bands).
set -euo pipefail
T="$(cd "$(dirname "$0")/.." && pwd)/.venv/bin/terrascape"
cd "${1:-$(mktemp -d)}"
SIZES=${2:-"2049 4097"}
OLD=${3:-}
run() {  # label, size, then shade's options; prints "seconds KiB"
  local label=$1 size=$2
  shift 2
  local path=""
  [ "$label" = old ] && path=$OLD
  PYTHONPATH=$path /usr/bin/time -f "%e %M" "$T" shade "m$size.npy" -o "$label-$size$*.png" \
      --force -q --max-memory 100% "$@" 2>&1 | tail -1
}
for size in 65 $SIZES; do
  [ -f "m$size.npy" ] || "$T" generate fbm --size "$size" --seed 3 -o "m$size.npy" -q
done
kinds=("--lighting daylight" "--color" "--lighting classic")
declare -A base
for kind in "${kinds[@]}"; do
  base[$kind]=$(run new 65 $kind | cut -d' ' -f2)
done
for size in $SIZES; do
  for kind in "${kinds[@]}"; do
    labels="new"
    [ -n "$OLD" ] && [ "$kind" != "--lighting classic" ] && labels="old new"
    for label in $labels; do
      read -r secs kib <<< "$(run "$label" "$size" $kind)"
      per=$(python3 -c "print(f'{($kib - ${base[$kind]}) * 1024 / $size**2:.1f}')")
      echo "$size² $kind ($label): $secs s, $((kib / 1024)) MiB, $per B a sample"
    done
    if [ "$labels" = "old new" ]; then
      cmp -s "old-$size$kind.png" "new-$size$kind.png" && echo "  same bytes" \
          || echo "  PNGs DIFFER"
    fi
  done
done
