#!/usr/bin/env python3
"""Scenes that time how `fast-reject repeats` scales with the number of
parts, written as binary glTF with the standard library alone:

  materials  N copies of one lopsided box (a box with a corner pulled out,
             so that no turn maps it onto itself), each a node of its own
             drawn in material k mod M (--materials M, default N: each in
             its own). The shape alone is one family of N copies; split by
             material it is M families, none where M = N.
  mirrors    N distinct lopsided boxes (each its own size) and, for each,
             one mirror image placed and turned at random, as a CAD model's
             left and right parts are: N families of two, one copy
             mirrored. --turned places a turned copy instead of a mirror
             image.

  python3 scripts/make-repeat-scaling-scenes.py materials OUT.glb N [--materials M]
  python3 scripts/make-repeat-scaling-scenes.py mirrors OUT.glb N [--turned] [--seed 1]

Time with `target/release/fast-reject repeats OUT.glb --json`.
"""
import argparse
import json
import math
import random
import struct


def lopsided(size):
    """The 8 corners and 12 triangles (faces outwards) of a box of `size`
    with its far corner pulled out."""
    sx, sy, sz = size
    corners = []
    for k in range(8):
        p = [sx if k & 1 else 0.0, sy if k & 2 else 0.0, sz if k & 4 else 0.0]
        if k == 7:
            p = [p[0] + 0.4 * sx, p[1] + 0.2 * sy, p[2] + 0.5 * sz]
        corners.append(p)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    triangles = []
    for a, b, c, d in quads:
        triangles += [(a, b, c), (a, c, d)]
    return corners, triangles


def random_turn(rng):
    """A uniformly random rotation matrix (from a unit quaternion)."""
    u1, u2, u3 = rng.random(), rng.random(), rng.random()
    w = math.sqrt(1 - u1) * math.sin(2 * math.pi * u2)
    x = math.sqrt(1 - u1) * math.cos(2 * math.pi * u2)
    y = math.sqrt(u1) * math.sin(2 * math.pi * u3)
    z = math.sqrt(u1) * math.cos(2 * math.pi * u3)
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]


def moved(m, at, p):
    return [sum(m[r][c] * p[c] for c in range(3)) + at[r] for r in range(3)]


class Glb:
    """Meshes of one primitive each, and nodes placing them."""

    def __init__(self):
        self.blob = bytearray()
        self.views, self.accessors, self.meshes, self.nodes = [], [], [], []

    def accessor(self, data, kind, component, count, extra=None):
        while len(self.blob) % 4:
            self.blob.append(0)
        self.views.append({"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)})
        self.blob += data
        accessor = {"bufferView": len(self.views) - 1, "componentType": component,
                    "count": count, "type": kind}
        accessor.update(extra or {})
        self.accessors.append(accessor)
        return len(self.accessors) - 1

    def mesh(self, corners, triangles, material=None):
        flat = [x for p in corners for x in p]
        lo = [min(p[i] for p in corners) for i in range(3)]
        hi = [max(p[i] for p in corners) for i in range(3)]
        position = self.accessor(struct.pack(f"<{len(flat)}f", *flat), "VEC3", 5126,
                                 len(corners), {"min": lo, "max": hi})
        flat = [i for t in triangles for i in t]
        indices = self.accessor(struct.pack(f"<{len(flat)}I", *flat), "SCALAR", 5125,
                                len(flat))
        primitive = {"attributes": {"POSITION": position}, "indices": indices}
        if material is not None:
            primitive["material"] = material
        self.meshes.append({"primitives": [primitive]})
        return len(self.meshes) - 1

    def node(self, mesh, translation=None):
        node = {"mesh": mesh}
        if translation:
            node["translation"] = translation
        self.nodes.append(node)

    def write(self, path, materials=0):
        doc = {
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": list(range(len(self.nodes)))}],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{"byteLength": len(self.blob)}],
        }
        if materials:
            doc["materials"] = [
                {"name": f"m{k}", "pbrMetallicRoughness": {"baseColorFactor": [
                    (k % 7) / 7, (k % 11) / 11, (k % 13) / 13, 1]}}
                for k in range(materials)
            ]
        text = json.dumps(doc, separators=(",", ":")).encode()
        text += b" " * (-len(text) % 4)
        blob = bytes(self.blob) + b"\0" * (-len(self.blob) % 4)
        with open(path, "wb") as f:
            f.write(struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(text) + 8 + len(blob)))
            f.write(struct.pack("<II", len(text), 0x4E4F534A) + text)
            f.write(struct.pack("<II", len(blob), 0x004E4942) + blob)


def materials(args):
    glb = Glb()
    corners, triangles = lopsided((1.0, 2.0, 3.0))
    count = args.materials or args.n
    # One mesh per material, each node placing one at its own place.
    meshes = [glb.mesh(corners, triangles, k) for k in range(count)]
    side = math.ceil(math.sqrt(args.n))
    for k in range(args.n):
        glb.node(meshes[k % count], [5.0 * (k % side), 5.0 * (k // side), 0.0])
    glb.write(args.out, count)


def mirrors(args):
    rng = random.Random(args.seed)
    glb = Glb()
    side = math.ceil(math.sqrt(2 * args.n))
    for k in range(args.n):
        # Sizes that differ far past the tolerance: distinct parts.
        size = (1.0 + 0.01 * (k % 100), 2.0 + 0.01 * (k // 100 % 100), 3.0 + 0.53 * rng.random())
        corners, triangles = lopsided(size)
        for copy in range(2):
            slot = 2 * k + copy
            at = [20.0 * (slot % side), 20.0 * (slot // side), 0.0]
            m = random_turn(rng)
            placed = [moved(m, at, p) for p in corners]
            faces = triangles
            if copy == 1 and not args.turned:
                # Reflected in x, its triangles turned over to face out.
                placed = [[2 * at[0] - p[0], p[1], p[2]] for p in placed]
                faces = [(a, c, b) for a, b, c in triangles]
            glb.node(glb.mesh(placed, faces))
    glb.write(args.out)


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("recipe", choices=["materials", "mirrors"])
    parser.add_argument("out")
    parser.add_argument("n", type=int)
    parser.add_argument("--materials", type=int, default=0)
    parser.add_argument("--turned", action="store_true")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    {"materials": materials, "mirrors": mirrors}[args.recipe](args)


if __name__ == "__main__":
    main()
