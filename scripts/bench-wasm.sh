#!/usr/bin/env bash
# Native against wasm (plain in Node, plain and threaded in headless
# Chromium with 2 threads) on zoo-bunny and crowd-rocker, with peak wasm
# memory; prints the Markdown table of README.md. BENCH_RUNS=N (default 3).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/wasm-env.sh
cargo build --release --bin fast-reject
[[ -f pkg/threads/fast_reject_bg.wasm && -f pkg/plain/fast_reject_bg.wasm ]] || bash scripts/build-wasm.sh all
node js/bench.js "$@"
