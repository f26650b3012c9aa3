#!/usr/bin/env bash
# Native against wasm (plain in Node, plain and threaded in headless
# Chromium with 2 threads) on zoo-bunny and crowd-rocker, with peak wasm
# memory; prints the Markdown table of docs/BENCHMARKS.md. BENCH_RUNS=N (default 3).
# On a shared machine, BENCH_NICE=-10 (root) runs it ahead of other work:
# a new session whose scheduler group gets that priority.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/wasm-env.sh
cargo build --release --bin fast-reject
build_pkg_if_stale
if [[ -n ${BENCH_NICE:-} && ${BENCH_SESSION:-} != 1 ]]; then
  exec setsid env BENCH_SESSION=1 bash -c 'echo "$BENCH_NICE" > /proc/self/autogroup && exec nice -n "$BENCH_NICE" node js/bench.js "$@"' bench "$@"
fi
node js/bench.js "$@"
