//! What every target checks on a mesh a loader accepted: the promises
//! `TriMesh` construction makes to the rest of the pipeline.

use fast_reject::mesh::TriMesh;

/// Panics if `mesh` breaks an invariant of a validated mesh.
pub fn check_mesh(mesh: &TriMesh) {
    let n = mesh.positions().len();
    assert!(
        !mesh.triangles().is_empty(),
        "a loaded mesh has no triangle"
    );
    for p in mesh.positions() {
        assert!(p.iter().all(|c| c.is_finite()), "non-finite vertex {p:?}");
    }
    for t in mesh.triangles() {
        assert!(
            t.iter().all(|&i| (i as usize) < n),
            "index out of range in {t:?} ({n} vertices)"
        );
    }
    let covered: u64 = mesh.parts().iter().map(|p| p.triangle_count as u64).sum();
    assert_eq!(
        covered,
        mesh.triangles().len() as u64,
        "parts do not cover the triangles"
    );
    let b = mesh.bounds();
    assert!(b.min.x <= b.max.x && b.min.y <= b.max.y && b.min.z <= b.max.z);
}
