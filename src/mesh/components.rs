//! Connected components: the parts an assembly is made of.
//!
//! A real scene is many parts that touch, sit in bores or rest on each
//! other, and a part's descriptor must not see its neighbours. Files split
//! vertices along seams, so vertices at the same position are welded first;
//! what is then joined by shared vertices is one component.

use super::{TriMesh, weld_vertices_on};
use crate::exec::Backend;

/// The triangles of each connected component (joined through welded
/// vertices), in order of their first triangle; triangles ascending. The
/// weld uses `backend`'s threads.
pub fn connected_components(mesh: &TriMesh, backend: Backend) -> Vec<Vec<u32>> {
    let (ids, welded) = weld_vertices_on(mesh.positions(), backend);
    let mut parent: Vec<u32> = (0..welded as u32).collect();
    fn root(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            // Path halving keeps the trees flat.
            let up = parent[parent[v as usize] as usize];
            parent[v as usize] = up;
            v = up;
        }
        v
    }
    for t in mesh.triangles() {
        let [a, b, c] = t.map(|i| root(&mut parent, ids[i as usize]));
        let low = a.min(b).min(c);
        for r in [a, b, c] {
            parent[r as usize] = low;
        }
    }
    let mut component_of_root = vec![u32::MAX; welded];
    let mut components: Vec<Vec<u32>> = Vec::new();
    for (i, t) in mesh.triangles().iter().enumerate() {
        let r = root(&mut parent, ids[t[0] as usize]) as usize;
        if component_of_root[r] == u32::MAX {
            component_of_root[r] = components.len() as u32;
            components.push(Vec::new());
        }
        components[component_of_root[r] as usize].push(i as u32);
    }
    components
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
        let c = connected_components(&mesh, Backend::Parallel);
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
        assert_eq!(connected_components(&mesh, Backend::Parallel).len(), 2);
    }
}
