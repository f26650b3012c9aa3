# Shared settings of the WebAssembly scripts (sourced, not run).
# The pinned versions live here so that installing and building agree.

# The nightly for the threaded build: atomics need build-std.
WASM_THREADS_TOOLCHAIN=nightly-2026-05-20
WASM_PACK_VERSION=0.15.1
WASMTIME_VERSION=49.0.4

# Tools that are not on a standard PATH go here (outside the clone, so that
# a fresh clone on the same machine reuses them).
TOOLS_DIR=${FAST_REJECT_TOOLS:-$HOME/.cache/fast-reject-tools}
mkdir -p "$TOOLS_DIR/bin"
WASMTIME=$TOOLS_DIR/bin/wasmtime
export PATH=$HOME/.cargo/bin:$TOOLS_DIR/bin:$PATH
export CHROMEDRIVER=${CHROMEDRIVER:-/usr/bin/chromedriver}
# Toolchains are named explicitly; never install one behind our back.
export RUSTUP_AUTO_INSTALL=0

# Both wasm builds use 128-bit SIMD (Node 16.4+, every current browser):
# LLVM vectorizes the descriptor loops with it, as it does with SSE natively.
WASM_RUSTFLAGS="-C target-feature=+simd128"

# Builds pkg/ (both builds) unless it is newer than every source it is made
# from, so that no script serves or measures a stale build.
build_pkg_if_stale() {
  local stamp=pkg/package.json
  if [[ ! -f $stamp || ! -f pkg/plain/fast_reject_bg.wasm || ! -f pkg/threads/fast_reject_bg.wasm ]] ||
    [[ -n $(find src js/src js/package.pkg.json assets/demo Cargo.toml Cargo.lock -newer "$stamp" -print -quit) ]]; then
    bash scripts/build-wasm.sh all
  fi
}
