#!/usr/bin/env python3
"""Scenes of a large hollow part with parts inside it, wrapped by another:
an engine's pistons, each in its bore, with a pin across its skirt and a
rod up into its hollow.

The template is a piston: a cup (a crown on a skirt, hollow from below)
with two pin bosses inside. Each copy has its pin (through both bosses and
the skirt) and its rod. One stands alone, turned at random (not with
--no-alone); --bored more (default 3) sit in bores, tubes that wrap the
skirt closely and touch as in an engine block, each piston turned about
its axis and the block as a whole. A decoy piston 12% narrower, with its
own pin, rod and bore, stands beside them (not with --no-decoy). With
--bored 2 --no-alone --no-decoy each piston is about a third of the
scene. Writes scene.glb, template.glb and
truth.json (the shared scenes' format) under --out; the CLI gives r_k for
truth.json's template_radius.

    make-hollow-scenes.py --seed 1 --out /tmp/pistons-1 --cli target/release/fast-reject
"""
import argparse, os

import numpy as np
import trimesh

from generated_scene import random_turn, template_report, write_scene

RADIUS, HEIGHT, WALL, CROWN = 1.0, 1.4, 0.12, 0.25


def piston(scale=1.0):
    """A cup revolved about z from its profile, with two bosses inside."""
    r, h = RADIUS * scale, HEIGHT
    profile = [(0, h), (r, h), (r, 0), (r - WALL, 0), (r - WALL, h - CROWN), (0, h - CROWN)]
    cup = trimesh.creation.revolve(np.array(profile), sections=64)
    bosses = []
    for side in (-1, 1):
        boss = trimesh.creation.cylinder(radius=0.22 * r, height=0.3 * r, sections=24)
        boss.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
        boss.apply_translation([side * (r - WALL - 0.15 * r), 0, 0.55 * h])
        bosses.append(boss)
    return trimesh.util.concatenate([cup, *bosses])


def pin(scale=1.0):
    p = trimesh.creation.cylinder(radius=0.12 * scale, height=2.0 * RADIUS * scale - 0.02, sections=16)
    p.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    p.apply_translation([0, 0, 0.55 * HEIGHT])
    return p


def rod(scale=1.0):
    r = trimesh.creation.box(extents=[0.3 * scale, 0.25 * scale, 2.2])
    r.apply_translation([0, 0, 0.55 * HEIGHT - 1.0])
    return r


def bore(scale=1.0):
    """A tube wrapping the skirt with a hair of clearance, taller than it."""
    inner, outer = RADIUS * scale * 1.004, 1.45 * RADIUS * scale
    profile = [(inner, -0.3 * HEIGHT), (outer, -0.3 * HEIGHT), (outer, 1.3 * HEIGHT),
               (inner, 1.3 * HEIGHT), (inner, -0.3 * HEIGHT)]
    return trimesh.creation.revolve(np.array(profile), sections=64)


def assembly(pose, scale, bored, name, scene):
    for what, mesh in (("pin", pin(scale)), ("rod", rod(scale))) + ((("bore", bore(scale)),) if bored else ()):
        scene.add_geometry(mesh.apply_transform(pose), node_name=f"{what}#{name}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cli", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--bored", type=int, default=3, help="pistons in the block")
    ap.add_argument("--no-alone", action="store_true", help="no piston standing alone")
    ap.add_argument("--no-decoy", action="store_true")
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    os.makedirs(a.out, exist_ok=True)
    template = piston()
    template_path = os.path.join(a.out, "template.glb")
    template.export(template_path)
    radius = template_report(a.cli, template_path)["radius"]
    scene, truth = trimesh.Scene(), []
    # The first piston stands alone, turned at random. The others sit in
    # bores 2.9 apart, touching as in an engine block's row of cylinders,
    # each turned about its own axis; the block is turned as a whole.
    block = random_turn(rng)
    for k in range(0 if not a.no_alone else 1, a.bored + 1):
        if k == 0:
            pose = random_turn(rng)
            pose[:3, 3] = [0, -5.0, 0]
        else:
            pose = trimesh.transformations.rotation_matrix(rng.uniform(0, 2 * np.pi), [0, 0, 1])
            pose[:3, 3] = [2.9 * k, 0, 0]
            pose = block @ pose
        scene.add_geometry(template.copy().apply_transform(pose), node_name=f"piston#{k}")
        truth.append({"node": f"piston#{k}", "transform": pose.tolist()})
        assembly(pose, 1.0, k > 0, k, scene)
    if not a.no_decoy:
        pose = random_turn(rng)
        pose[:3, 3] = [6.0, -5.0, 0]
        scene.add_geometry(piston(0.88).apply_transform(pose), node_name="decoy")
        assembly(pose, 0.88, True, "decoy", scene)
    # The bosses face each other across the axis: half a turn about it
    # maps the piston onto itself.
    half_turn = trimesh.transformations.rotation_matrix(np.pi, [0, 0, 1])
    write_scene(a.out, scene, truth, radius, symmetries=[np.eye(4).tolist(), half_turn.tolist()])


if __name__ == "__main__":
    main()
