//! Shells: the edge-connected components of a part, each filled on its own.

use crate::exec::Threads;
use crate::math::Vec3;
use crate::mesh::{TriMesh, weld_vertices};

/// The triangles of one edge-connected component, whether it is closed,
/// and whether it faces one way.
pub(crate) struct Shell {
    /// Triangle indices into the mesh.
    pub triangles: Vec<u32>,
    /// Every edge is shared by an even number of the shell's triangles.
    pub closed: bool,
    /// Every triangle faces into one open half-space: a terrain, a sheet, a
    /// shallow bowl, a lone triangle. A column along that half-space's
    /// direction crosses such a shell the same way every time, out and never
    /// back in, so the shell bounds no solid of its own, and any column that
    /// calls a voxel inside it is miscounting through its rim.
    pub one_sided: bool,
}

/// Triangle indices of each shell.
///
/// Triangles belong to one shell when they share an edge (after welding, so
/// that texture seams do not cut a surface apart). Sharing a single vertex is
/// not enough: two objects that merely touch, or interpenetrate with a few
/// coincident vertices, must be filled separately and united, never merged
/// into one parity count. Shells never cross parts (separately placed
/// meshes are separate objects), and instances of one mesh share its
/// connectivity, computed once. Distinct parts are split into shells in
/// parallel: that was the serial half of filling a scene.
pub(crate) fn shells(mesh: &TriMesh, backend: Threads) -> Vec<Shell> {
    let parts = mesh.parts();
    let local_tris: Vec<Vec<[u32; 3]>> = parts
        .iter()
        .map(|part| {
            let first = part.first_triangle as usize;
            mesh.triangles()[first..first + part.triangle_count as usize]
                .iter()
                .map(|t| t.map(|i| i - part.first_vertex))
                .collect()
        })
        .collect();
    // Each part's computing twin: the first part with the same source and
    // the same triangles (a degenerate triangle dropped in one instance only
    // would differ), itself when there is none.
    let mut twin: Vec<usize> = Vec::with_capacity(parts.len());
    for i in 0..parts.len() {
        let found = (0..i).find(|&j| {
            twin[j] == j && parts[j].source == parts[i].source && local_tris[j] == local_tris[i]
        });
        twin.push(found.unwrap_or(i));
    }
    let distinct: Vec<usize> = (0..parts.len()).filter(|&i| twin[i] == i).collect();
    let distinct_shells = backend.map_each(distinct.len(), |k| {
        let part = &parts[distinct[k]];
        let vertices = part.first_vertex as usize..(part.first_vertex + part.vertex_count) as usize;
        part_shells(&mesh.positions()[vertices], &local_tris[distinct[k]])
    });
    let mut shells = Vec::new();
    for (i, part) in parts.iter().enumerate() {
        let k = distinct.binary_search(&twin[i]).expect("a twin computes");
        let first = part.first_triangle;
        shells.extend(distinct_shells[k].iter().map(|s| Shell {
            triangles: s.triangles.iter().map(|&t| t + first).collect(),
            closed: s.closed,
            one_sided: s.one_sided,
        }));
    }
    shells
}

/// Shells of one part, as triangle indices within it.
fn part_shells(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<Shell> {
    let (ids, n) = weld_vertices(positions);
    let tris: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| t.map(|i| ids[i as usize]))
        .collect();
    // Triangles around each welded vertex (counting sort, no hashing).
    let mut start = vec![0u32; n + 1];
    for t in &tris {
        for &v in t {
            start[v as usize + 1] += 1;
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    // Each incident triangle with its two other corners, so that finding the
    // triangle across an edge reads one vertex's list and nothing else.
    let mut fill = start.clone();
    let mut around = vec![(0u32, 0u32, 0u32); tris.len() * 3];
    for (ti, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let v = t[k] as usize;
            around[fill[v] as usize] = (ti as u32, t[(k + 1) % 3], t[(k + 2) % 3]);
            fill[v] += 1;
        }
    }
    let mut parent: Vec<u32> = (0..tris.len() as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            let p = parent[x as usize];
            parent[x as usize] = parent[p as usize];
            x = p;
        }
        x
    }
    // Triangles with an edge that an odd number of triangles use: they open
    // their shell. The edge v-w is used by every triangle around v that has
    // w as one of its other corners: one, plus those that share w with it.
    let mut open_edge_triangles = Vec::new();
    let mut sharing: Vec<[u32; 2]> = Vec::new();
    for v in 0..n {
        let list = &around[start[v] as usize..start[v + 1] as usize];
        sharing.clear();
        sharing.resize(list.len(), [0, 0]);
        // Two triangles around v share an edge when they share another corner.
        for (i, &(t1, a1, b1)) in list.iter().enumerate() {
            for (j, &(t2, a2, b2)) in list.iter().enumerate().skip(i + 1) {
                let (a1_shared, b1_shared) = (a1 == a2 || a1 == b2, b1 == a2 || b1 == b2);
                if a1_shared || b1_shared {
                    sharing[i][0] += a1_shared as u32;
                    sharing[i][1] += b1_shared as u32;
                    sharing[j][0] += (a2 == a1 || a2 == b1) as u32;
                    sharing[j][1] += (b2 == a1 || b2 == b1) as u32;
                    let (r1, r2) = (find(&mut parent, t1), find(&mut parent, t2));
                    if r1 != r2 {
                        parent[r1.max(r2) as usize] = r1.min(r2);
                    }
                }
            }
        }
        // Each edge once, from its lower end.
        for (&(t, a, b), shared) in list.iter().zip(&sharing) {
            if (a as usize > v && shared[0] % 2 == 0) || (b as usize > v && shared[1] % 2 == 0) {
                open_edge_triangles.push(t);
            }
        }
    }
    let mut shell_of_root = vec![u32::MAX; tris.len()];
    let mut shells: Vec<Shell> = Vec::new();
    for ti in 0..tris.len() as u32 {
        let root = find(&mut parent, ti) as usize;
        if shell_of_root[root] == u32::MAX {
            shell_of_root[root] = shells.len() as u32;
            shells.push(Shell {
                triangles: Vec::new(),
                closed: true,
                one_sided: false,
            });
        }
        shells[shell_of_root[root] as usize].triangles.push(ti);
    }
    for t in open_edge_triangles {
        let root = find(&mut parent, t) as usize;
        shells[shell_of_root[root] as usize].closed = false;
    }
    for shell in shells.iter_mut().filter(|s| !s.closed) {
        shell.one_sided = faces_one_way(positions, triangles, &shell.triangles);
    }
    shells
}

/// Whether every triangle of `shell` with an area faces into the half-space
/// of the shell's vector area (the sum of its area-weighted normals). A
/// closed surface's vector area is zero, so it never does; a shell that
/// does is told without solving for the best direction, and one that faces
/// one way only about another direction is filled as before.
fn faces_one_way(positions: &[[f32; 3]], triangles: &[[u32; 3]], shell: &[u32]) -> bool {
    let normal = |t: u32| {
        let [a, b, c] =
            triangles[t as usize].map(|i| Vec3::from(positions[i as usize].map(f64::from)));
        (b - a).cross(c - a)
    };
    let direction: Vec3 = shell.iter().map(|&t| normal(t)).sum();
    shell.iter().all(|&t| {
        let n = normal(t);
        n == Vec3::ZERO || n.dot(direction) > 0.0
    })
}
