#!/usr/bin/env bash
# Every test: the Rust suites (unit oracles, the shared scenes, bad input,
# the CLI, serial = parallel), then the CLI scored by the shared
# evaluate.py on the scenes the defaults must match perfectly, a report on
# the others, and the WebAssembly tests (scripts/test-wasm.sh; its tools
# come from scripts/install-tools.sh). FAST_REJECT_SKIP_WASM=1 skips those.
set -euo pipefail
cd "$(dirname "$0")/.."
# The GPU tests run on lavapipe (scripts/install-tools.sh installs it), the
# only adapter it offers, so that they behave alike on every machine.
lavapipe=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json
if [[ -z ${VK_DRIVER_FILES:-} && -e $lavapipe ]]; then
  export VK_DRIVER_FILES=$lavapipe
fi
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
cargo test --release --features internals
cargo build --release --bin fast-reject
echo "== evaluate.py on the required scenes"
scripts/evaluate.sh zoo-bunny remeshed-cow crowd-rocker select-cow-head fused-homer cluttered-bunny
echo "== evaluate.py on twisted-homer (volume+harmonics, reported, not required)"
scripts/evaluate.sh --report-only twisted-homer
echo "== evaluate.py with the curvature descriptor (tests/curvature.rs asserts zoo-bunny and remeshed-cow too)"
FAST_REJECT_MATCH_ARGS="--descriptor curvature" scripts/evaluate.sh twisted-homer fused-homer select-cow-head
if [[ ${FAST_REJECT_SKIP_WASM:-0} != 1 ]]; then
  bash scripts/test-wasm.sh
fi
