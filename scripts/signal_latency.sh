#!/bin/bash
# How long a command takes to exit after a signal sent DELAY seconds into its run.
#
#     bash scripts/signal_latency.sh DELAY SIGNAL COMMAND [ARGS...]
#
# e.g. bash scripts/signal_latency.sh 4 TERM terrascape erode m2049.tif o.tif --model thermal -n 2000
#
# Prints the exit code, the seconds from the signal to the exit and the command's last line
# on stderr; exits 1 if the command ended before the signal.
set -u
if [ $# -lt 3 ]; then
    echo "usage: bash scripts/signal_latency.sh DELAY SIGNAL COMMAND [ARGS...]" >&2
    exit 2
fi
delay=$1
sig=$2
shift 2
err=$(mktemp)
trap 'rm -f "$err"' EXIT
# SIGINT back to its default in the command: a script's background job, or anything
# started from a shell in the background (nohup), has it ignored, and Python then ignores
# Ctrl-C too
env --default-signal=INT "$@" > /dev/null 2> "$err" &
pid=$!
sleep "$delay"
if ! kill -0 "$pid" 2> /dev/null; then
    wait "$pid"
    echo "ended before the signal (exit $?)"
    exit 1
fi
start=$(date +%s.%N)
kill -"$sig" "$pid"
wait "$pid"
code=$?
end=$(date +%s.%N)
printf 'exit %d after %.2f s: %s\n' "$code" "$(echo "$end - $start" | bc)" "$(tail -n 1 "$err")"
