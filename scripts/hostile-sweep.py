#!/usr/bin/env python3
"""Runs the release CLI on the reliability issues' hostile inputs, each
under an address-space limit and a time limit, and prints one row per
input: exit status, wall seconds, peak memory, and whether any output held
a raw control character. The issue's bar: exit 0, 1 (a typed error) or 2
(usage), within 2 GiB and 20 s, and no control character but newline.

    python3 scripts/hostile-sweep.py [--bin target/release/fast-reject]
        [--limit-s 20] [--limit-mib 2048] [--only NAME] [--keep DIR]

The small inputs come from `cargo run --example hostile_files`; the large
ones (fans, many parts) are generated here, seeded, so every run sees the
same files. Nothing is judged but those four figures: read the rows."""

import argparse
import random
import resource
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def stl(triangles):
    out = bytearray(b"hostile sweep".ljust(80) + struct.pack("<I", len(triangles)))
    for t in triangles:
        out += struct.pack("<3f", 0, 0, 0)
        for v in t:
            out += struct.pack("<3f", *v)
        out += b"\0\0"
    return bytes(out)


def ply(vertices, faces):
    head = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(vertices)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    ).encode()
    body = bytearray()
    for v in vertices:
        body += struct.pack("<3f", *v)
    for f in faces:
        body += struct.pack("<B", len(f)) + struct.pack(f"<{len(f)}i", *f)
    return head + bytes(body)


def cube(size):
    h = size / 2
    v = [(x, y, z) for z in (-h, h) for y in (-h, h) for x in (-h, h)]
    v = [v[0], v[1], v[3], v[2], v[4], v[5], v[7], v[6]]
    f = [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 6, 7), (0, 1, 5), (0, 5, 4),
         (1, 2, 6), (1, 6, 5), (2, 3, 7), (2, 7, 6), (3, 0, 4), (3, 4, 7)]
    return [tuple(v[i] for i in t) for t in f]


def right_tetrahedron(a, b, c, at=(0.0, 0.0, 0.0)):
    x, y, z = at
    v = [(x, y, z), (x + a, y, z), (x, y + b, z), (x, y, z + c)]
    return v, [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def tetrahedra(count, size, jitter, seed):
    """`count` right tetrahedra on a lattice, legs `size` times 1 +- `jitter`."""
    rng = random.Random(seed)
    side = max(1, round(count ** (1 / 3) + 0.5))
    vertices, faces = [], []
    for i in range(count):
        at = (i % side * 2 * size, i // side % side * 2 * size, i // side // side * 2 * size)
        legs = [size * (1 + jitter * (2 * rng.random() - 1)) for _ in range(3)]
        v, f = right_tetrahedron(*legs, at=at)
        base = len(vertices)
        vertices += v
        faces += [tuple(base + k for k in t) for t in f]
    return ply(vertices, faces)


def fanned_cylinder(segments):
    """A unit cylinder, two high, whose caps are fans of slivers."""
    import math
    ring = lambda z: [(math.cos(2 * math.pi * i / segments), math.sin(2 * math.pi * i / segments), z)
                      for i in range(segments)]
    bottom, top = ring(0.0), ring(2.0)
    tris = []
    for i in range(segments):
        j = (i + 1) % segments
        tris += [(bottom[i], bottom[j], top[j]), (bottom[i], top[j], top[i]),
                 ((0, 0, 2), top[i], top[j]), ((0, 0, 0), bottom[j], bottom[i])]
    return stl(tris)


def tiles(n):
    tris = []
    for i in range(n):
        for j in range(n):
            x, y = 1.5 * i, 1.5 * j
            tris += [((x, y, 0), (x + 1, y, 0), (x + 1, y + 1, 0)),
                     ((x, y, 0), (x + 1, y + 1, 0), (x, y + 1, 0))]
    return stl(tris)


def generated(folder):
    """The large inputs, written once into `folder`."""
    files = {
        "cube-100.stl": lambda: stl(cube(100.0)),
        "tetrahedron-0.05.stl": lambda: stl([tuple(right_tetrahedron(0.05, 0.05, 0.05)[0][i] for i in t)
                                             for t in right_tetrahedron(0.05, 0.05, 0.05)[1]]),
        "one-tetrahedron.ply": lambda: ply(*right_tetrahedron(0.575, 0.498, 0.425)),
        "tetrahedra-jittered-2000.ply": lambda: tetrahedra(2000, 0.5, 0.25, 1),
        "tetrahedra-jittered-20000.ply": lambda: tetrahedra(20000, 0.5, 0.25, 2),
        "tetrahedra-tiny-100000.ply": lambda: tetrahedra(100000, 0.01, 0.25, 3),
        "tiny-tetrahedron.ply": lambda: ply(*right_tetrahedron(0.01, 0.01, 0.01)),
        "fanned-cylinder-6000.stl": lambda: fanned_cylinder(6000),
        "fanned-cylinder-24000.stl": lambda: fanned_cylinder(24000),
        "tiles-10x10.stl": lambda: tiles(10),
    }
    for name, make in files.items():
        path = folder / name
        if not path.exists():
            path.write_bytes(make())


def cases(d):
    """(name, arguments) per input; paths are inside `d`."""
    m = lambda *a: ["match", *[str(x) for x in a]]
    return [
        ("cube 100 wide, tetrahedron 0.05", m(d / "cube-100.stl", "--template", d / "tetrahedron-0.05.stl")),
        ("PLY of 255-corner faces", m(d / "wide-faces.ply", "--template", d / "tetrahedron.stl")),
        ("memory budget 2^64-1", m(d / "tetrahedron.stl", "--template", d / "tetrahedron.stl",
                                   "--memory-budget", 2**64 - 1)),
        ("escape sequences in a buffer uri", m(d / "escape-sequences.gltf", "--template", d / "tetrahedron.stl")),
        ("STL whose header says glTF (template)", m(d / "tiles-10x10.stl", "--template", d / "header-gltf.stl")),
        ("quantized positions, string extras", m(d / "quantized.gltf", "--template", d / "tetrahedron.stl")),
        ("100 flat tiles, one selected", m(d / "tiles-10x10.stl", "--select", "0.5,0.5,0,0.8")),
        ("--group-radius -1", m(d / "tetrahedron.stl", "--template", d / "tetrahedron.stl", "--group-radius", -1)),
        ("2000 instances of 20k triangles", m(d / "instanced-2000.gltf", "--template", d / "tetrahedron.stl")),
        ("tiny part in a wide scene", m(d / "tiny-in-wide.stl", "--template", d / "tetrahedron.stl")),
        ("2000 random triangles", m(d / "random-2000.stl", "--template", d / "tetrahedron.stl")),
        ("buffer outside the folder", m(d / "escape-parent.gltf", "--template", d / "tetrahedron.stl")),
        ("sparse accessor of 1e9", m(d / "sparse-1e9.gltf", "--template", d / "tetrahedron.stl")),
        ("2000 jittered tetrahedra", m(d / "tetrahedra-jittered-2000.ply", "--template", d / "one-tetrahedron.ply")),
        ("20000 jittered tetrahedra", m(d / "tetrahedra-jittered-20000.ply", "--template", d / "one-tetrahedron.ply")),
        ("100000 tiny tetrahedra", m(d / "tetrahedra-tiny-100000.ply", "--template", d / "tiny-tetrahedron.ply")),
        ("100000 tiny tetrahedra, 20 MiB", m(d / "tetrahedra-tiny-100000.ply", "--template",
                                             d / "tiny-tetrahedron.ply", "--memory-budget", 20)),
        ("fanned cylinder 6000, curvature", m(d / "fanned-cylinder-6000.stl", "--descriptor", "curvature",
                                              "--select", "1,0,2,0.3")),
        ("fanned cylinder 24000, curvature", m(d / "fanned-cylinder-24000.stl", "--descriptor", "curvature",
                                               "--select", "1,0,2,0.3")),
    ]


def raw_control(data):
    return any(b < 0x20 and b not in (0x0A, 0x09) or b == 0x7F for b in data)


def run(binary, args, limit_s, limit_mib):
    def limits():
        size = limit_mib << 20
        resource.setrlimit(resource.RLIMIT_AS, (size, size))

    start = time.monotonic()
    proc = subprocess.Popen([str(binary), *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=limits)
    try:
        out, err = proc.communicate(timeout=limit_s)
        status = proc.returncode
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        status = "timeout"
    seconds = time.monotonic() - start
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    return status, seconds, peak, raw_control(out + err), err.decode("utf-8", "replace").strip()


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bin", default=str(ROOT / "target/release/fast-reject"))
    p.add_argument("--limit-s", type=float, default=20.0)
    p.add_argument("--limit-mib", type=int, default=2048)
    p.add_argument("--only", help="run the cases whose name holds this")
    p.add_argument("--keep", help="a folder for the inputs, kept between runs")
    a = p.parse_args()
    folder = Path(a.keep) if a.keep else Path(tempfile.mkdtemp(prefix="hostile-sweep-"))
    folder.mkdir(parents=True, exist_ok=True)
    subprocess.run(["cargo", "run", "--quiet", "--release", "--example", "hostile_files", "--", str(folder)],
                   cwd=ROOT, check=True)
    generated(folder)
    print(f"{'input':40} {'exit':>7} {'s':>7} {'peak MiB':>9}  raw control  last line of stderr")
    worst = 0
    for name, args in cases(folder):
        if a.only and a.only not in name:
            continue
        # Peak memory is the largest child so far: measure each in its own
        # process so that one input's peak is not another's.
        code = (
            "import sys, json; sys.path.insert(0, %r); import importlib.util as u;"
            "s = u.spec_from_file_location('sweep', %r); m = u.module_from_spec(s); s.loader.exec_module(m);"
            "print(json.dumps(m.run(%r, %r, %r, %r)))"
        ) % (str(ROOT / "scripts"), __file__, a.bin, [str(x) for x in args], a.limit_s, a.limit_mib)
        import json
        result = json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                           check=True).stdout)
        status, seconds, peak, control, err = result
        line = err.splitlines()[-1] if err else ""
        ok = status in (0, 1, 2) and seconds <= a.limit_s and not control
        worst = max(worst, 0 if ok else 1)
        print(f"{name:40} {str(status):>7} {seconds:7.2f} {peak:9.0f}  {'YES' if control else 'no':11}  "
              f"{line[:100]}")
    return worst


if __name__ == "__main__":
    sys.exit(main())
