#!/usr/bin/env python3
"""City blocks: towers standing on a large ground slab, among near twins of
the same footprint and height, with truth.json in the format of
../shared/scenes (scored by ../shared/bench/evaluate.py).

A tower is built as city and BIM exports build it: boxes (and a roof
prism) that touch without being welded. The template is one kind of
tower; the scene holds a few copies of it, each turned about the vertical,
and near twins that differ only in their top (a setback moved to a
corner, a setback of another shape, a gable roof), beside towers of other
sizes, all standing on the slab. No tower holds the template whole (a
plain box of its footprint and height would: that is part-in-whole, not a
near twin). With --variants, taller and shorter variants of the template
stand among them: a taller one holds the template whole, which the default
search reports as "part of a larger whole", the paper's part-in-whole; score
those scenes with --whole-copies. With --terrain the ground is not a slab
but rolling terrain, one open sheet of triangles as a city model's terrain
comes, and each tower is sunk into it to below its footprint's lowest
corner.

  python3 scripts/make-city-scenes.py OUT [--seed 1] [--copies 3]
      [--twins 2] [--others 12] [--variants 0] [--ground 600] [--upright]
      [--terrain]

Needs numpy and trimesh, and a release build of the CLI (for the
template's radius in truth.json).
"""
import argparse
import os
import sys

import numpy as np
import trimesh

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from generated_scene import height_field_mesh, template_report, write_scene  # noqa: E402

here = os.path.dirname(os.path.abspath(__file__))


def block(size, at):
    """A box of `size` whose bottom face is centred at `at`."""
    b = trimesh.creation.box(extents=size)
    b.apply_translation([at[0], at[1], at[2] + size[2] / 2])
    return b


def gable(w, d, rise, z):
    """A roof prism over a w x d footprint centred at the origin, its ridge
    along x, `rise` high, standing at height z."""
    v = np.array([[-w / 2, -d / 2, z], [w / 2, -d / 2, z], [w / 2, d / 2, z], [-w / 2, d / 2, z],
                  [-w / 2, 0, z + rise], [w / 2, 0, z + rise]])
    f = [[0, 2, 1], [0, 3, 2], [0, 1, 5], [0, 5, 4], [3, 4, 5], [3, 5, 2], [0, 4, 3], [1, 2, 5]]
    return trimesh.Trimesh(v, f, process=False)


def tower(kind, w, d, h, top):
    """The pieces of a tower of footprint w x d and height h whose top
    `top` metres are shaped by `kind`, standing on z = 0 around the origin."""
    shaft = h - top
    if kind == "plain":
        return [block([w, d, h], [0, 0, 0])]
    pieces = [block([w, d, shaft], [0, 0, 0])]
    if kind == "setback":
        pieces.append(block([0.6 * w, 0.6 * d, top], [0, 0, shaft]))
    elif kind == "corner-setback":
        pieces.append(block([0.6 * w, 0.6 * d, top], [0.2 * w, 0.2 * d, shaft]))
    elif kind == "long-setback":
        pieces.append(block([0.8 * w, 0.45 * d, top], [0, 0, shaft]))
    elif kind == "gable":
        pieces.append(gable(w, d, top, shaft))
    return pieces


KINDS = ["setback", "corner-setback", "long-setback", "gable", "plain"]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--copies", type=int, default=3)
    p.add_argument("--twins", type=int, default=2, help="near twins of each other kind")
    p.add_argument("--others", type=int, default=12, help="towers of other sizes")
    p.add_argument("--variants", type=int, default=0,
                   help="taller and shorter variants of the template, this many of each")
    p.add_argument("--ground", type=float, default=600.0, help="side of the ground slab (m)")
    p.add_argument("--kind", choices=KINDS, help="the template's kind (default: drawn)")
    p.add_argument("--upright", action="store_true",
                   help="turn copies by quarter turns only, as a city grid's are (default: any angle)")
    p.add_argument("--terrain", action="store_true",
                   help="rolling terrain (an open sheet) in place of the ground slab")
    p.add_argument("--cli", default=os.path.join(here, "..", "target", "release", "fast-reject"))
    a = p.parse_args()
    rng = np.random.default_rng(a.seed)
    kind = a.kind or KINDS[rng.integers(len(KINDS) - 1)]
    w, d = rng.uniform(14, 30, 2)
    h = rng.uniform(40, 120)
    top = rng.uniform(0.12, 0.25) * h
    template = trimesh.util.concatenate(tower(kind, w, d, h, top))
    # Every tower on a lattice of lots, in a shuffled order; lots are wide
    # enough for the largest tower turned any way, with a street between.
    # A plain box of the same footprint and height holds the template
    # whole, as any tower at least as wide, deep and tall does: the paper's
    # part-in-whole, reported as "part of a larger whole", not a near twin.
    # Neither is drawn.
    others = [(k, w, d, h, top) for k in KINDS if k not in (kind, "plain") for _ in range(a.twins)]
    # Taller and shorter variants of the template's own kind: the same top
    # on a longer or a shorter shaft.
    for _ in range(a.variants):
        for stretch in (rng.uniform(1.15, 1.4), rng.uniform(0.6, 0.85)):
            others.append((kind, w, d, top + (h - top) * stretch, top))
    while len(others) < a.twins * (len(KINDS) - 2) + 2 * a.variants + a.others:
        ow, od = rng.uniform(10, 40, 2)
        oh = rng.uniform(20, 150)
        if oh >= h and min(ow, od) >= min(w, d) and max(ow, od) >= max(w, d):
            continue
        others.append((KINDS[rng.integers(len(KINDS))], ow, od, oh, rng.uniform(0.1, 0.3) * oh))
    towers = [None] * a.copies + others
    order = rng.permutation(len(towers))
    lot = 1.15 * max(np.hypot(t[1], t[2]) if t else np.hypot(w, d) for t in towers) + 8.0
    side = int(np.ceil(np.sqrt(len(towers))))
    if side * lot > a.ground:
        sys.exit(f"the ground ({a.ground} m) is too small for {len(towers)} lots of {lot:.0f} m")
    if a.terrain:
        # Its own generator, so that a seed's towers and turns
        # are those of the slab's scene.
        phase = np.random.default_rng(a.seed + 1000).uniform(0, 2 * np.pi, 2)

        def height(x, y):
            return 4.0 * np.sin(x / 70.0 + phase[0]) * np.cos(y / 90.0 + phase[1]) + 1.5 * np.sin((x + y) / 35.0)
        ground = height_field_mesh(a.ground, int(a.ground / 10) + 1, height)
    else:
        ground = block([a.ground, a.ground, 2.0], [0, 0, -2.0])
    parts, truth = [ground], []
    for slot, i in enumerate(order):
        x = (slot % side - (side - 1) / 2) * lot
        y = (slot // side - (side - 1) / 2) * lot
        angle = rng.integers(4) * np.pi / 2 if a.upright else rng.uniform(0, 2 * np.pi)
        turn = trimesh.transformations.rotation_matrix(angle, [0, 0, 1])
        pieces = tower(kind, w, d, h, top) if towers[i] is None else tower(*towers[i])
        z = 0.0
        if a.terrain:
            # Below the terrain under every corner of the turned footprint.
            lo, hi = trimesh.util.concatenate(pieces).bounds
            corners = [turn[:2, :2] @ [u, v] for u in (lo[0], hi[0]) for v in (lo[1], hi[1])]
            z = min(height(x + c[0], y + c[1]) for c in corners) - 0.5
        turn[:3, 3] = [x, y, z]
        for piece in pieces:
            piece.apply_transform(turn)
            parts.append(piece)
        if towers[i] is None:
            truth.append({"node": f"tower#{len(truth)}", "transform": turn.tolist()})
    os.makedirs(a.out, exist_ok=True)
    template_path = os.path.join(a.out, "template.glb")
    template.export(template_path)
    radius = template_report(a.cli, template_path)["radius"]
    scene = trimesh.util.concatenate(parts)
    # Every kind but the corner setback is the same turned half way about
    # its vertical axis.
    symmetries = None
    if kind != "corner-setback":
        half = trimesh.transformations.rotation_matrix(np.pi, [0, 0, 1])
        symmetries = [np.eye(4).tolist(), half.tolist()]
    write_scene(a.out, scene, truth, radius, symmetries)
    print(f"{a.out}: {kind} tower {w:.0f} x {d:.0f} x {h:.0f} m, {len(truth)} copies among "
          f"{len(towers) - len(truth)} others ({(len(KINDS) - 2) * a.twins} near twins, "
          f"{2 * a.variants} taller or shorter), "
          f"{len(scene.faces)} triangles")


if __name__ == "__main__":
    main()
