#!/bin/bash
# Peak resident memory and time of `photostereo run --sphere` on a synthetic capture read by
# row bands (docs/benchmarks.md, "Big captures"). Usage:
#   scripts/bigcap_memory.sh SIZE [MEMORY]      e.g. scripts/bigcap_memory.sh 4096 1.5G
# Renders (once) a SIZE² vase of plastic under 32 lights, 16-bit PNGs, with a sphere of
# radius 200 into /tmp/bigcap_SIZE, then runs it under /usr/bin/time -v (with --memory
# MEMORY when given) and prints the peak RSS, wall time, mask pixels and the accuracy.
set -euo pipefail
size=${1:?size in pixels}
mem=${2:-}
bin=${PHOTOSTEREO:-target/release/photostereo}
data=/tmp/bigcap_$size
if [ ! -d "$data/sphere" ]; then
  "$bin" -q synth --shape vase --material plastic -k 32 --size "$size" --calib-sphere 200 -o "$data"
fi
out=/tmp/bigcap_${size}_out
rm -rf "$out"
args=(run "$data" --sphere "$data/sphere" -o "$out")
if [ -n "$mem" ]; then args+=(--memory "$mem"); fi
uptime
/usr/bin/time -v "$bin" "${args[@]}" > "$out.log" 2>&1 || { tail -5 "$out.log"; exit 1; }
grep -E "memory plan|Maximum resident|Elapsed|pixels in the mask|angular error|^\[" "$out.log"
