#!/usr/bin/env python3
"""Scenes of the kind a building model is, with truth.json in the format of
../shared/scenes (scored by ../shared/bench/evaluate.py):

  slab      a square floor slab 0.3 m thick, six long ducts above it, and
            20 turned copies of a model (0.3 m bounding radius) standing
            on the slab: small parts on very large plain ones.
  terrain   an open height field SIZE m square with a vertex every CELL m
            (one connected surface, as a scan or a game level's ground
            is), and 20 turned copies of the model standing on it: a part
            too large for one grid with vertices everywhere.
  families  PARTS parts drawn from FAMILIES families of boxes, cylinders
            and capsules (0.1-3 m), each placed and turned at random over
            a 60 m floor, and 20 turned copies of the model: a building's
            services, where every fitting repeats. --families 0 draws
            every part anew.

Every recipe writes one mesh; --nodes writes each part as a glTF node of
its own instead, as BIM and CAD exporters do (a viewer then has one draw
call per part unless it merges them).

  python3 scripts/make-building-scenes.py slab OUT [--size 100] [--seed 1]
  python3 scripts/make-building-scenes.py terrain OUT [--size 30] [--cell 0.25]
  python3 scripts/make-building-scenes.py families OUT [--parts 3000]
      [--families 20] [--seed 4] [--nodes]

Needs numpy and trimesh; --model names a file of ../shared/models
(default rocker-arm.obj).
"""
import argparse
import json
import os
import sys

import numpy as np
import trimesh

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, here)
from generated_scene import height_field_mesh  # noqa: E402
shared = os.environ.get("FAST_REJECT_SHARED", os.path.join(here, "..", "..", "shared"))


def template(model):
    t = trimesh.load(os.path.join(shared, "models", model), force="mesh")
    sphere = t.bounding_sphere.primitive
    t.apply_translation(-sphere.center)
    t.apply_scale(0.3 / sphere.radius)
    return t


def slab(args, rng, t):
    size = args.size
    floor = trimesh.creation.box(extents=[size, size, 0.3])
    floor.apply_translation([0, 0, -0.15])
    parts = [floor]
    for _ in range(6):
        duct = trimesh.creation.box(extents=[0.9 * size, 0.4, 0.4])
        duct.apply_translation([0, rng.uniform(-size / 2, size / 2), 2.5])
        parts.append(duct)
    placed = []
    for _ in range(20):
        m = trimesh.transformations.random_rotation_matrix(rng.random(3))
        turned = t.copy()
        turned.apply_transform(m)
        x, y = rng.uniform(-size / 2 + 1, size / 2 - 1, 2)
        m[:3, 3] = [x, y, 0.001 - turned.bounds[0][2]]
        placed.append(m)
    return parts, placed


def height(x, y):
    return 0.6 * np.sin(0.31 * x) * np.cos(0.23 * y) + 0.25 * np.sin(0.9 * x + 0.4 * y)


def terrain(args, rng, t):
    ground = height_field_mesh(args.size, int(round(args.size / args.cell)) + 1, height)
    placed = []
    for _ in range(20):
        m = trimesh.transformations.random_rotation_matrix(rng.random(3))
        turned = t.copy()
        turned.apply_transform(m)
        x, y = rng.uniform(-args.size / 2 + 1, args.size / 2 - 1, 2)
        # Clear of the ground under the copy's whole footprint.
        lo, hi = turned.bounds
        under = [height(x + u, y + v) for u in (lo[0], hi[0]) for v in (lo[1], hi[1])]
        m[:3, 3] = [x, y, max(under + [height(x, y)]) + 0.05 - lo[2]]
        placed.append(m)
    return [ground], placed


def families(args, rng, t):
    def shape():
        kind = rng.integers(3)
        if kind == 0:
            return trimesh.creation.box(extents=rng.uniform(0.1, 0.6, 3))
        if kind == 1:
            return trimesh.creation.cylinder(
                radius=rng.uniform(0.03, 0.2), height=rng.uniform(0.2, 3.0), sections=24)
        return trimesh.creation.capsule(
            radius=rng.uniform(0.05, 0.2), height=rng.uniform(0.1, 0.5), count=[12, 12])

    kinds = [shape() for _ in range(args.families)]
    spread = np.array([60.0, 60.0, 12.0])
    parts = []
    for _ in range(args.parts):
        m = (kinds[rng.integers(len(kinds))] if kinds else shape()).copy()
        m.apply_transform(trimesh.transformations.random_rotation_matrix(rng.random(3)))
        m.apply_translation(rng.uniform(-0.5, 0.5, 3) * spread)
        parts.append(m)
    placed = []
    for _ in range(20):
        m = trimesh.transformations.random_rotation_matrix(rng.random(3))
        m[:3, 3] = rng.uniform(-0.5, 0.5, 3) * spread
        placed.append(m)
    return parts, placed


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("recipe", choices=["slab", "terrain", "families"])
    p.add_argument("out")
    p.add_argument("--size", type=float, default=None, help="metres (slab: 100, terrain: 30)")
    p.add_argument("--parts", type=int, default=3000)
    p.add_argument("--cell", type=float, default=0.25)
    p.add_argument("--families", type=int, default=20)
    p.add_argument("--model", default="rocker-arm.obj")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--nodes", action="store_true", help="each part a glTF node of its own")
    args = p.parse_args()
    if args.size is None:
        args.size = 30.0 if args.recipe == "terrain" else 100.0
    rng = np.random.default_rng(args.seed)
    t = template(args.model)
    recipe = {"slab": slab, "terrain": terrain, "families": families}[args.recipe]
    parts, placed = recipe(args, rng, t)
    instances = []
    for i, m in enumerate(placed):
        copy = t.copy()
        copy.apply_transform(m)
        parts.append(copy)
        instances.append({"node": f"{args.model}#{i}", "transform": m.tolist()})
    os.makedirs(args.out, exist_ok=True)
    if args.nodes:
        scene = trimesh.Scene()
        for i, part in enumerate(parts):
            scene.add_geometry(part, node_name=f"part-{i}", geom_name=f"part-{i}")
        faces = sum(len(part.faces) for part in parts)
    else:
        scene = trimesh.util.concatenate(parts)
        faces = len(scene.faces)
    scene.export(os.path.join(args.out, "scene.glb"))
    t.export(os.path.join(args.out, "template.glb"))
    truth = {"template": "template.glb", "scene": "scene.glb", "instances": instances,
             "template_radius": 0.3}
    with open(os.path.join(args.out, "truth.json"), "w") as f:
        json.dump(truth, f, indent=1)
    print(f"{args.out}: {len(parts)} objects, {faces} triangles, {len(instances)} instances")


if __name__ == "__main__":
    main()
