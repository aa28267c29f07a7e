#!/usr/bin/env bash
# Run benchmark cases at two commits, interleaved A B B A, each from its own git worktree:
#   bash scripts/bench_before_after.sh BEFORE AFTER OUT_DIR CASE [CASE ...]
# Writes OUT_DIR/CASE_COMMIT_rROUND.md (`terrascape bench CASE --quick --markdown`) and prints
# one line per run with the time and load average. Uses this checkout's Python environment
# (PYTHON, default .venv/bin/python); the worktrees are made under OUT_DIR and left there.
set -euo pipefail
[ $# -ge 4 ] || { echo "usage: bash scripts/bench_before_after.sh BEFORE AFTER OUT_DIR CASE..." >&2; exit 2; }
repo="$(cd "$(dirname "$0")/.." && pwd)"
python="${PYTHON:-$repo/.venv/bin/python}"
before="$(git -C "$repo" rev-parse --short "$1")"
after="$(git -C "$repo" rev-parse --short "$2")"
out="$3"; shift 3
mkdir -p "$out"
for commit in "$before" "$after"; do
  [ -d "$out/tree_$commit" ] || git -C "$repo" worktree add -q --detach "$out/tree_$commit" "$commit"
done
run() {  # COMMIT CASE ROUND
  local tree="$out/tree_$1"
  echo "$2 at $1 (round $3): $(date -u +%H:%M:%S) UTC, load $(cut -d' ' -f1 /proc/loadavg)"
  (cd "$tree" && PYTHONPATH="$tree/src" "$python" -c \
    "from terrascape.cli import main; main(['bench', '$2', '--quick', '--markdown'])" \
    > "$out/${2}_${1}_r$3.md" 2>&1) || echo "  failed: see $out/${2}_${1}_r$3.md"
}
for case in "$@"; do
  run "$before" "$case" 1; run "$after" "$case" 1; run "$after" "$case" 2; run "$before" "$case" 2
done
