#!/usr/bin/env bash
# Scores the CLI on shared scenes with ../shared/bench/evaluate.py.
#   scripts/evaluate.sh [--report-only] SCENE...
# Selection scenes (select-*) are searched with their truth.json sphere and
# scored with --select. Exits non-zero when a scene is not found perfectly,
# unless --report-only. FAST_REJECT_MATCH_ARGS adds flags to every search
# (e.g. "--descriptor curvature"); FAST_REJECT_SCENES names another folder
# of scenes (scripts/make-more-scenes.sh).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
shared=${FAST_REJECT_SHARED:-$here/../shared}
bin=${FAST_REJECT_BIN:-$here/target/release/fast-reject}
report_only=0
if [[ ${1:-} == --report-only ]]; then report_only=1; shift; fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
failed=0
for name in "$@"; do
  dir=${FAST_REJECT_SCENES:-$shared/scenes}/$name
  if [[ $name == select-* ]]; then
    sel=$(python3 -c "import json,sys; s=json.load(open(sys.argv[1]))['select']; print(','.join(map(repr, s['center'] + [s['radius']])))" "$dir/truth.json")
    "$bin" match "$dir/scene.glb" --select="$sel" --json ${FAST_REJECT_MATCH_ARGS:-} > "$out/$name.json"
    flag=--select
  else
    "$bin" match "$dir/scene.glb" --template "$dir/template.glb" --json ${FAST_REJECT_MATCH_ARGS:-} > "$out/$name.json"
    flag=
  fi
  if score=$(python3 "$shared/bench/evaluate.py" "$dir/truth.json" "$out/$name.json" $flag); then
    status=ok
  else
    status=FAIL
    failed=1
  fi
  ms=$(python3 -c "import json,sys; print(round(json.load(open(sys.argv[1]))['timings_ms']['total']))" "$out/$name.json")
  printf '%-18s %-4s %s  (%s ms)\n' "$name" "$status" "$score" "$ms"
done
if [[ $failed == 1 && $report_only == 0 ]]; then
  echo "some scenes were not matched perfectly" >&2
  exit 1
fi
