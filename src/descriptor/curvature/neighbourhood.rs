//! The connected neighbourhood of a vertex, grown ball by ball: a walk
//! over the welded surface from the vertex's own triangles, whole patches
//! and triangles inside the ball summed once, those cut by the sphere
//! clipped again for each layer.

use super::Layer;
use super::ball_clip::{clip_triangle_to_ball, segment_in_ball};
use super::surface::{CurvedEdge, Surface};
use crate::math::{Vec3, symmetric_eigen};
use crate::mesh::closest_point_on_triangle;

/// The neighbourhood of one vertex, grown layer by layer.
pub struct CurvatureState {
    /// The surface normal at the vertex: every layer's tensor is read in
    /// its tangent plane.
    pub(super) normal: Vec3,
    /// Region triangles wholly inside the last ball: their sums are final.
    pub(super) interior: Sums,
    /// Patches of the region taken whole (their sums are in `interior`).
    pub(super) patches: Vec<u32>,
    /// The other region triangles so far, counted one by one (the walk
    /// must not enter them again).
    pub(super) region: Vec<u32>,
    /// Region triangles cut by the last ball: summed again each layer.
    pub(super) cut: Vec<u32>,
    /// Tested triangles next to the region that missed the last ball.
    pub(super) waiting: Vec<u32>,
    /// Whether the walk has started from the vertex's own triangles.
    pub(super) started: bool,
    pub(super) distance: f64,
}

/// Area and edge tensor of a set of triangles inside a ball.
#[derive(Clone, Copy, Default)]
pub(super) struct Sums {
    pub(super) area: f64,
    /// The symmetric edge tensor's upper triangle, row by row: xx, xy, xz,
    /// yy, yz, zz.
    pub(super) tensor: [f64; 6],
    /// Area-weighted sum of positions (cut triangles at their centroid).
    pub(super) moment: Vec3,
}

impl CurvatureState {
    pub(super) fn at(surface: &Surface, v: u32) -> CurvatureState {
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

/// Per-thread scratch for the neighbourhood walk: a mark per triangle
/// (equal to `current` when seen in this walk), per patch whether it was
/// taken whole or cannot be (some of its triangles are counted one by one,
/// or it does not fit in the ball), and the walk's queue. Marks are
/// generations, so a walk never clears the arrays.
#[derive(Default)]
pub(super) struct Walk {
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
pub(super) fn grow_layer(surface: &Surface, v: u32, r: f64, state: &mut CurvatureState) -> Layer {
    let ball = gather(surface, v, r, state);
    let (sums, _) = add_cut_edges(surface, &ball, state);
    add_cut_areas(surface, &ball, state, sums)
}

/// Grows `state`'s region to the ball of radius `r` at vertex `v`: the
/// triangles wholly inside are summed, those cut by the sphere are listed
/// in `state.cut`.
pub(super) fn gather(surface: &Surface, v: u32, r: f64, state: &mut CurvatureState) -> LayerBall {
    let c = surface.position(v);
    let r2 = r * r;
    let ball = LayerBall {
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
            let inside = p.map(|q| (q - c).length_squared() <= r2);
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
        if surface
            .corners(t)
            .iter()
            .all(|q| (*q - c).length_squared() <= r2)
        {
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
pub(super) fn add_cut_edges(
    surface: &Surface,
    ball: &LayerBall,
    state: &CurvatureState,
) -> (Sums, f64) {
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
pub(super) fn add_cut_areas(
    surface: &Surface,
    ball: &LayerBall,
    state: &CurvatureState,
    mut sums: Sums,
) -> Layer {
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
pub(super) fn gaussian(values: [f64; 3]) -> f64 {
    let smallest = (0..3)
        .min_by(|&i, &j| values[i].abs().total_cmp(&values[j].abs()))
        .expect("three eigenvalues");
    (0..3)
        .filter(|&i| i != smallest)
        .map(|i| values[i])
        .product()
}

pub(super) fn centroid(p: [Vec3; 3]) -> Vec3 {
    (p[0] + p[1] + p[2]) * (1.0 / 3.0)
}

/// The ball of one layer, with the normal of the vertex at its centre.
pub(super) struct LayerBall {
    pub(super) centre: Vec3,
    pub(super) radius: f64,
    pub(super) normal: Vec3,
}

impl LayerBall {
    /// Whether patch `p` lies wholly inside the ball.
    fn holds_patch(&self, surface: &Surface, p: u32) -> bool {
        // |centre - c| + radius <= r, without a square root in the walk's
        // hottest test.
        let (centre, radius) = surface.patch_bounds(p);
        let room = self.radius - radius;
        room >= 0.0 && (centre - self.centre).length_squared() <= room * room
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
    pub(super) fn edge_tensor<'e>(
        &self,
        edges: impl Iterator<Item = (&'e CurvedEdge, f64)>,
    ) -> [f64; 6] {
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
pub(super) fn full_tensor(upper: [f64; 6]) -> [[f64; 3]; 3] {
    let t = upper;
    [[t[0], t[1], t[2]], [t[1], t[3], t[4]], [t[2], t[4], t[5]]]
}
