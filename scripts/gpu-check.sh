#!/usr/bin/env bash
# The GPU backend on a machine with a GPU that cannot build the crate (a
# lent, offline one): what it needs is packed here, run there.
#
#   scripts/gpu-check.sh pack DIR     here: the CLI and the stages bench
#                                     (stripped), the shared scenes, the
#                                     Vulkan loader's Debian packages
#   bash DIR/gpu-check.sh run DIR OUT there: the CPU and GPU backends on
#                                     every shared scene (same instances),
#                                     the whole search with cpu, gpu and
#                                     auto side by side (whole.txt), then
#                                     the stages bench on both,
#                                     alternating, 2 threads and all; logs
#                                     in OUT
#
# FAST_REJECT_BENCH_RUNS (default 3), GPU_CHECK_RUNS (whole searches,
# default 5) and GPU_CHECK_SCENES (names the bench
# takes, default all) shorten a run. GPU_CHECK_EXTRA="DIR ..." at pack time
# copies more scene folders (scene.glb, template.glb, truth.json: a
# generated building scene, where the GPU's work is largest) beside the
# shared ones; both the comparison and the bench take them (a 3 000-part
# building scene adds about 11 s per CPU search on 2 threads). Mind a
# device tool's carry limit (64 MiB): the shared scenes and one build
# take 50 MB, a second build 13 MB more, that building scene 15 MB.
# GPU_CHECK_BASE=COMMIT at pack time packs that commit's build too
# (built in a git worktree): run then benches both on the GPU,
# alternating, for a before/after on one machine.
# Seen working on an NVIDIA H100 (driver 580, its Vulkan ICD under
# /usr/local/nvidia): docs/BENCHMARKS.md, "GPU backend on an NVIDIA H100".
set -euo pipefail
mode=${1:?usage: gpu-check.sh pack DIR | run DIR OUT}
dir=${2:?a folder}
case $mode in
pack)
  here=$(cd "$(dirname "$0")/.." && pwd)
  shared=${FAST_REJECT_SHARED:-$here/../shared}
  cd "$here"
  mkdir -p "$dir/debs"
  cargo build --release --bin fast-reject
  bench=$(cargo bench --bench stages --no-run --message-format=json 2>/dev/null |
    python3 -c 'import json,sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "stages" and m.get("executable"):
        print(m["executable"])')
  strip -o "$dir/fast-reject" target/release/fast-reject
  strip -o "$dir/stages" "$bench"
  if [[ -n ${GPU_CHECK_BASE:-} ]]; then
    base=$(mktemp -d)
    git worktree add -f --detach "$base" "$GPU_CHECK_BASE" > /dev/null
    mkdir -p "$dir/base"
    (cd "$base" && CARGO_TARGET_DIR="$here/target/gpu-check-base" cargo build --release --bin fast-reject)
    base_bench=$(cd "$base" && CARGO_TARGET_DIR="$here/target/gpu-check-base" \
      cargo bench --bench stages --no-run --message-format=json 2>/dev/null |
      python3 -c 'import json,sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m["target"]["name"] == "stages" and m.get("executable"):
        print(m["executable"])')
    strip -o "$dir/base/fast-reject" "$here/target/gpu-check-base/release/fast-reject"
    strip -o "$dir/base/stages" "$base_bench"
    git worktree remove --force "$base"
  fi
  rm -rf "$dir/scenes" && cp -r "$shared/scenes" "$dir/scenes"
  for extra in ${GPU_CHECK_EXTRA:-}; do
    for f in scene.glb template.glb truth.json; do
      [[ -f $extra/$f ]] || { echo "$extra has no $f" >&2; exit 2; }
    done
    cp -r "$extra" "$dir/scenes/$(basename "$extra")"
  done
  cp scripts/gpu-check.sh scripts/gpu-compare.py "$dir/"
  # The Vulkan loader (a machine with only the driver lacks it).
  lists=$(mktemp -d)
  o="-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=$lists"
  mkdir -p "$lists/partial"
  apt-get $o update > /dev/null
  (cd "$dir/debs" && apt-get $o download libvulkan1 > /dev/null)
  du -sh "$dir"
  ;;
run)
  out=${3:?an output folder}
  mkdir -p "$out"
  if ! ldconfig -p | grep -q libvulkan.so.1; then
    for f in "$dir"/debs/*.deb; do dpkg -x "$f" /; done
    ldconfig
  fi
  for icd in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /usr/share/vulkan/icd.d/nvidia_icd.json; do
    if [[ -f $icd && -z ${VK_DRIVER_FILES:-} ]]; then export VK_DRIVER_FILES=$icd; fi
  done
  nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null || true
  export FAST_REJECT_SHARED=$dir
  python3 "$dir/gpu-compare.py" "$dir/fast-reject" "$dir/scenes" | tee "$out/same.txt"
  echo "== whole searches, cpu / gpu / auto on 2 threads"
  python3 "$dir/gpu-compare.py" --time "$dir/fast-reject" "$dir/scenes" | tee "$out/whole.txt"
  bench() { # name backend threads [bench binary]
    # shellcheck disable=SC2086 # GPU_CHECK_SCENES is a list of names.
    FAST_REJECT_BENCH_RUNS=${FAST_REJECT_BENCH_RUNS:-3} RAYON_NUM_THREADS=$3 \
      FAST_REJECT_BENCH_BACKEND=$2 "${4:-$dir/stages}" ${GPU_CHECK_SCENES:-} > "$out/$1.txt" 2>&1
    echo "== $1"
    grep -E '^\| [a-z]' "$out/$1.txt" | grep -v -E ' (volume|harmonics) |us per candidate'
  }
  if [[ -x $dir/base/stages ]]; then
    bench base-gpu-2-a gpu 2 "$dir/base/stages"; bench gpu-2-a gpu 2
    bench base-gpu-2-b gpu 2 "$dir/base/stages"; bench gpu-2-b gpu 2
    bench cpu-2-a cpu 2
    exit 0
  fi
  threads=$(nproc)
  bench gpu-2-a gpu 2; bench cpu-2-a cpu 2; bench gpu-2-b gpu 2; bench cpu-2-b cpu 2
  bench gpu-all gpu "$threads"; bench cpu-all cpu "$threads"
  ;;
*) echo "usage: gpu-check.sh pack DIR | run DIR OUT" >&2; exit 2 ;;
esac
