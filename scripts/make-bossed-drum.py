#!/usr/bin/env python3
"""A bossed drum for the shared scene generator: a cylinder with a flange
and one small boss on its side, finely meshed so that `make_scenes.py
--remesh` can coarsen its copies. A body of near revolution whose only hold
on a turn about its axis is the boss: the case of a piston's pin bosses or
a wheel's valve.

    make-bossed-drum.py /tmp/drum-models
    python3 ../shared/bench/make_scenes.py --models /tmp/drum-models \\
        --template bossed-drum.obj --distractors cow.obj teapot.obj \\
        --instances 20 --seed 1 --rotate --remesh 0.3 0.7 --out /tmp/drum-1

(copy cow.obj and teapot.obj from ../shared/models beside it first).
"""
import os, sys

import trimesh


def bossed_drum():
    drum = trimesh.creation.cylinder(radius=1.0, height=2.5, sections=48)
    boss = trimesh.creation.box(extents=[0.4, 0.4, 0.5])
    boss.apply_translation([1.1, 0.0, 0.6])
    flange = trimesh.creation.annulus(r_min=0.5, r_max=1.3, height=0.3, sections=48)
    flange.apply_translation([0.0, 0.0, -1.1])
    m = trimesh.util.concatenate([drum, boss, flange])
    v, f = trimesh.remesh.subdivide_to_size(m.vertices, m.faces, max_edge=0.08)
    return trimesh.Trimesh(v, f)


if __name__ == "__main__":
    out = sys.argv[1] if len(sys.argv) > 1 else "."
    os.makedirs(out, exist_ok=True)
    bossed_drum().export(os.path.join(out, "bossed-drum.obj"))
