#!/usr/bin/env python3
"""Scenes of a template of two shells whose copies may have c_T buried.

The template is one model with a smaller one beside it, apart (a knee and its
pin, a wheel pair). Each copy is turned at random; on every other copy a small
ball sits at c_T, as a neighbour's boss or a pin would, and the copy's part
gathers it. A decoy of the larger model alone and a distractor model stand
among them. Writes scene.glb, template.glb and truth.json (the shared scenes'
format) under --out.

    make-buried-scenes.py --big cow.obj --small cheburashka.obj --seed 3 \
        --out /tmp/buried-cow --cli target/release/fast-reject
"""
import argparse, os, sys

import numpy as np
import trimesh

from generated_scene import random_turn, template_report, write_scene


def normalized(path, radius):
    mesh = trimesh.load(path, force="mesh", process=False)
    centre = mesh.bounding_sphere.primitive.center
    mesh.apply_translation(-centre)
    mesh.apply_scale(radius / np.linalg.norm(mesh.vertices, axis=1).max())
    return mesh


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--models", default=os.path.join(os.path.dirname(__file__), "../../shared/models"))
    ap.add_argument("--big", required=True)
    ap.add_argument("--small", required=True)
    ap.add_argument("--distractor", default="teapot.obj")
    ap.add_argument("--copies", type=int, default=4)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--pin", type=float, default=0.1, help="buried ball's radius, share of the big model's")
    ap.add_argument("--cli", required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    big = normalized(os.path.join(a.models, a.big), 1.0)
    small = normalized(os.path.join(a.models, a.small), 0.35)
    small.apply_translation([big.bounds[1][0] + 0.1 + 0.35, 0.0, 0.0])
    template = trimesh.util.concatenate([big, small])
    os.makedirs(a.out, exist_ok=True)
    template_path = os.path.join(a.out, "template.glb")
    template.export(template_path)
    report = template_report(a.cli, template_path)
    c_t = np.array(report["center"])
    radius = report["radius"]
    scene = trimesh.Scene()
    truth = []
    spacing = 4.0 * radius
    for k in range(a.copies):
        pose = random_turn(rng)
        pose[:3, 3] = [spacing * (k % 3), spacing * (k // 3), 0.0]
        scene.add_geometry(template.copy().apply_transform(pose), node_name=f"copy#{k}")
        truth.append({"node": f"copy#{k}", "transform": pose.tolist()})
        if k % 2 == 1:
            at = pose[:3, :3] @ c_t + pose[:3, 3]
            pin = trimesh.creation.icosphere(subdivisions=2, radius=a.pin)
            scene.add_geometry(pin.apply_translation(at), node_name=f"pin#{k}")
    row = (a.copies + 2) // 3
    decoy = big.copy().apply_transform(random_turn(rng))
    scene.add_geometry(decoy.apply_translation([0.0, spacing * row, 0.0]), node_name="decoy")
    other = normalized(os.path.join(a.models, a.distractor), 1.0)
    scene.add_geometry(other.apply_translation([spacing, spacing * row, 0.0]), node_name="distractor")
    write_scene(a.out, scene, truth, radius)
    print(f"{a.out}: {a.copies} copies, {a.copies // 2} with c_T buried", file=sys.stderr)


if __name__ == "__main__":
    main()
