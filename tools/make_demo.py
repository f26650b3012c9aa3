#!/usr/bin/env python3
"""Builds the embedded demo: assets/demo/{scene.glb, template.glb, truth.json}.

A mug (a cylinder with a torus handle: two overlapping shells) is the
template; the scene holds three rotated mugs among other simple solids, laid
out like the shared benchmark scenes (one node per object, objects scaled to a
bounding radius of 1). Procedural on purpose: no third-party model data ends up
in the binary or the npm package. Deterministic.

Needs: numpy, trimesh (pip). Run from the repository root:
    python3 tools/make_demo.py
"""
import json, os
import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

OUT = os.path.join(os.path.dirname(__file__), "..", "assets", "demo")

def normalized(m):
    m = m.copy()
    c = (m.bounds[0] + m.bounds[1]) / 2
    m.apply_translation(-c)
    m.apply_scale(1.0 / np.linalg.norm(m.vertices, axis=1).max())
    return m

def mug():
    # The handle sits high, as on a real mug: a centred one would make the
    # mug look the same turned upside down, and no method can tell a point
    # from its image under a symmetry of the object.
    body = trimesh.creation.cylinder(radius=0.35, height=0.8, sections=48)
    handle = trimesh.creation.torus(major_radius=0.18, minor_radius=0.06, major_sections=40, minor_sections=12)
    handle.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    handle.apply_translation([0.38, 0, 0.14])
    return normalized(trimesh.util.concatenate([body, handle]))

def others():
    return [
        normalized(trimesh.creation.icosphere(subdivisions=3, radius=0.8)),
        normalized(trimesh.creation.box(extents=[1.2, 0.7, 0.5])),
        normalized(trimesh.creation.cone(radius=0.5, height=1.0, sections=48)),
        normalized(trimesh.creation.torus(major_radius=0.6, minor_radius=0.2, major_sections=48, minor_sections=16)),
        normalized(trimesh.creation.capsule(height=1.0, radius=0.3, count=[24, 24])),
        normalized(trimesh.creation.cylinder(radius=0.4, height=1.2, sections=48)),
    ]

def main():
    rng = np.random.default_rng(2010)
    template = mug()
    objects = [("mug", template)] * 3 + [(f"shape{i}", m) for i, m in enumerate(others())]
    order = rng.permutation(len(objects))
    cols = 3
    scene = trimesh.Scene()
    truth = []
    for slot, idx in enumerate(order):
        name, m = objects[idx]
        T = np.eye(4)
        T[:3, :3] = Rotation.random(random_state=int(rng.integers(1 << 31))).as_matrix()
        T[:3, 3] = [(slot % cols) * 2.6, (slot // cols) * 2.6, 0.0]
        node = f"{name}#{slot}"
        scene.add_geometry(m, node_name=node, geom_name=node, transform=T)
        if name == "mug":
            truth.append({"node": node, "transform": T.tolist()})
    os.makedirs(OUT, exist_ok=True)
    scene.export(os.path.join(OUT, "scene.glb"))
    template.export(os.path.join(OUT, "template.glb"))
    with open(os.path.join(OUT, "truth.json"), "w") as f:
        json.dump({"template": "template.glb", "scene": "scene.glb", "instances": truth, "tolerance": 0.2}, f, indent=1)
    tris = sum(len(g.faces) for g in scene.geometry.values())
    print(f"{OUT}: {len(objects)} objects, {tris} triangles, {len(truth)} mugs")

if __name__ == "__main__":
    main()
