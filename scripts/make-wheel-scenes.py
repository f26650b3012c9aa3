#!/usr/bin/env python3
"""Scenes of a wheel pair wrapped by other parts, the truck's case.

The template is two tori on one axis with a hub disc on one of them (three
shells). Four copies are turned at random: one alone, one with an axle
through both hubs, two with the axle and an arch over the pair. A decoy
pair without its hub stands beside them. Writes scene.glb, template.glb and
truth.json (the shared scenes' format) under --out; the CLI gives r_k for
truth.json's template_radius.

    make-wheel-scenes.py --seed 1 --out /tmp/wheels-1 --cli target/release/fast-reject
"""
import argparse, os

import numpy as np
import trimesh

from generated_scene import random_turn, template_report, write_scene

X_AXIS = trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0])


def wheel(x):
    ring = trimesh.creation.torus(major_radius=1.0, minor_radius=0.35,
                                  major_sections=48, minor_sections=16)
    ring.apply_transform(X_AXIS)
    ring.apply_translation([x, 0, 0])
    return ring


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cli", required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    os.makedirs(a.out, exist_ok=True)
    hub = trimesh.creation.cylinder(radius=0.5, height=0.2, sections=24)
    hub.apply_transform(X_AXIS)
    hub.apply_translation([-1.3, 0, 0])
    template = trimesh.util.concatenate([wheel(-1.3), hub, wheel(1.3)])
    template_path = os.path.join(a.out, "template.glb")
    template.export(template_path)
    # The template alone, at a coarse resolution to be quick: r_k only
    # scales the scorer's tolerance.
    radius = template_report(a.cli, template_path, "--resolution", "128")["radius"]
    scene, truth = trimesh.Scene(), []
    for k in range(4):
        pose = random_turn(rng)
        pose[:3, 3] = [8.0 * k, 0, 0]
        scene.add_geometry(template.copy().apply_transform(pose), node_name=f"pair#{k}")
        truth.append({"node": f"pair#{k}", "transform": pose.tolist()})
        if k >= 1:
            axle = trimesh.creation.cylinder(radius=0.3, height=3.2, sections=16)
            axle.apply_transform(X_AXIS)
            scene.add_geometry(axle.apply_transform(pose), node_name=f"axle#{k}")
        if k >= 2:
            arch = trimesh.creation.box(extents=[4.0, 3.2, 0.3])
            arch.apply_translation([0, 0, 1.6])
            scene.add_geometry(arch.apply_transform(pose), node_name=f"arch#{k}")
    decoy = trimesh.util.concatenate([wheel(-1.3), wheel(1.3)])
    pose = random_turn(rng)
    pose[:3, 3] = [0, 8.0, 0]
    scene.add_geometry(decoy.apply_transform(pose), node_name="decoy")
    write_scene(a.out, scene, truth, radius)


if __name__ == "__main__":
    main()
