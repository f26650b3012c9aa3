#!/usr/bin/env python3
"""Writes the committed seed corpus, fuzz/seeds/<target>/: tiny valid files of
every format the loaders read, each a few bytes to a few KB.

    python3 fuzz/make_seeds.py        (rewrites fuzz/seeds/ from scratch)

Deterministic: the same files every time, so a re-run shows no git diff.
"""
import base64
import json
import os
import shutil
import struct

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "seeds")

# A tetrahedron, a unit cube (12 triangles) and a cube with a box on top: closed
# meshes with a little structure for the search.
TET_V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TET_F = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def box(x0, y0, z0, x1, y1, z1, base=0):
    v = [(x, y, z) for z in (z0, z1) for y in (y0, y1) for x in (x0, x1)]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    f = []
    for a, b, c, d in quads:
        f += [(base + a, base + b, base + c), (base + a, base + c, base + d)]
    return v, f, [tuple(base + i for i in q) for q in quads]


CUBE_V, CUBE_F, CUBE_Q = box(0, 0, 0, 1, 1, 1)
_top_v, _top_f, _top_q = box(0.25, 0.25, 1, 0.75, 0.75, 1.6, base=8)
TOWER_V, TOWER_F, TOWER_Q = CUBE_V + _top_v, CUBE_F + _top_f, CUBE_Q + _top_q


def write(target, name, data):
    d = os.path.join(ROOT, target)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def num(x):
    return repr(float(x)).rstrip("0").rstrip(".") if x != int(x) else str(int(x))


# --- OBJ -------------------------------------------------------------------

def obj_plain(v, f):
    return "".join(f"v {' '.join(num(c) for c in p)}\n" for p in v) + "".join(
        f"f {' '.join(str(i + 1) for i in t)}\n" for t in f)


def obj_negative_polygons():
    # Quads with negative (relative) indices, written after each face's own
    # vertices, plus the other corner forms, comments, CRLF and a continuation.
    out = ["# cube: quads, negative indices\r\n", "o cube\n", "mtllib none.mtl\n"]
    for q in CUBE_Q:
        for i in q:
            out.append("v %s\n" % " ".join(num(c) for c in CUBE_V[i]))
        out.append("vt 0 0\nvn 0 0 1\n")
        out.append("f -4/-1/-1 -3/-1/-1 -2//-1 -1\n")
    out.append("g rest\ns off\nusemtl x\n")
    out.append("v 0 0 2 1.0\nv 1 0 2 0.5 0.5 0.5\nv 1 1 2\nv 0.5 1.5 2\nv 0 1 2\n")
    out.append("f -5 -4 \\\n -3 -2 -1\n")  # a pentagon over a line continuation
    out.append("l 1 2\np 3\n")
    return "".join(out)


# --- PLY -------------------------------------------------------------------

def ply_ascii(v, faces):
    head = ("ply\nformat ascii 1.0\ncomment tiny\nelement vertex %d\n"
            "property float x\nproperty float y\nproperty float z\nproperty uchar red\n"
            "element face %d\nproperty list uchar int vertex_indices\n"
            "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n") % (len(v), len(faces))
    body = "".join("%s %s %s 200\n" % tuple(num(c) for c in p) for p in v)
    body += "".join("%d %s\n" % (len(f), " ".join(map(str, f))) for f in faces)
    body += "0 1\n"
    return head + body


def ply_binary(v, faces, big_endian, coord="double", index="uint", count="uchar"):
    e = ">" if big_endian else "<"
    fmt = {"float": "f", "double": "d"}[coord]
    ifmt = {"int": "i", "uint": "I", "short": "h", "ushort": "H"}[index]
    cfmt = {"uchar": "B", "ushort": "H"}[count]
    head = ("ply\r\nformat binary_%s_endian 1.0\r\nelement vertex %d\r\n"
            "property %s x\r\nproperty %s y\r\nproperty %s z\r\nproperty float nx\r\n"
            "element face %d\r\nproperty list %s %s vertex_index\r\nproperty uchar flags\r\nend_header\r\n") % (
        "big" if big_endian else "little", len(v), coord, coord, coord, len(faces), count, index)
    body = b"".join(struct.pack(e + fmt * 3 + "f", *p, 0.0) for p in v)
    for f in faces:
        body += struct.pack(e + cfmt + ifmt * len(f) + "B", len(f), *f, 7)
    return head.encode() + body


# --- STL -------------------------------------------------------------------

def stl_ascii(v, f, name="tiny"):
    out = ["solid %s\n" % name]
    for t in f:
        out.append("  facet normal 0 0 0\n    outer loop\n")
        for i in t:
            out.append("      vertex %s\n" % " ".join(num(c) for c in v[i]))
        out.append("    endloop\n  endfacet\n")
    out.append("endsolid %s\n" % name)
    return "".join(out)


def stl_binary(v, f, header=b"solid binary header"):
    out = header.ljust(80, b" ") + struct.pack("<I", len(f))
    for t in f:
        out += struct.pack("<3f", 0, 0, 0)
        for i in t:
            out += struct.pack("<3f", *v[i])
        out += b"\0\0"
    return out


# --- glTF ------------------------------------------------------------------

def gltf_parts(v, f, index_type=5123, mode=None, sparse=False, nodes=None):
    """The JSON and the binary buffer of one mesh."""
    pos = b"".join(struct.pack("<3f", *p) for p in v)
    flat = [i for t in f for i in t]
    if index_type == 5121:
        idx = bytes(flat)
    elif index_type == 5123:
        idx = struct.pack("<%dH" % len(flat), *flat)
    else:
        idx = struct.pack("<%dI" % len(flat), *flat)
    idx += b"\0" * (-len(idx) % 4)
    buf = pos + idx
    lo = [min(p[k] for p in v) for k in range(3)]
    hi = [max(p[k] for p in v) for k in range(3)]
    views = [
        {"buffer": 0, "byteOffset": 0, "byteLength": len(pos), "target": 34962},
        {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx), "target": 34963},
    ]
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": len(v), "type": "VEC3", "min": lo, "max": hi},
        {"bufferView": 1, "componentType": index_type, "count": len(flat), "type": "SCALAR"},
    ]
    if sparse:
        # Move vertex 0 by a sparse substitution: one u8 index, one VEC3 value.
        extra = bytes([0, 0, 0, 0]) + struct.pack("<3f", -0.5, -0.5, -0.5)
        views += [
            {"buffer": 0, "byteOffset": len(buf), "byteLength": 1},
            {"buffer": 0, "byteOffset": len(buf) + 4, "byteLength": 12},
        ]
        buf += extra
        accessors[0]["sparse"] = {
            "count": 1,
            "indices": {"bufferView": 2, "componentType": 5121},
            "values": {"bufferView": 3},
        }
        accessors[0]["min"] = [min(a, -0.5) for a in lo]
    prim = {"attributes": {"POSITION": 0}, "indices": 1}
    if mode is not None:
        prim["mode"] = mode
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes))) if nodes else [0]}],
        "nodes": nodes or [{"mesh": 0}],
        "meshes": [{"primitives": [prim]}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(buf)}],
    }
    return doc, buf


def gltf_embedded(doc, buf):
    doc = json.loads(json.dumps(doc))
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(buf).decode()
    return json.dumps(doc, indent=1)


def gltf_external(doc, uri):
    doc = json.loads(json.dumps(doc))
    doc["buffers"][0]["uri"] = uri
    return json.dumps(doc, indent=1)


def glb(doc, buf):
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    buf = buf + b"\0" * (-len(buf) % 4)
    chunks = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(buf), 0x004E4942) + buf
    return b"glTF" + struct.pack("<II", 2, 12 + len(chunks)) + chunks


def main():
    if os.path.isdir(ROOT):
        shutil.rmtree(ROOT)
    seeds = {}  # name -> bytes, also reused for load_any and search_small

    seeds["tet.obj"] = obj_plain(TET_V, TET_F)
    seeds["cube-negative-quads.obj"] = obj_negative_polygons()
    seeds["tower.obj"] = obj_plain(TOWER_V, TOWER_F)

    seeds["cube-ascii.ply"] = ply_ascii(CUBE_V, CUBE_Q)
    seeds["tet-le.ply"] = ply_binary(TET_V, TET_F, False, "float", "int")
    seeds["cube-be.ply"] = ply_binary(CUBE_V, CUBE_Q, True, "double", "ushort", "ushort")
    seeds["tower-le.ply"] = ply_binary(TOWER_V, TOWER_Q, False, "float", "uint")

    seeds["tet-ascii.stl"] = stl_ascii(TET_V, TET_F)
    seeds["cube-binary.stl"] = stl_binary(CUBE_V, CUBE_F)
    seeds["tet-binary-noname.stl"] = stl_binary(TET_V, TET_F, header=b"")
    # Two solids, odd case and layout, and a quad loop.
    seeds["two-solids.stl"] = (stl_ascii(TET_V, TET_F, "a").upper().replace("\n      ", "\n\t")
                               + "solid\nfacet normal 0 0 1\nouter loop\nvertex 0 0 5\nvertex 1 0 5\n"
                               "vertex 1 1 5\nvertex 0 1 5\nendloop\nendfacet\nendsolid\n")

    doc, buf = gltf_parts(TET_V, TET_F)
    seeds["tet-embedded.gltf"] = gltf_embedded(doc, buf)
    seeds["tet.glb"] = glb(doc, buf)
    doc_u8, buf_u8 = gltf_parts(CUBE_V, CUBE_F, index_type=5121, sparse=True)
    seeds["cube-sparse.glb"] = glb(doc_u8, buf_u8)
    # A strip (mode 5) with u32 indices.
    strip_v = [(0, 0, 0), (0, 1, 0), (1, 0, 0), (1, 1, 0.2), (2, 0, 0), (2, 1, 0)]
    doc_s, buf_s = gltf_parts(strip_v, [(0, 1, 2), (3, 4, 5)], index_type=5125, mode=5)
    seeds["strip-u32-embedded.gltf"] = gltf_embedded(doc_s, buf_s)
    # One mesh on two nodes (instances) under a parent with a transform.
    nodes = [
        {"children": [1, 2], "translation": [1, 2, 3], "scale": [2, 2, 2]},
        {"mesh": 0, "rotation": [0, 0, 0.7071068, 0.7071068]},
        {"mesh": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 3, 0, 0, 1]},
    ]
    doc_i, buf_i = gltf_parts(TOWER_V, TOWER_F, nodes=nodes)
    doc_i["scenes"] = [{"nodes": [0]}]
    seeds["tower-instanced.glb"] = glb(doc_i, buf_i)

    by_ext = {"obj": "load_obj", "ply": "load_ply", "stl": "load_stl", "gltf": "load_gltf", "glb": "load_gltf"}
    for name, data in seeds.items():
        write(by_ext[name.rsplit(".", 1)[1]], name, data)
        write("load_any", name, data)

    # gltf_resolver: a document, then files after "\n@@file NAME\n" lines.
    def bundle(document, files):
        out = document.encode() if isinstance(document, str) else document
        for n, c in files:
            out += b"\n@@file " + n.encode() + b"\n" + c
        return out

    write("gltf_resolver", "tet-external.gltf", bundle(gltf_external(doc, "tet.bin"), [("tet.bin", buf)]))
    write("gltf_resolver", "cube-subdir-escaped.gltf",
          bundle(gltf_external(doc_u8, "./parts//my%20cube.bin"), [("parts/my cube.bin", buf_u8)]))
    write("gltf_resolver", "tet-missing-file.gltf", bundle(gltf_external(doc, "missing.bin"), [("tet.bin", buf)]))
    write("gltf_resolver", "tet-short-file.gltf", bundle(gltf_external(doc, "tet.bin"), [("tet.bin", buf[:20])]))
    write("gltf_resolver", "tet-embedded.gltf", bundle(seeds["tet-embedded.gltf"], []))
    write("gltf_resolver", "tet.glb", bundle(seeds["tet.glb"], [("unused.bin", b"\1\2\3")]))
    # Two buffers, one embedded and one external, one view into each.
    two = json.loads(gltf_external(doc, "pos.bin"))
    two["buffers"] = [{"uri": "pos.bin", "byteLength": 48},
                      {"uri": "data:application/octet-stream;base64," + base64.b64encode(buf[48:]).decode(),
                       "byteLength": len(buf) - 48}]
    two["bufferViews"][1] = {"buffer": 1, "byteOffset": 0, "byteLength": len(buf) - 48}
    write("gltf_resolver", "two-buffers.gltf", bundle(json.dumps(two, indent=1), [("pos.bin", buf[:48])]))
    # Plain URIs for ResourcePath::parse (the whole input is one).
    for i, uri in enumerate(["a/b%20c.bin", "../x.bin", "%2e%2e/x", "C:/w.bin", "a\\b.bin", "caf%C3%A9.bin"]):
        write("gltf_resolver", "uri-%d" % i, uri)

    # search_small: 8 parameter bytes (see fuzz_targets/search_small.rs), then a file.
    params = {
        "tower.obj": bytes([24, 128, 128, 200, 5, 60, 0, 2]),
        "tower-le.ply": bytes([16, 128, 128, 60, 7, 120, 1, 5]),
        "cube-binary.stl": bytes([12, 0, 0, 0, 9, 200, 2, 0]),
        "tower-instanced.glb": bytes([32, 100, 30, 30, 3, 90, 3, 0x83]),
        "cube-negative-quads.obj": bytes([8, 128, 128, 128, 4, 0, 0, 5]),
        "tet-ascii.stl": bytes([20, 10, 10, 10, 1, 0, 3, 1]),
        "cube-ascii.ply": bytes([48, 255, 255, 255, 4, 255, 1, 3]),
    }
    for name, p in params.items():
        data = seeds[name]
        write("search_small", name, p + (data.encode() if isinstance(data, str) else data))

    # load_ply_limited: the PLY seeds, and faces of 255 one-byte corners
    # (twelve times their bytes of triangles) past the target's limit.
    for name, data in seeds.items():
        if name.endswith(".ply"):
            write("load_ply_limited", name, data)
    wide = (b"ply\nformat binary_little_endian 1.0\nelement vertex 256\n"
            b"property uchar x\nproperty uchar y\nproperty uchar z\n"
            b"element face 32\nproperty list uchar uchar vertex_indices\nend_header\n")
    wide += bytes(c for i in range(256) for c in (i % 7, i // 7 % 7, i // 49))
    wide += (bytes([255]) + bytes(range(255))) * 32
    write("load_ply_limited", "wide-faces.ply", wide)

    # message_text: files whose words and names carry terminal escapes.
    attack = "\x1b[2J\x1b[Hall good\x1b]52;c;aGk=\x07\u202e"
    write("message_text", "header.ply", "ply\nformat ascii 1.0\n%s 1\nend_header\n" % attack)
    write("message_text", "vertex.obj", "v 1 %s 3\nf 1 1 1\n" % attack)
    write("message_text", "facet.stl", "solid x\nfacet %s\nendsolid\n" % attack)
    write("message_text", "uri.gltf", gltf_external(doc, attack.replace("\x1b", "%1B")))
    write("message_text", "value.gltf", json.dumps({"asset": {"version": "2.0"}, "scenes": attack}))


if __name__ == "__main__":
    main()
