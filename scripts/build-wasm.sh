#!/usr/bin/env bash
# Builds pkg/, the npm package `fast-reject`: the plain WebAssembly build
# (stable Rust), the threaded one (pinned nightly: atomics, shared memory,
# build-std, wasm-bindgen-rayon), the JS entry that picks between them, its
# types and the `fast-reject` bin.
#   bash scripts/build-wasm.sh [plain|threads|all]   (default: all)
# pkg/ is generated, never committed.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/wasm-env.sh
which=${1:-all}

build_plain() {
  # rayon falls back to the calling thread where threads cannot be spawned,
  # so the plain build runs the same parallel code on one thread.
  RUSTFLAGS=$WASM_RUSTFLAGS CARGO_TARGET_DIR=target-wasm wasm-pack build --release --target web --no-pack \
    --out-dir pkg/plain --out-name fast_reject -- --no-default-features --features parallel,serde,gpu
}

build_threads() {
  # Since nightly 2026-05, +atomics no longer implies shared memory: the
  # module must import a shared memory with a fixed maximum and export the
  # TLS symbols wasm-bindgen's thread support initializes on every worker.
  local link_args=(--shared-memory --max-memory=1073741824 --import-memory
    --export=__wasm_init_tls --export=__tls_size --export=__tls_align --export=__tls_base)
  local flags="$WASM_RUSTFLAGS -C target-feature=+atomics,+bulk-memory,+mutable-globals"
  for arg in "${link_args[@]}"; do flags+=" -C link-arg=$arg"; done
  RUSTUP_TOOLCHAIN=$WASM_THREADS_TOOLCHAIN RUSTFLAGS=$flags \
    CARGO_UNSTABLE_BUILD_STD=panic_abort,std CARGO_TARGET_DIR=target-wasm-threads \
    wasm-pack build --release --target web --no-pack \
    --out-dir pkg/threads --out-name fast_reject -- --no-default-features --features threads,gpu
  # wasm-bindgen-rayon 1.3 starts each pool worker with wasm-bindgen's old
  # positional init(module, memory), which prints a deprecation warning in
  # every worker; the object form is the same call.
  local helpers
  helpers=$(find pkg/threads/snippets -name 'workerHelpers*.js')
  grep -q 'await pkg.default(data.module, data.memory);' $helpers ||
    { echo "build-wasm: wasm-bindgen-rayon's worker start changed; check for the init warning" >&2; exit 1; }
  sed -i 's/await pkg.default(data.module, data.memory);/await pkg.default({ module_or_path: data.module, memory: data.memory });/' $helpers
  # It starts each pool worker from a blob: copy of its own script (for a
  # script on a CDN). A dev server that rewrites the script to import its
  # client from a root path (Vite's does, for the script's import()) makes
  # that copy fail to load, and the pool waits for it for ever. A script
  # of the page's own origin is started from its URL instead.
  node scripts/patch-pool-start.mjs $helpers
}

mkdir -p pkg
case $which in
  plain) build_plain ;;
  threads) build_threads ;;
  all) build_plain && build_threads ;;
  *) echo "usage: $0 [plain|threads|all]" >&2; exit 2 ;;
esac
# wasm-pack leaves a `*` .gitignore in each output, which npm pack would
# honour and so drop the builds from the tarball.
rm -f pkg/*/.gitignore pkg/*/package.json
cp js/src/index.js js/src/index.d.ts js/src/errors.js js/src/worker.js js/src/worker.d.ts js/src/search-thread.js pkg/
mkdir -p pkg/bin
cp js/src/bin/fast-reject.js pkg/bin/
chmod +x pkg/bin/fast-reject.js
# The demo scene of `fast-reject demo`, as in the native CLI.
mkdir -p pkg/demo
cp assets/demo/scene.glb assets/demo/template.glb pkg/demo/
version=$(awk -F'"' '/^version = / { print $2; exit }' Cargo.toml)
sed "s/@VERSION@/$version/" js/package.pkg.json > pkg/package.json
cp js/PACKAGE-README.md pkg/README.md
echo "pkg/ built ($which)"
