"""What the scene generators share: a random turn, the template's own
report from the CLI (c_T and r_k), and writing a scene with its truth.json
in the shared scenes' format."""
import json
import os
import subprocess

import numpy as np
import trimesh


def random_turn(rng):
    """A 4x4 rotation drawn uniformly."""
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return trimesh.transformations.quaternion_matrix(q)


def height_field_mesh(side, n, height):
    """A square sheet `side` wide about the origin, of n x n vertices lifted
    by `height(x, y)` (on arrays), two triangles a cell: one open shell, as
    a city model's or a survey's terrain comes."""
    xs = np.linspace(-side / 2, side / 2, n)
    gx, gy = np.meshgrid(xs, xs, indexing="ij")
    vertices = np.stack([gx.ravel(), gy.ravel(), height(gx, gy).ravel()], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return trimesh.Trimesh(vertices, faces, process=False)


def template_report(cli, template_path, *extra):
    """The CLI's `template` entry (center, radius) for the template searched
    in a scene of itself; `extra` are further CLI arguments."""
    found = subprocess.run([cli, "match", template_path, "--template", template_path, "--json", *extra],
                           capture_output=True, text=True, check=True)
    return json.loads(found.stdout)["template"]


def write_scene(out, scene, truth, radius, symmetries=None):
    """scene.glb and truth.json under `out`; `truth` lists {node, transform}
    and `radius` is r_k, which scales the scorer's tolerance. `symmetries`
    (4x4 lists in template coordinates) map the template onto itself: a
    copy placed by one of them is found too."""
    scene.export(os.path.join(out, "scene.glb"))
    truth_json = {"template": "template.glb", "scene": "scene.glb", "instances": truth,
                  "tolerance": 0.2, "template_radius": radius}
    if symmetries:
        truth_json["template_symmetries"] = symmetries
    with open(os.path.join(out, "truth.json"), "w") as f:
        json.dump(truth_json, f)
