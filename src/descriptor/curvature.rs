//! Gaussian curvature onion descriptor (paper, sec. 4.3).
//!
//! At a mesh vertex v and radius r, the curvature tensor of the surface in
//! the ball B(v, r) is (Cohen-Steiner and Morvan's normal cycle estimate)
//!
//!   T = 1/|B| * sum over edges e of beta(e) |e ∩ B| e e^T
//!
//! with beta(e) the signed dihedral angle, |e ∩ B| the exact length of the
//! edge inside the ball, e the unit edge direction and |B| the exact area of
//! the surface inside the ball. Only the part of the surface connected to v
//! inside the ball counts: a nearby but separate sheet (the other side of a
//! thin part, a neighbouring object) is not this point's neighbourhood.
//! The layer's value is the Gaussian curvature: the product of the two
//! eigenvalues of T of largest magnitude (the third belongs to the normal
//! and is near zero). A product of two angles, it does not depend on which
//! side the winding calls outside.
//!
//! Layers are incremental: the connected neighbourhood gathered for r_i is
//! grown for r_{i+1}, never gathered again, and triangles wholly inside a
//! ball are summed once (they stay inside the larger ones); only those cut
//! by the sphere are clipped again. Values are compared after
//! scaling by r_k^2, which makes them independent of the scene's units.

use super::OnionDescriptor;
use crate::math::{Vec3, symmetric_eigen};
use crate::mesh::surface::Surface;
use crate::mesh::{
    FxHashSet, closest_point_on_triangle, segment_length_in_ball, triangle_area_in_ball,
};

/// The curvature descriptor of a scene's surface against a template's.
pub struct CurvatureDescriptor<'a> {
    surface: &'a Surface,
    radii: Vec<f64>,
    /// The template's layers, scaled.
    template: Vec<f64>,
    /// r_k^2: the scale of every value.
    scale: f64,
    threshold: f64,
}

/// The neighbourhood of one vertex, grown layer by layer.
pub struct CurvatureState {
    /// The surface normal at the vertex: every layer's tensor is read in
    /// its tangent plane.
    normal: Vec3,
    /// Region triangles wholly inside the last ball: their sums are final.
    interior: Sums,
    /// Region triangles cut by the last ball: summed again each layer.
    cut: Vec<u32>,
    /// Triangles tested so far (in the region or waiting).
    seen: FxHashSet<u32>,
    /// Tested triangles next to the region that missed the last ball.
    waiting: Vec<u32>,
    distance: f64,
}

/// Area and edge tensor of a set of triangles inside a ball.
#[derive(Clone, Copy, Default)]
struct Sums {
    area: f64,
    tensor: [[f64; 3]; 3],
}

impl<'a> CurvatureDescriptor<'a> {
    /// Compares `surface` against the template layers `template` (unscaled
    /// Gaussian curvatures at `radii`); rejects past `threshold`.
    pub fn new(
        surface: &'a Surface,
        radii: &[f64],
        template: &[f64],
        threshold: f64,
    ) -> CurvatureDescriptor<'a> {
        let outer = radii.last().copied().unwrap_or(1.0);
        let scale = outer * outer;
        CurvatureDescriptor {
            surface,
            radii: radii.to_vec(),
            template: template.iter().map(|g| g * scale).collect(),
            scale,
            threshold,
        }
    }

    /// The Gaussian curvature of `surface` at vertex `v` for every radius:
    /// the template's descriptor, computed the same way as the scene's.
    pub fn describe(surface: &Surface, v: u32, radii: &[f64]) -> Vec<f64> {
        let mut state = CurvatureState::at(surface, v);
        radii
            .iter()
            .map(|&r| gaussian_curvature(surface, v, r, &mut state))
            .collect()
    }
}

impl CurvatureState {
    fn at(surface: &Surface, v: u32) -> CurvatureState {
        CurvatureState {
            normal: surface.vertex_normal(v),
            interior: Sums::default(),
            cut: Vec::new(),
            seen: FxHashSet::default(),
            waiting: Vec::new(),
            distance: 0.0,
        }
    }
}

impl OnionDescriptor for CurvatureDescriptor<'_> {
    type State = CurvatureState;

    fn name(&self) -> &'static str {
        "curvature"
    }

    fn layers(&self) -> usize {
        self.radii.len()
    }

    fn radius(&self, layer: usize) -> f64 {
        self.radii[layer]
    }

    fn threshold(&self) -> f64 {
        self.threshold
    }

    fn start(&self, point: u32) -> CurvatureState {
        CurvatureState::at(self.surface, point)
    }

    fn extend(&self, point: u32, layer: usize, state: &mut CurvatureState) -> f64 {
        let g = gaussian_curvature(self.surface, point, self.radii[layer], state) * self.scale;
        let d = g - self.template[layer];
        state.distance += d * d;
        state.distance
    }
}

/// Grows `state`'s region to the ball of radius `r` at vertex `v` and
/// returns the Gaussian curvature there (0 where the ball holds no area).
fn gaussian_curvature(surface: &Surface, v: u32, r: f64, state: &mut CurvatureState) -> f64 {
    let c = surface.position(v);
    let normal = state.normal;
    let fresh = grow(surface, c, v, r, state);
    // Triangles cut by the last ball and new ones: those now wholly inside
    // join the final sums, the rest are counted for this ball only.
    let mut cut = std::mem::take(&mut state.cut);
    cut.extend(fresh);
    let mut sums = state.interior;
    for t in cut {
        let corners = surface.corners(t);
        let whole = corners.iter().all(|p| p.dist(c) <= r);
        if whole {
            add_triangle(surface, t, c, r, normal, &mut state.interior);
        } else {
            state.cut.push(t);
        }
        add_triangle(surface, t, c, r, normal, &mut sums);
    }
    if sums.area <= 0.0 {
        return 0.0;
    }
    let tensor = sums.tensor.map(|row| row.map(|x| x / sums.area));
    let (values, _) = symmetric_eigen(tensor);
    // Drop the eigenvalue of least magnitude (the normal's).
    let smallest = (0..3)
        .min_by(|&i, &j| values[i].abs().total_cmp(&values[j].abs()))
        .expect("three eigenvalues");
    (0..3)
        .filter(|&i| i != smallest)
        .map(|i| values[i])
        .product()
}

/// Adds triangle `t`'s area inside the ball and half of each of its edges'
/// tensors: both triangles of a manifold edge meeting the ball are in the
/// region (they share the part inside it), so each edge is counted whole.
fn add_triangle(surface: &Surface, t: u32, c: Vec3, r: f64, normal: Vec3, sums: &mut Sums) {
    sums.area += triangle_area_in_ball(surface.corners(t), c, r);
    for e in surface.triangle_edges(t) {
        let edge = surface.edge(e);
        if edge.angle == 0.0 {
            continue;
        }
        let (a, b) = (
            surface.position(edge.ends[0]),
            surface.position(edge.ends[1]),
        );
        let inside = segment_length_in_ball(a, b, c, r);
        if inside == 0.0 {
            continue;
        }
        let Some(dir) = transport((b - a) * (1.0 / (b - a).norm()), edge.normal, normal) else {
            continue;
        };
        let w = 0.5 * edge.angle * inside;
        let d = [dir.x, dir.y, dir.z];
        for i in 0..3 {
            for j in 0..3 {
                sums.tensor[i][j] += w * d[i] * d[j];
            }
        }
    }
}

/// Turns `dir`, tangent where the surface has normal `from`, by the rotation
/// taking `from` to `to`: the edge as seen from the centre's tangent plane.
/// Without it, on a curved patch the edges tilt out of that plane, the
/// normal direction takes a share of the tensor, and the two tangential
/// eigenvalues shrink with the radius (16% at r = 0.6 R on a sphere of
/// radius R). None where the surface has turned by 180 degrees or more.
fn transport(dir: Vec3, from: Vec3, to: Vec3) -> Option<Vec3> {
    let c = from.dot(to);
    if from == Vec3::ZERO || to == Vec3::ZERO {
        return Some(dir);
    }
    if c <= -1.0 + 1e-9 {
        return None;
    }
    // Rodrigues with k sin = from x to, cos = c: R x = c x + k x x + (k.x) k / (1 + c).
    let k = from.cross(to);
    Some(dir * c + k.cross(dir) + k * (k.dot(dir) / (1.0 + c)))
}

/// Adds to the region every triangle connected to `v` through triangles that
/// meet the ball of radius `r` at `c`; returns the ones added.
fn grow(surface: &Surface, c: Vec3, v: u32, r: f64, state: &mut CurvatureState) -> Vec<u32> {
    let meets = |t: u32| {
        let [a, b, d] = surface.corners(t);
        closest_point_on_triangle(c, a, b, d, t as usize).distance2 <= r * r
    };
    let mut queue: Vec<u32> = Vec::new();
    if state.seen.is_empty() {
        for &t in surface.triangles_at(v) {
            state.seen.insert(t);
            queue.push(t);
        }
    }
    // Those that missed the smaller ball may meet this one.
    queue.append(&mut state.waiting);
    let mut added = Vec::new();
    while let Some(t) = queue.pop() {
        if !meets(t) {
            state.waiting.push(t);
            continue;
        }
        added.push(t);
        for n in surface.neighbours(t) {
            if state.seen.insert(n) {
                queue.push(n);
            }
        }
    }
    added
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::mesh::TriMesh;
    use crate::mesh::shapes::uv_sphere;

    fn nearest_vertex(s: &Surface, p: Vec3) -> u32 {
        (0..s.vertex_count() as u32)
            .min_by(|&a, &b| s.position(a).dist(p).total_cmp(&s.position(b).dist(p)))
            .unwrap()
    }

    /// A square grid of `n` x `n` cells over [-1, 1]^2, lifted by `height`.
    fn height_field(n: usize, height: impl Fn(f64, f64) -> f64) -> TriMesh {
        let mut p = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (
                    2.0 * i as f64 / n as f64 - 1.0,
                    2.0 * j as f64 / n as f64 - 1.0,
                );
                p.push([x as f32, y as f32, height(x, y) as f32]);
            }
        }
        let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let mut t = Vec::new();
        for j in 0..n {
            for i in 0..n {
                t.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                t.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        TriMesh::new(p, t).unwrap()
    }

    #[test]
    fn a_sphere_has_curvature_one_over_r_squared_at_every_radius() {
        let radius = 2.0;
        let s = Surface::new(&uv_sphere(Vec3::ZERO, radius, 96, 192));
        // Away from the poles, where the tessellation is most regular.
        let v = nearest_vertex(&s, Vec3::new(radius, 0.0, 0.0));
        let radii = [0.3, 0.6, 0.9, 1.2];
        for g in CurvatureDescriptor::describe(&s, v, &radii) {
            let want = 1.0 / (radius * radius);
            assert!((g - want).abs() < 0.03 * want, "{g} vs {want}");
        }
    }

    #[test]
    fn a_plane_has_none() {
        let s = Surface::new(&height_field(40, |_, _| 0.0));
        let v = nearest_vertex(&s, Vec3::ZERO);
        for g in CurvatureDescriptor::describe(&s, v, &[0.2, 0.4, 0.6]) {
            assert!(g.abs() < 1e-9, "{g}");
        }
    }

    #[test]
    fn a_cylinder_has_about_none() {
        // z = sqrt(R^2 - x^2): curved across x only.
        let s = Surface::new(&height_field(80, |x, _| (4.0 - x * x).sqrt()));
        let v = nearest_vertex(&s, Vec3::new(0.0, 0.0, 2.0));
        for g in CurvatureDescriptor::describe(&s, v, &[0.2, 0.4, 0.6]) {
            // Next to the sphere's 1 / R^2 = 0.25.
            assert!(g.abs() < 0.01, "{g}");
        }
    }

    #[test]
    fn a_saddle_is_negative() {
        // z = (x^2 - y^2) / 2: K = -1 at the origin.
        let s = Surface::new(&height_field(80, |x, y| 0.5 * (x * x - y * y)));
        let v = nearest_vertex(&s, Vec3::ZERO);
        let g = CurvatureDescriptor::describe(&s, v, &[0.2]);
        assert!(g[0] < -0.7 && g[0] > -1.3, "{g:?}");
    }

    #[test]
    fn rotation_and_reindexing_change_nothing() {
        let m = uv_sphere(Vec3::ZERO, 1.0, 24, 48);
        // Squash it so the curvature varies, then rotate and reverse the
        // triangle order.
        let squashed = m
            .map_positions(|p| Vec3::new(p.x, 0.7 * p.y, 0.5 * p.z + 0.2 * p.x * p.x))
            .unwrap();
        let (s, c) = (0.6f64.sin(), 0.6f64.cos());
        let turned = squashed
            .map_positions(|p| Vec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z))
            .unwrap();
        let reordered = TriMesh::new(
            turned.positions().to_vec(),
            turned.triangles().iter().rev().copied().collect(),
        )
        .unwrap();
        let (a, b) = (Surface::new(&squashed), Surface::new(&reordered));
        let radii = [0.15, 0.3, 0.45];
        for v in [0u32, 100, 300, 700] {
            let p = a.position(v);
            let q = Vec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z);
            let w = nearest_vertex(&b, q);
            let ga = CurvatureDescriptor::describe(&a, v, &radii);
            let gb = CurvatureDescriptor::describe(&b, w, &radii);
            for (x, y) in ga.iter().zip(&gb) {
                assert!((x - y).abs() < 1e-4 * (1.0 + x.abs()), "{ga:?} vs {gb:?}");
            }
        }
    }

    #[test]
    fn retessellation_changes_little() {
        let want = 1.0;
        let coarse = Surface::new(&uv_sphere(Vec3::ZERO, 1.0, 48, 96));
        let fine = Surface::new(&uv_sphere(Vec3::ZERO, 1.0, 96, 160));
        let radii = [0.3, 0.5];
        for s in [&coarse, &fine] {
            let v = nearest_vertex(s, Vec3::new(0.0, 1.0, 0.0));
            for g in CurvatureDescriptor::describe(s, v, &radii) {
                assert!((g - want).abs() < 0.05, "{g}");
            }
        }
    }

    #[test]
    fn layers_grow_the_same_neighbourhood_as_a_fresh_gather() {
        let s = Surface::new(&uv_sphere(Vec3::ZERO, 1.0, 32, 64));
        let v = nearest_vertex(&s, Vec3::new(1.0, 0.0, 0.0));
        let radii = [0.2, 0.4, 0.8];
        let incremental = CurvatureDescriptor::describe(&s, v, &radii);
        for (i, &r) in radii.iter().enumerate() {
            let fresh = CurvatureDescriptor::describe(&s, v, &[r]);
            assert!((fresh[0] - incremental[i]).abs() < 1e-12);
        }
    }

    #[test]
    fn a_separate_sheet_inside_the_ball_is_ignored() {
        let plane = height_field(40, |_, _| 0.0);
        let mut both = plane.clone();
        both.append(&uv_sphere(Vec3::new(0.0, 0.0, 0.35), 0.2, 16, 32));
        let (a, b) = (Surface::new(&plane), Surface::new(&both));
        let v = nearest_vertex(&a, Vec3::ZERO);
        assert_eq!(
            CurvatureDescriptor::describe(&a, v, &[0.6]),
            CurvatureDescriptor::describe(&b, v, &[0.6])
        );
    }

    #[test]
    fn the_cascade_distance_grows_layer_by_layer() {
        let s = Surface::new(&uv_sphere(Vec3::ZERO, 1.0, 32, 64));
        let radii = [0.2, 0.4];
        let d = CurvatureDescriptor::new(&s, &radii, &[0.0, 0.0], 10.0);
        let v = nearest_vertex(&s, Vec3::new(1.0, 0.0, 0.0));
        let mut state = d.start(v);
        let first = d.extend(v, 0, &mut state);
        let second = d.extend(v, 1, &mut state);
        // Each layer adds (r_k^2 * (1 - 0))^2 = 0.0256.
        assert!((first - 0.0256).abs() < 0.003, "{first}");
        assert!((second - 2.0 * 0.0256).abs() < 0.006, "{second}");
    }
}
