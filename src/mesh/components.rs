//! Connected components: the parts an assembly is made of.
//!
//! A real scene is many parts that touch, sit in bores or rest on each
//! other, and a part's descriptor must not see its neighbours. Files split
//! vertices along seams, so vertices at the same position are welded first;
//! what is then joined by shared vertices is one component.

use std::sync::atomic::AtomicU32;
use std::sync::atomic::Ordering::Relaxed;

use super::{TriMesh, weld_vertices_on};
use crate::exec::Threads;

/// The triangles of each connected component (joined through welded
/// vertices), in order of their first triangle; triangles ascending. The
/// weld and the joining use `backend`'s threads.
pub fn connected_components(mesh: &TriMesh, backend: Threads) -> Vec<Vec<u32>> {
    let (ids, welded) = weld_vertices_on(mesh.positions(), backend);
    components_through(mesh, &ids, welded, backend)
}

/// The pieces as the file stores them: triangles joined through the
/// vertices they index, unwelded. A CAD body's faces, or copies that
/// overlap with coincident vertices, stay apart; in order of their first
/// triangle, triangles ascending.
pub fn stored_pieces(mesh: &TriMesh, backend: Threads) -> Vec<Vec<u32>> {
    let ids: Vec<u32> = (0..mesh.positions().len() as u32).collect();
    components_through(mesh, &ids, ids.len(), backend)
}

/// The components of triangles joined through shared `ids` (a vertex's
/// number among `count`).
fn components_through(
    mesh: &TriMesh,
    ids: &[u32],
    count: usize,
    backend: Threads,
) -> Vec<Vec<u32>> {
    let welded = count;
    let parent: Vec<AtomicU32> = (0..welded as u32).map(AtomicU32::new).collect();
    let triangles = mesh.triangles();
    backend.for_each_range(triangles.len(), 1 << 14, |range| {
        for t in &triangles[range] {
            let [a, b, c] = t.map(|i| ids[i as usize]);
            join(&parent, a, b);
            join(&parent, a, c);
        }
    });
    let roots = backend.map(triangles.len(), |t| {
        root(&parent, ids[triangles[t][0] as usize])
    });
    let mut component_of_root = vec![u32::MAX; welded];
    let mut components: Vec<Vec<u32>> = Vec::new();
    for (i, &r) in roots.iter().enumerate() {
        let r = r as usize;
        if component_of_root[r] == u32::MAX {
            component_of_root[r] = components.len() as u32;
            components.push(Vec::new());
        }
        components[component_of_root[r] as usize].push(i as u32);
    }
    components
}

// A union-find that threads share without a lock: a vertex's parent is
// never above it (a root is linked under a lower one, and halving a path
// points a vertex at its grandparent), so no cycle forms; a root changes
// only by a compare-exchange that finds it still a root; and every value
// a parent ever holds stays an ancestor, as trees only merge. So relaxed
// loads and stores suffice, and the sets, whatever the threads'
// interleaving, are the connected ones.

/// The root of `v`'s tree, halving the path on the way.
fn root(parent: &[AtomicU32], mut v: u32) -> u32 {
    loop {
        let up = parent[v as usize].load(Relaxed);
        if up == v {
            return v;
        }
        let above = parent[up as usize].load(Relaxed);
        if above != up {
            // `v` is no root, so no link writes it: a store is safe.
            parent[v as usize].store(above, Relaxed);
        }
        v = above;
    }
}

/// Joins the trees of `a` and `b`: the higher root goes under the lower.
fn join(parent: &[AtomicU32], a: u32, b: u32) {
    let (mut a, mut b) = (a, b);
    loop {
        (a, b) = (root(parent, a), root(parent, b));
        if a == b {
            return;
        }
        let (low, high) = (a.min(b), a.max(b));
        match parent[high as usize].compare_exchange(high, low, Relaxed, Relaxed) {
            Ok(_) => return,
            // Another thread linked `high` first: look again.
            Err(_) => (a, b) = (low, high),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::mesh::shapes::{cuboid, uv_sphere};

    #[test]
    fn touching_solids_are_separate_unless_they_share_vertices() {
        // A cube, a second one on its +x face sharing its four corners, a
        // third on its +y face shifted so that no corner coincides, and a
        // sphere whose seam repeats vertices.
        let mut mesh = cuboid(Vec3::ZERO, Vec3::ONE);
        mesh.append(&cuboid(Vec3::new(1.0, 0.0, 0.0), Vec3::new(2.0, 1.0, 1.0)));
        mesh.append(&cuboid(Vec3::new(0.5, 1.0, 0.0), Vec3::new(1.5, 2.0, 1.0)));
        mesh.append(&uv_sphere(Vec3::new(5.0, 0.0, 0.0), 1.0, 8, 12));
        let c = connected_components(&mesh, Threads::Parallel);
        let sizes: Vec<usize> = c.iter().map(Vec::len).collect();
        let sphere = mesh.triangles().len() - 36;
        assert_eq!(sizes, [24, 12, sphere]);
        // Every triangle once, ascending within its component.
        let mut all: Vec<u32> = c.concat();
        all.sort_unstable();
        assert_eq!(all, (0..mesh.triangles().len() as u32).collect::<Vec<_>>());
        assert!(c.iter().all(|t| t.windows(2).all(|w| w[0] < w[1])));
        // A component's own mesh keeps only its vertices.
        let own = mesh.subset(&c[1]);
        assert_eq!((own.positions().len(), own.triangles().len()), (8, 12));
    }

    #[test]
    fn solids_that_only_overlap_are_separate() {
        let mut mesh = cuboid(Vec3::ZERO, Vec3::ONE);
        mesh.append(&cuboid(Vec3::splat(0.5), Vec3::splat(1.5)));
        assert_eq!(connected_components(&mesh, Threads::Parallel).len(), 2);
    }

    /// Many threads joining at once find the sets one thread finds: random
    /// triangles within groups of vertices, far more than one chunk, the
    /// groups' triangles interleaved, against a plain union-find.
    #[test]
    fn threads_find_the_components_one_thread_finds() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |n: u32| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % u64::from(n)) as u32
        };
        let (groups, per_group) = (300u32, 400u32);
        let positions: Vec<[f32; 3]> = (0..groups * per_group)
            .map(|v| [v as f32, (v % 7) as f32, (v % 13) as f32 * 0.5])
            .collect();
        let triangles: Vec<[u32; 3]> = (0..120_000)
            .map(|_| {
                let base = next(groups) * per_group;
                [0; 3].map(|_| base + next(per_group))
            })
            .collect();
        let mesh = TriMesh::new(positions, triangles).unwrap();
        // Each vertex at its own position: vertex indices are the ids.
        let mut parent: Vec<u32> = (0..groups * per_group).collect();
        fn find(parent: &mut [u32], mut v: u32) -> u32 {
            while parent[v as usize] != v {
                v = parent[v as usize];
            }
            v
        }
        for t in mesh.triangles() {
            for &other in &t[1..] {
                let (a, b) = (find(&mut parent, t[0]), find(&mut parent, other));
                parent[a.max(b) as usize] = a.min(b);
            }
        }
        let mut expected: Vec<Vec<u32>> = Vec::new();
        let mut slot = std::collections::HashMap::new();
        for (i, t) in mesh.triangles().iter().enumerate() {
            let r = find(&mut parent, t[0]);
            let k = *slot.entry(r).or_insert_with(|| {
                expected.push(Vec::new());
                expected.len() - 1
            });
            expected[k].push(i as u32);
        }
        assert!(expected.len() > groups as usize, "{}", expected.len());
        assert_eq!(connected_components(&mesh, Threads::Serial), expected);
        for _ in 0..3 {
            assert_eq!(connected_components(&mesh, Threads::Parallel), expected);
        }
    }
}
