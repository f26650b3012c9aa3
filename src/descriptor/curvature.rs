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
use crate::mesh::surface::{CurvedEdge, Surface};
use crate::mesh::{clip_triangle_to_ball, closest_point_on_triangle, segment_in_ball};

/// The curvature descriptor of a scene's surface against a template's.
pub struct CurvatureDescriptor<'a> {
    name: &'static str,
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
    /// Patches of the region taken whole (their sums are in `interior`).
    patches: Vec<u32>,
    /// The other region triangles so far, counted one by one (the walk
    /// must not enter them again).
    region: Vec<u32>,
    /// Region triangles cut by the last ball: summed again each layer.
    cut: Vec<u32>,
    /// Tested triangles next to the region that missed the last ball.
    waiting: Vec<u32>,
    /// Whether the walk has started from the vertex's own triangles.
    started: bool,
    distance: f64,
}

/// Area and edge tensor of a set of triangles inside a ball.
#[derive(Clone, Copy, Default)]
struct Sums {
    area: f64,
    /// The symmetric edge tensor's upper triangle, row by row: xx, xy, xz,
    /// yy, yz, zz.
    tensor: [f64; 6],
    /// Area-weighted sum of positions (cut triangles at their centroid).
    moment: Vec3,
}

/// One layer of the neighbourhood of a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layer {
    /// Gaussian curvature (unscaled).
    pub gaussian: f64,
    /// Centre of the area of the neighbourhood, relative to the vertex:
    /// which way the surface around it extends (see [`handedness`]).
    pub centroid: Vec3,
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
            name: "curvature",
            surface,
            radii: radii.to_vec(),
            template: template.iter().map(|g| g * scale).collect(),
            scale,
            threshold,
        }
    }

    /// The same descriptor reported under another stage name (a pass over
    /// a sample of the vertices, say).
    pub fn named(self, name: &'static str) -> CurvatureDescriptor<'a> {
        CurvatureDescriptor { name, ..self }
    }

    /// The Gaussian curvature of `surface` at vertex `v` for every radius:
    /// the template's descriptor, computed the same way as the scene's.
    pub fn describe(surface: &Surface, v: u32, radii: &[f64]) -> Vec<f64> {
        Self::layers_at(surface, v, radii)
            .iter()
            .map(|l| l.gaussian)
            .collect()
    }

    /// Every layer at vertex `v`, with the centroids.
    pub fn layers_at(surface: &Surface, v: u32, radii: &[f64]) -> Vec<Layer> {
        let mut state = CurvatureState::at(surface, v);
        radii
            .iter()
            .map(|&r| grow_layer(surface, v, r, &mut state))
            .collect()
    }
}

impl CurvatureState {
    fn at(surface: &Surface, v: u32) -> CurvatureState {
        CurvatureState {
            normal: surface.vertex_normal(v),
            interior: Sums::default(),
            patches: Vec::new(),
            region: Vec::new(),
            cut: Vec::new(),
            waiting: Vec::new(),
            started: false,
            distance: 0.0,
        }
    }
}

impl OnionDescriptor for CurvatureDescriptor<'_> {
    type State = CurvatureState;

    fn name(&self) -> &'static str {
        self.name
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
        let ball = gather(self.surface, point, self.radii[layer], state);
        let (sums, cut_area) = add_cut_edges(self.surface, &ball, state);
        // Most points are rejected here, before the cut triangles' areas
        // are clipped.
        let (low, high) = gaussian_bounds(sums.tensor, sums.area, sums.area + cut_area);
        let t = self.template[layer];
        let gap = (low * self.scale - t).max(t - high * self.scale).max(0.0);
        let lower = state.distance + gap * gap;
        if lower > self.threshold * (1.0 + BOUND_MARGIN) {
            return lower;
        }
        let g = add_cut_areas(self.surface, &ball, state, sums).gaussian * self.scale;
        let d = g - self.template[layer];
        state.distance += d * d;
        state.distance
    }
}

/// Per-thread scratch for the neighbourhood walk: a mark per triangle
/// (equal to `current` when seen in this walk), per patch whether it was
/// taken whole or cannot be (some of its triangles are counted one by one,
/// or it does not fit in the ball), and the walk's queue. Marks are
/// generations, so a walk never clears the arrays.
#[derive(Default)]
struct Walk {
    marks: Vec<u32>,
    taken: Vec<u32>,
    mixed: Vec<u32>,
    current: u32,
    queue: Vec<u32>,
}

impl Walk {
    /// Starts a walk over `surface`.
    fn begin(&mut self, surface: &Surface) {
        let (triangles, patches) = (surface.triangles().len(), surface.patch_count());
        if self.marks.len() < triangles {
            self.marks.resize(triangles, 0);
        }
        if self.taken.len() < patches {
            self.taken.resize(patches, 0);
            self.mixed.resize(patches, 0);
        }
        if self.current == u32::MAX {
            self.marks.fill(0);
            self.taken.fill(0);
            self.mixed.fill(0);
            self.current = 0;
        }
        self.current += 1;
        self.queue.clear();
    }

    /// Marks `t`; false if it was already marked in this walk.
    fn mark(&mut self, t: u32) -> bool {
        let m = &mut self.marks[t as usize];
        let fresh = *m != self.current;
        *m = self.current;
        fresh
    }
}

thread_local! {
    static WALK: std::cell::RefCell<Walk> = std::cell::RefCell::new(Walk::default());
}

/// Grows `state`'s region to the ball of radius `r` at vertex `v` and
/// returns the layer there (Gaussian curvature 0 where the ball holds no
/// area).
fn grow_layer(surface: &Surface, v: u32, r: f64, state: &mut CurvatureState) -> Layer {
    let ball = gather(surface, v, r, state);
    let (sums, _) = add_cut_edges(surface, &ball, state);
    add_cut_areas(surface, &ball, state, sums)
}

/// Grows `state`'s region to the ball of radius `r` at vertex `v`: the
/// triangles wholly inside are summed, those cut by the sphere are listed
/// in `state.cut`.
fn gather(surface: &Surface, v: u32, r: f64, state: &mut CurvatureState) -> Ball {
    let c = surface.position(v);
    let r2 = r * r;
    let ball = Ball {
        centre: c,
        radius: r,
        normal: state.normal,
    };
    let previous_cut = std::mem::take(&mut state.cut);
    WALK.with_borrow_mut(|walk| {
        walk.begin(surface);
        for &p in &state.patches {
            walk.taken[p as usize] = walk.current;
            for t in surface.patch_triangles(p) {
                walk.mark(t);
            }
        }
        for &t in &state.region {
            walk.mark(t);
            walk.mixed[surface.patch_of(t) as usize] = walk.current;
        }
        for &t in &state.waiting {
            walk.mark(t);
        }
        let mut queue = std::mem::take(&mut walk.queue);
        // Those that missed the smaller ball may meet this one.
        queue.append(&mut state.waiting);
        if !state.started {
            state.started = true;
            for &t in surface.triangles_at(v) {
                if walk.mark(t) {
                    queue.push(t);
                }
            }
        }
        while let Some(t) = queue.pop() {
            let patch = surface.patch_of(t) as usize;
            if walk.taken[patch] == walk.current {
                continue;
            }
            if walk.mixed[patch] != walk.current && ball.holds_patch(surface, patch as u32) {
                // Wholly inside and connected: all of it is in the region.
                walk.taken[patch] = walk.current;
                state.patches.push(patch as u32);
                ball.add_patch(surface, patch as u32, &mut state.interior);
                for u in surface.patch_triangles(patch as u32) {
                    walk.mark(u);
                }
                for &n in surface.patch_border(patch as u32) {
                    if walk.mark(n) {
                        queue.push(n);
                    }
                }
                continue;
            }
            // Not wholly inside this ball: its other triangles need not
            // test it again.
            walk.mixed[patch] = walk.current;
            let p = surface.corners(t);
            let inside = p.map(|q| (q - c).norm2() <= r2);
            let meets = inside.iter().any(|&x| x)
                || closest_point_on_triangle(c, p[0], p[1], p[2], t as usize).distance2 <= r2;
            if !meets {
                state.waiting.push(t);
                continue;
            }
            state.region.push(t);
            if inside.iter().all(|&x| x) {
                ball.add_whole(surface, t, &mut state.interior);
            } else {
                state.cut.push(t);
            }
            for &n in surface.neighbours(t) {
                if walk.mark(n) {
                    queue.push(n);
                }
            }
        }
        walk.queue = queue;
    });
    // Triangles cut by the smaller ball may now lie wholly inside.
    for t in previous_cut {
        if surface.corners(t).iter().all(|q| (*q - c).norm2() <= r2) {
            ball.add_whole(surface, t, &mut state.interior);
        } else {
            state.cut.push(t);
        }
    }
    ball
}

/// The interior's sums of the region `gather` left in `state`, with the
/// cut triangles' edges clipped and added (one quadratic per edge), and
/// the cut triangles' whole area: the tensor is final, and the area lies
/// between the sums' and that much more.
fn add_cut_edges(surface: &Surface, ball: &Ball, state: &CurvatureState) -> (Sums, f64) {
    let mut sums = state.interior;
    let mut cut_area = 0.0;
    let r2 = ball.radius * ball.radius;
    for &t in &state.cut {
        cut_area += surface.area(t);
        let p = surface.corners(t).map(|q| q - ball.centre);
        let edges = surface.curved_edges(t).iter().map(|e| {
            let side = e.side as usize;
            (e, segment_in_ball(p[side], p[(side + 1) % 3], r2))
        });
        sums.add_tensor(ball.edge_tensor(edges.filter(|&(_, length)| length > 0.0)));
    }
    (sums, cut_area)
}

/// The layer: `sums` from [`add_cut_edges`] with the cut triangles'
/// clipped areas added (Gaussian curvature 0 where the ball holds no
/// area).
fn add_cut_areas(surface: &Surface, ball: &Ball, state: &CurvatureState, mut sums: Sums) -> Layer {
    for &t in &state.cut {
        let p = surface.corners(t);
        let area = clip_triangle_to_ball(p, ball.centre, ball.radius).area;
        sums.area += area;
        sums.moment += centroid(p) * area;
    }
    if sums.area <= 0.0 {
        return Layer {
            gaussian: 0.0,
            centroid: Vec3::ZERO,
        };
    }
    let tensor = full_tensor(sums.tensor).map(|row| row.map(|x| x / sums.area));
    let (values, _) = symmetric_eigen(tensor);
    Layer {
        gaussian: gaussian(values),
        centroid: sums.moment * (1.0 / sums.area) - ball.centre,
    }
}

/// The Gaussian curvature from the tensor's eigenvalues: the product of
/// the two of largest magnitude (the third belongs to the normal).
fn gaussian(values: [f64; 3]) -> f64 {
    let smallest = (0..3)
        .min_by(|&i, &j| values[i].abs().total_cmp(&values[j].abs()))
        .expect("three eigenvalues");
    (0..3)
        .filter(|&i| i != smallest)
        .map(|i| values[i])
        .product()
}

/// How far past the threshold a bound must lie to reject: the bound and
/// the exact value round differently, and a point must never be dropped
/// that the exact value would keep.
const BOUND_MARGIN: f64 = 1e-6;

/// An interval that holds the Gaussian curvature of a layer whose tensor
/// is `tensor` (final) and whose area lies in `low_area..=high_area`.
/// Clipping the cut triangles' areas is the costly part of a layer, and
/// most points lie far enough from the template for this interval to
/// reject them without it. Unbounded where the area may be zero.
fn gaussian_bounds(tensor: [f64; 6], low_area: f64, high_area: f64) -> (f64, f64) {
    if low_area <= 0.0 {
        return (f64::NEG_INFINITY, f64::INFINITY);
    }
    let (values, _) = symmetric_eigen(full_tensor(tensor));
    // The exact value solves the tensor divided by the area, which rounds
    // differently: widen each eigenvalue by a little of the scale.
    let slack = 1e-9 * values.iter().map(|x| x.abs()).fold(0.0, f64::max);
    let ranges = values.map(|x| (x - slack, x + slack));
    let least_magnitude = |(a, b): (f64, f64)| {
        if a <= 0.0 && b >= 0.0 {
            0.0
        } else {
            a.abs().min(b.abs())
        }
    };
    let most_magnitude = |(a, b): (f64, f64)| a.abs().max(b.abs());
    // `gaussian` drops the eigenvalue of least magnitude: any of the three
    // may be the one dropped only if it can be no larger than both others.
    let mut product = (f64::INFINITY, f64::NEG_INFINITY);
    for (k, i, j) in [(0, 1, 2), (1, 0, 2), (2, 0, 1)] {
        let others = most_magnitude(ranges[i]).min(most_magnitude(ranges[j]));
        if least_magnitude(ranges[k]) > others {
            continue;
        }
        let (a, b) = (ranges[i], ranges[j]);
        for x in [a.0 * b.0, a.0 * b.1, a.1 * b.0, a.1 * b.1] {
            product = (product.0.min(x), product.1.max(x));
        }
    }
    // Divided by the area squared, at whichever end of its range moves
    // each end of the product outward.
    let divide = |x: f64, outward_low: bool| {
        let larger_area = (x >= 0.0) == outward_low;
        x / if larger_area {
            high_area * high_area
        } else {
            low_area * low_area
        }
    };
    (divide(product.0, true), divide(product.1, false))
}

/// Which way the neighbourhood of a vertex turns from an inner layer to an
/// outer one, seen along the vertex normal: the sine of the angle between
/// the two centroids' tangential parts (positive counter-clockwise). A
/// mirror image flips its sign, a rotation or a bending does not; the
/// Gaussian curvature cannot tell a point from its mirror twin (the other
/// flank of a symmetric shape), this can. Zero where a centroid has no
/// tangential part.
pub fn handedness(normal: Vec3, inner: Vec3, outer: Vec3) -> f64 {
    let flat = |m: Vec3| m - normal * normal.dot(m);
    let (a, b) = (flat(inner), flat(outer));
    let scale = a.norm() * b.norm();
    if scale > 0.0 {
        normal.dot(a.cross(b)) / scale
    } else {
        0.0
    }
}

fn centroid(p: [Vec3; 3]) -> Vec3 {
    (p[0] + p[1] + p[2]) * (1.0 / 3.0)
}

/// The ball of one layer, with the normal of the vertex at its centre.
struct Ball {
    centre: Vec3,
    radius: f64,
    normal: Vec3,
}

impl Ball {
    /// Whether patch `p` lies wholly inside the ball.
    fn holds_patch(&self, surface: &Surface, p: u32) -> bool {
        // |centre - c| + radius <= r, without a square root in the walk's
        // hottest test.
        let (centre, radius) = surface.patch_bounds(p);
        let room = self.radius - radius;
        room >= 0.0 && (centre - self.centre).norm2() <= room * room
    }

    /// Adds patch `p`, wholly inside, with its curved edges.
    fn add_patch(&self, surface: &Surface, p: u32, sums: &mut Sums) {
        let (area, moment) = surface.patch_area(p);
        sums.area += area;
        sums.moment += moment;
        let edges = surface.patch_curved_edges(p);
        sums.add_tensor(self.edge_tensor(edges.iter().map(|e| (e, e.length))));
    }

    /// Adds triangle `t`, wholly inside, with its curved edges.
    fn add_whole(&self, surface: &Surface, t: u32, sums: &mut Sums) {
        let area = surface.area(t);
        sums.area += area;
        sums.moment += centroid(surface.corners(t)) * area;
        let edges = surface.curved_edges(t);
        sums.add_tensor(self.edge_tensor(edges.iter().map(|e| (e, e.length))));
    }

    /// The sum of `angle * length * d d^T` over `edges` (each with the
    /// length of it that counts), upper triangle row by row, with each edge
    /// direction d turned by the rotation that takes the edge's normal to
    /// the centre's. Without it, on a curved patch the edges tilt out of the
    /// centre's tangent plane, the normal direction takes a share of the
    /// tensor, and the two tangential eigenvalues shrink with the radius
    /// (16% at r = 0.6 R on a sphere of radius R). Skipped where the surface
    /// has turned by 180 degrees or more.
    fn edge_tensor<'e>(&self, edges: impl Iterator<Item = (&'e CurvedEdge, f64)>) -> [f64; 6] {
        let u = self.normal;
        let mut sum = [0.0; 6];
        for (e, length) in edges {
            let (n, d) = (e.normal, e.direction);
            let cos = n.dot(u);
            if cos <= -1.0 + 1e-9 {
                continue;
            }
            // The minimal rotation taking n to u, applied to d (d is normal
            // to n): R d = d - ((u . d) / (1 + n . u)) (n + u).
            let d = d - (n + u) * (u.dot(d) / (1.0 + cos));
            let w = e.angle * length;
            let wd = d * w;
            sum[0] += wd.x * d.x;
            sum[1] += wd.x * d.y;
            sum[2] += wd.x * d.z;
            sum[3] += wd.y * d.y;
            sum[4] += wd.y * d.z;
            sum[5] += wd.z * d.z;
        }
        sum
    }
}

impl Sums {
    /// Adds an edge tensor given as its upper triangle, row by row.
    fn add_tensor(&mut self, upper: [f64; 6]) {
        for (sum, x) in self.tensor.iter_mut().zip(upper) {
            *sum += x;
        }
    }
}

/// The symmetric matrix whose upper triangle, row by row, is `upper`.
fn full_tensor(upper: [f64; 6]) -> [[f64; 3]; 3] {
    let t = upper;
    [[t[0], t[1], t[2]], [t[1], t[3], t[4]], [t[2], t[4], t[5]]]
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

    /// A surface with curvature of both signs and many sizes.
    fn bumpy() -> Surface {
        Surface::new(&height_field(60, |x, y| {
            0.3 * (3.0 * x).sin() * (2.0 * y).cos() + 0.2 * x * y
        }))
    }

    #[test]
    fn the_bounds_hold_the_exact_curvature() {
        let s = bumpy();
        let radii = [0.1, 0.25, 0.4, 0.6];
        let (mut checked, mut narrow) = (0, 0);
        for v in (0..s.vertex_count() as u32).step_by(7) {
            let mut state = CurvatureState::at(&s, v);
            for &r in &radii {
                let ball = gather(&s, v, r, &mut state);
                let (sums, cut_area) = add_cut_edges(&s, &ball, &state);
                let (low, high) = gaussian_bounds(sums.tensor, sums.area, sums.area + cut_area);
                let clipped: f64 = state
                    .cut
                    .iter()
                    .map(|&t| clip_triangle_to_ball(s.corners(t), ball.centre, r).area)
                    .sum();
                let g = add_cut_areas(&s, &ball, &state, sums).gaussian;
                assert!(
                    low <= g && g <= high,
                    "vertex {v} r {r}: {g} not in {low}..{high}"
                );
                // With the area known the interval closes on the value.
                let area = sums.area + clipped;
                let (at_low, at_high) = gaussian_bounds(sums.tensor, area, area);
                assert!(at_low <= g && g <= at_high, "vertex {v} r {r}");
                assert!(
                    at_high - at_low <= 1e-6 * (1.0 + g.abs()),
                    "vertex {v} r {r}"
                );
                checked += 1;
                narrow += usize::from(high - low < 0.5 * (1.0 + g.abs()));
            }
        }
        // Useful as well as safe: most intervals are narrow.
        assert!(narrow * 2 > checked, "{narrow} of {checked} narrow");
    }

    #[test]
    fn rejecting_by_the_bounds_keeps_what_the_exact_values_keep() {
        let s = bumpy();
        let radii = [0.1, 0.2, 0.3];
        let scale = radii[2] * radii[2];
        let template = CurvatureDescriptor::describe(&s, 1830, &radii);
        let threshold = 0.02;
        let d = CurvatureDescriptor::new(&s, &radii, &template, threshold);
        let (mut kept, mut by_bound) = (0, 0);
        for v in 0..s.vertex_count() as u32 {
            let exact = CurvatureDescriptor::describe(&s, v, &radii);
            let mut state = d.start(v);
            let mut running = 0.0;
            for layer in 0..radii.len() {
                let step = exact[layer] * scale - template[layer] * scale;
                running += step * step;
                let got = d.extend(v, layer, &mut state);
                if running <= threshold {
                    assert_eq!(got, running, "vertex {v} layer {layer}");
                    kept += usize::from(layer + 1 == radii.len());
                } else {
                    // Rejected either way; a bound never passes the exact value.
                    assert!(
                        got > threshold && got <= running * (1.0 + 1e-9),
                        "vertex {v}"
                    );
                    by_bound += usize::from(got != running);
                    break;
                }
            }
        }
        assert!(
            kept > 0 && by_bound > 0,
            "kept {kept}, rejected by the bound {by_bound}"
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

    #[test]
    fn a_mirror_image_keeps_the_curvature_and_flips_the_handedness() {
        // A lopsided blob: its centroids turn one way around the normal.
        let m = uv_sphere(Vec3::ZERO, 1.0, 32, 64)
            .map_positions(|p| {
                Vec3::new(
                    p.x + 0.3 * p.y * p.y,
                    0.8 * p.y + 0.2 * p.z * p.x,
                    0.6 * p.z + 0.25 * p.x * p.y,
                )
            })
            .unwrap();
        let mirror = |p: Vec3| Vec3::new(-p.x, p.y, p.z);
        let mirrored = m.map_positions(mirror).unwrap();
        let mirrored = TriMesh::new(
            mirrored.positions().to_vec(),
            mirrored
                .triangles()
                .iter()
                .map(|t| [t[0], t[2], t[1]])
                .collect(),
        )
        .unwrap();
        let (a, b) = (Surface::new(&m), Surface::new(&mirrored));
        let radii = [0.3, 0.6, 0.9];
        let mut clear = 0;
        for v in [10u32, 200, 500, 900, 1500] {
            let w = nearest_vertex(&b, mirror(a.position(v)));
            let (la, lb) = (
                CurvatureDescriptor::layers_at(&a, v, &radii),
                CurvatureDescriptor::layers_at(&b, w, &radii),
            );
            for (x, y) in la.iter().zip(&lb) {
                assert!((x.gaussian - y.gaussian).abs() < 1e-6 * (1.0 + x.gaussian.abs()));
            }
            let ha = handedness(a.vertex_normal(v), la[0].centroid, la[2].centroid);
            let hb = handedness(b.vertex_normal(w), lb[0].centroid, lb[2].centroid);
            assert!((ha + hb).abs() < 1e-6, "{ha} vs {hb}");
            if ha.abs() > 0.3 {
                clear += 1;
            }
        }
        assert!(clear >= 2, "the blob should turn clearly somewhere");
    }
}
