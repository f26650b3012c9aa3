#!/usr/bin/env bash
# Makes 20 scenes beside the shared ones with ../shared/bench/make_scenes.py
# (other seeds and models; zoo, ground, clutter and selection recipes), to
# check that a change generalizes:
#   scripts/make-more-scenes.sh OUT
#   FAST_REJECT_SCENES=OUT scripts/evaluate.sh --report-only $(ls OUT)
# Needs numpy, trimesh, scipy, networkx and fast-simplification (PY names
# the Python that has them).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
shared=${FAST_REJECT_SHARED:-$here/../shared}
out=${1:?usage: make-more-scenes.sh OUT}
G="${PY:-python3} $shared/bench/make_scenes.py --models $shared/models"
all="stanford-bunny.obj cow.obj homer.obj teapot.obj rocker-arm.obj fandisk.obj cheburashka.obj horse.ply"
others() { for m in $all; do [[ $m != "$1" ]] && printf '%s ' "$m"; done; }
zoo() { $G --template "$2" --distractors $(others "$2") --instances 4 --rotate --seed "$1" --out "$out/g$1-zoo-${2%.*}"; }
ground() { $G --template "$2" --distractors $(others "$2") --instances 4 --rotate --ground --remesh 0.2 0.5 --seed "$1" --out "$out/g$1-ground-${2%.*}"; }
clutter() { $G --template "$2" --distractors $(others "$2") --instances 4 --decoys 2 --decoy-scale 0.75 --rotate --remesh 0.3 0.6 --noise 0.05 --spacing 1.7 --seed "$1" --out "$out/g$1-clutter-${2%.*}"; }
selection() { $G --template "$2" --distractors $(others "$2") --instances 4 --rotate --remesh 0.2 0.4 --select $3 $4 $5 $6 --seed "$1" --out "$out/select-g$1-${2%.*}"; }
mkdir -p "$out"
zoo 11 cow.obj
zoo 12 teapot.obj
zoo 13 fandisk.obj
zoo 14 cheburashka.obj
zoo 15 horse.ply
ground 16 rocker-arm.obj
ground 17 stanford-bunny.obj
ground 18 teapot.obj
ground 19 cheburashka.obj
ground 20 cow.obj
clutter 21 homer.obj
clutter 22 cow.obj
clutter 23 fandisk.obj
clutter 24 horse.ply
clutter 25 rocker-arm.obj
selection 26 homer.obj 0.0 0.6 0.0 0.35
selection 27 stanford-bunny.obj 0.3 0.5 0.0 0.3
selection 28 horse.ply 0.6 0.3 0.0 0.3
selection 29 teapot.obj 0.9 0.1 0.0 0.3
selection 30 rocker-arm.obj -0.6 0.0 0.0 0.35
