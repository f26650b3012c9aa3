#!/usr/bin/env bash
# The README's main command: installs what the viewer needs (idempotent),
# builds pkg/ (both WebAssembly builds) when the sources changed since the
# last build, and serves www/ on 127.0.0.1 with the COOP/COEP headers that
# let it run threaded. It prints the address; the page opens on the
# embedded demo and searches it at once.
#   bash scripts/viewer.sh [--port N] [--no-isolation]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-tools.sh --viewer
source scripts/wasm-env.sh
build_pkg_if_stale
exec node www/server.js "$@"
