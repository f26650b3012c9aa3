#!/usr/bin/env bash
# The WebAssembly tests (run by scripts/test.sh after the native suites;
# tools from scripts/install-tools.sh):
#  1. the pure core's tests built for wasm32-wasip1, under wasmtime;
#  2. the binding under wasm-bindgen-test, in Node and in headless Chromium,
#     against the native command's result on the same scene;
#  3. pkg/ (both builds) through its JS API in Node (with the reliability
#     issue's hostile inputs, scenes held past the memory), the threaded build in
#     cross-origin isolated headless Chromium, the `fast-reject` bin scored
#     by ../shared/bench/evaluate.py, and `npm pack` imported by a bundler;
#  4. the viewer in www/ driven end to end in headless Chromium.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/wasm-env.sh
here=$(pwd)
shared=${FAST_REJECT_SHARED:-$here/../shared}
step() { printf '\n== test-wasm: %s\n' "$*"; }

step "core tests (unit, errors, the shared scenes, serial = parallel) on wasm32-wasip1 under wasmtime"
# The sandbox opens the repository (the demo assets) and sees the shared
# data as /shared: it follows neither a symlinked ../shared out of an
# opened folder nor ".." in a path.
runner="$WASMTIME run --dir $here::$here --dir $(readlink -f "$shared")::/shared --env FAST_REJECT_SHARED=/shared"
CARGO_TARGET_DIR=target-wasip1 \
  CARGO_TARGET_WASM32_WASIP1_RUNNER="$runner" \
  cargo test --release --target wasm32-wasip1 --no-default-features --features parallel,serde \
  --lib --test errors --test scenes --test backends

step "native reference result for the wasm-bindgen tests"
cargo build --release --bin fast-reject
mkdir -p target-wasm/native
target/release/fast-reject match "$shared/scenes/zoo-bunny/scene.glb" \
  --template "$shared/scenes/zoo-bunny/template.glb" --json > target-wasm/native/zoo-bunny.json

step "clippy for the wasm32 binding and its tests"
RUSTFLAGS=$WASM_RUSTFLAGS CARGO_TARGET_DIR=target-wasm cargo clippy --release \
  --target wasm32-unknown-unknown --no-default-features --features parallel,serde \
  --lib --test wasm -- -D warnings
RUSTFLAGS=$WASM_RUSTFLAGS CARGO_TARGET_DIR=target-wasm cargo clippy --release \
  --target wasm32-unknown-unknown --no-default-features --features parallel,serde,gpu \
  --lib --test wasm_gpu -- -D warnings

step "wasm-bindgen-test in Node"
RUSTFLAGS=$WASM_RUSTFLAGS CARGO_TARGET_DIR=target-wasm wasm-pack test --release --node -- \
  --no-default-features --features parallel,serde --test wasm
step "wasm-bindgen-test in headless Chromium"
# The suite is not marked run_in_browser (it runs in Node too); this makes
# the runner take it to the browser.
WASM_BINDGEN_USE_BROWSER=1 RUSTFLAGS=$WASM_RUSTFLAGS CARGO_TARGET_DIR=target-wasm wasm-pack test --release --headless --chrome \
  --chromedriver "$CHROMEDRIVER" -- --no-default-features --features parallel,serde --test wasm

step "the WebGPU path in headless Chromium (SwiftShader, flags in webdriver.json)"
RUSTFLAGS=$WASM_RUSTFLAGS CARGO_TARGET_DIR=target-wasm wasm-pack test --release --headless --chrome \
  --chromedriver "$CHROMEDRIVER" -- --no-default-features --features parallel,serde,gpu --test wasm_gpu

step "build pkg/ (plain and threaded)"
bash scripts/build-wasm.sh all

step "the hostile inputs of the reliability issue, for the JS tests"
# js/test/hostile.test.js feeds every one to one module, then searches.
cargo run --release --example hostile_files -- target/hostile

step "JS API in Node (the worker API, hostile inputs, scenes held past the memory), threaded build in Chromium"
(cd js && node --test test/api.test.js test/worker.test.js test/hostile.test.js test/hostile-calls.test.js test/held-scenes.test.js test/browser.test.js)

step "fast-reject repeats --out: the instanced glTF through the Khronos glTF validator"
(cd js && node --test test/instanced-glb.test.js)

step "the fast-reject bin on zoo-bunny, select-cow-head and (curvature) twisted-homer, scored by evaluate.py"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
node pkg/bin/fast-reject.js match "$shared/scenes/zoo-bunny/scene.glb" --group-radius 1 \
  --template "$shared/scenes/zoo-bunny/template.glb" --json > "$out/zoo-bunny.json"
# Exits non-zero unless every instance is found with no false positive.
python3 "$shared/bench/evaluate.py" "$shared/scenes/zoo-bunny/truth.json" "$out/zoo-bunny.json"
# A selection sphere instead of a template file, scored the same way.
select=$(python3 -c "import json,sys; s=json.load(open(sys.argv[1]))['select']; print(','.join(map(repr, s['center'] + [s['radius']])))" "$shared/scenes/select-cow-head/truth.json")
node pkg/bin/fast-reject.js match "$shared/scenes/select-cow-head/scene.glb" --select="$select" --json > "$out/select-cow-head.json"
python3 "$shared/bench/evaluate.py" "$shared/scenes/select-cow-head/truth.json" "$out/select-cow-head.json" --select

# The curvature descriptor through the same bin (no voxels: the mesh).
node pkg/bin/fast-reject.js match "$shared/scenes/twisted-homer/scene.glb" \
  --template "$shared/scenes/twisted-homer/template.glb" --descriptor curvature --json > "$out/twisted-homer.json"
python3 "$shared/bench/evaluate.py" "$shared/scenes/twisted-homer/truth.json" "$out/twisted-homer.json"

step "the viewer (www/) end to end in headless Chromium, threaded and single-threaded"
# Screenshots land in target/viewer/.
(cd www && node --test test/)

step "npm pack, imported by a bundler and by tsc"
bash js/test/package-test.sh
step "all wasm tests passed"
