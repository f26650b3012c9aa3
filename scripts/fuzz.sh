#!/usr/bin/env bash
# Fuzzes every loader, the glTF resource resolver and a small search with
# cargo-fuzz (libFuzzer + AddressSanitizer, on the pinned nightly); see
# fuzz/README.md.
#
#   bash scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]
#
# SECONDS_PER_TARGET defaults to 30; TARGETs default to all of them. First it
# replays, once each, every committed seed (fuzz/seeds/TARGET/) and every
# saved crash (fuzz/regressions/TARGET/): those are the regression tests.
# Then it fuzzes each target for that long in a scratch corpus
# (fuzz/corpus/TARGET/, the seeds plus what earlier runs kept; ignored by
# git), and prints a line per target with the executions done. Exits
# non-zero if any input crashes, times out (10 s) or passes 2 GiB, printing
# where the input was saved (fuzz/artifacts/TARGET/). Logs:
# fuzz/artifacts/logs/TARGET.log.
#
# FUZZ_KEEP_GOING=1 fuzzes on past crashes (libFuzzer's fork mode, one
# worker), saving every failing input, instead of stopping at the first one:
# for long runs that should list everything they find.
#
# Needs cargo-fuzz and the nightly (bash scripts/install-tools.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/wasm-env.sh

seconds=${1:-30}
shift || true
[[ $seconds =~ ^[0-9]+$ ]] || { echo "usage: $0 [SECONDS_PER_TARGET] [TARGET...]" >&2; exit 2; }
all_targets=(load_obj load_ply load_ply_limited load_stl load_any load_gltf instance_gltf gltf_resolver search_small message_text)
targets=("$@")
((${#targets[@]})) || targets=("${all_targets[@]}")
# Also caps the size of single allocations (libFuzzer's -malloc_limit_mb
# defaults to it): a loader that believes a header's count fails here.
limits=(-rss_limit_mb=2048 -timeout=10)
# A search's time follows its candidates, and AddressSanitizer makes it
# about 20 times slower than a release build: search_small bounds its work
# (resolution, survivors per layer) and gets a longer timeout, still far
# below what a real hang would take.
limits_for() {
  if [[ $1 == search_small ]]; then
    echo -rss_limit_mb=2048 -timeout=60
  else
    echo "${limits[@]}"
  fi
}

if ! command -v cargo-fuzz >/dev/null; then
  echo "fuzz: cargo-fuzz is missing; run: bash scripts/install-tools.sh" >&2
  exit 1
fi
fuzz=(cargo "+$WASM_THREADS_TOOLCHAIN" fuzz)
log() { printf '== fuzz: %s\n' "$*"; }
logs=fuzz/artifacts/logs
mkdir -p "$logs"

log "building the targets ($WASM_THREADS_TOOLCHAIN, AddressSanitizer)"
"${fuzz[@]}" build

failed=()
# Regression tests: every seed and every saved crash, run once each (given
# as files, libFuzzer runs each and names the one that fails).
for target in "${targets[@]}"; do
  mapfile -t inputs < <(find "fuzz/seeds/$target" "fuzz/regressions/$target" -type f 2>/dev/null | sort)
  out=$logs/$target.replay.log
  read -ra target_limits <<<"$(limits_for "$target")"
  if "${fuzz[@]}" run "$target" "${inputs[@]}" -- "${target_limits[@]}" >"$out" 2>&1; then
    printf '%-14s replay: %s seeds and regressions pass\n' "$target" "${#inputs[@]}"
  else
    input=$(sed -n 's/^Running: //p' "$out" | tail -1)
    printf '%-14s replay: FAILED on %s\n' "$target" "$input"
    grep -m2 -E 'panicked at|ERROR: libFuzzer|ERROR: AddressSanitizer' "$out" || true
    failed+=("$target: $input fails (log: $out)")
  fi
done

((seconds > 0)) || targets=()
((seconds == 0)) || log "fuzzing each target for ${seconds}s"
for target in "${targets[@]}"; do
  corpus=fuzz/corpus/$target
  mkdir -p "$corpus"
  # The seeds go in, but fuzzing writes to the scratch copy only.
  cp -n "fuzz/seeds/$target"/* "$corpus"/ 2>/dev/null || true
  out=$logs/$target.log
  artifacts=fuzz/artifacts/$target
  mkdir -p "$artifacts"
  stamp=$(mktemp)
  read -ra target_limits <<<"$(limits_for "$target")"
  status=ok
  start=$SECONDS
  if [[ ${FUZZ_KEEP_GOING:-0} == 1 ]]; then
    "${fuzz[@]}" run "$target" "$corpus" -- -max_total_time="$seconds" "${target_limits[@]}" \
      -fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1 >"$out" 2>&1 || status=CRASH
    # Fork mode's progress lines: "#RUNS: cov: ... crash/oom/timeout ...".
    runs=$(sed -n 's/^#\([0-9]*\): cov:.*/\1/p' "$out" | tail -1)
  else
    "${fuzz[@]}" run "$target" "$corpus" -- -max_total_time="$seconds" -print_final_stats=1 \
      "${target_limits[@]}" >"$out" 2>&1 || status=CRASH
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$out" | tail -1)
  fi
  elapsed=$((SECONDS - start))
  found=$(find "$artifacts" -maxdepth 1 -type f -newer "$stamp" \( -name 'crash-*' -o -name 'oom-*' -o -name 'timeout-*' -o -name 'leak-*' \) | sort)
  rm -f "$stamp"
  [[ -z $found ]] || status=CRASH
  files=$(find "$corpus" -type f | wc -l)
  printf '%-14s %s: %s executions in %ss, corpus %s files\n' "$target" "$status" "${runs:-?}" "$elapsed" "$files"
  if [[ $status != ok ]]; then
    grep -m3 -E 'panicked at|ERROR: libFuzzer|ERROR: AddressSanitizer|SUMMARY' "$out" || true
    [[ -n $found ]] || found="(no input saved)"
    while read -r file; do failed+=("$target: $file (log: $out)"); done <<<"$found"
  fi
done

if ((${#failed[@]})); then
  echo "FAILED:"
  printf '  %s\n' "${failed[@]}"
  echo "(a new input: minimize it with cargo +$WASM_THREADS_TOOLCHAIN fuzz tmin TARGET FILE, keep it in fuzz/regressions/TARGET/)"
  exit 1
fi
log "no crash"
