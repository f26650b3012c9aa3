//! Covers: the scene's vertices in small groups around sample vertices,
//! with intervals, computed at the sample alone, that hold every layer's
//! Gaussian curvature at every vertex of its group. A group whose
//! intervals lie too far from the template is rejected whole: no vertex in
//! it can pass the exact cascade, so a pass over the covers drops only
//! vertices the exact pass would drop.
//!
//! Why the intervals hold. Let v lie within `reach` (d) of sample s and on
//! a triangle of s's connected neighbourhood within d, with 2d <= r. Every
//! triangle meeting B(s, r - d) meets B(v, r) and is connected to v inside
//! it (through s's neighbourhood within d, which B(v, r) contains), and
//! every triangle of v's neighbourhood at r meets B(s, r + d) and is
//! connected to s inside it. So v's neighbourhood at r lies between s's at
//! r - d and s's at r + d, each edge's clipped length and each triangle's
//! clipped area too. With the edges read in the same frame, v's tensor is
//! then at least (inner positive share - outer negative share) and at most
//! (outer positive share - inner negative share) in the Loewner order, so
//! its sorted eigenvalues lie between those of the two (Weyl), and its
//! area between the two areas. The frame is v's normal, not s's: that
//! moves the tensor by at most the outer sums' `wobble` (spectral norm),
//! given the largest turn between s's normal and a member's.

use super::bounds::{BOUND_MARGIN, gaussian_range};
use super::neighbourhood::{
    CurvatureState, Sums, add_cut_edges, clip_cut_areas, full_tensor, gather,
};
use super::surface::Surface;
use crate::cascade::Anchors;
use crate::descriptor::OnionDescriptor;
use crate::math::symmetric_eigen;
use crate::mesh::closest_point_on_triangle;

/// A surface's vertices grouped around samples; each used vertex belongs to
/// exactly one group.
pub struct Covers {
    /// How far a member may lie from its sample.
    reach: f64,
    samples: Vec<u32>,
    /// The largest angle (radians) between a sample's normal and a member's.
    turns: Vec<f64>,
    /// Group g's members are `members[starts[g]..starts[g + 1]]`.
    starts: Vec<usize>,
    members: Vec<u32>,
}

impl Covers {
    /// Groups the used vertices of `surface` around samples at most `reach`
    /// apart, taking first the vertex nearest each grid cell's centre
    /// (cells of side `reach`) and then any vertex left over.
    pub fn new(surface: &Surface, reach: f64) -> Covers {
        let mut covers = Covers {
            reach,
            samples: Vec::new(),
            turns: Vec::new(),
            starts: vec![0],
            members: Vec::new(),
        };
        let order: Vec<u32> = match super::VertexGrid::new(surface, reach) {
            Some(grid) => grid.sample(surface),
            None => Vec::new(),
        };
        let mut taken = vec![false; surface.vertex_count()];
        let mut walk = CoverWalk::default();
        for s in order.into_iter().chain(surface.used_vertices()) {
            if taken[s as usize] {
                continue;
            }
            let normal = surface.vertex_normal(s);
            let mut turn: f64 = 0.0;
            for v in walk.near(surface, s, reach) {
                if !taken[v as usize] {
                    taken[v as usize] = true;
                    covers.members.push(v);
                    let cos = normal.dot(surface.vertex_normal(v)).clamp(-1.0, 1.0);
                    turn = turn.max(cos.acos());
                }
            }
            covers.samples.push(s);
            covers.turns.push(turn);
            covers.starts.push(covers.members.len());
        }
        covers
    }

    /// How many groups.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Whether there is no group (a surface with no used vertex).
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Group `g`'s sample vertex.
    pub fn sample(&self, g: u32) -> u32 {
        self.samples[g as usize]
    }

    /// Group `g`'s vertices (its sample among them).
    pub fn members(&self, g: u32) -> &[u32] {
        let g = g as usize;
        &self.members[self.starts[g]..self.starts[g + 1]]
    }
}

/// Scratch for the small walks that find a sample's neighbours.
#[derive(Default)]
struct CoverWalk {
    marks: Vec<u32>,
    current: u32,
    queue: Vec<u32>,
    found: Vec<u32>,
}

impl CoverWalk {
    /// The corners within `reach` of `s` of the triangles connected to `s`
    /// through triangles that meet the ball B(s, reach) (`s` among them).
    fn near(&mut self, surface: &Surface, s: u32, reach: f64) -> std::vec::IntoIter<u32> {
        if self.marks.len() < surface.triangles().len() {
            self.marks.resize(surface.triangles().len(), 0);
        }
        if self.current == u32::MAX {
            self.marks.fill(0);
            self.current = 0;
        }
        self.current += 1;
        let c = surface.position(s);
        let r2 = reach * reach;
        self.found.clear();
        self.found.push(s);
        self.queue.clear();
        for &t in surface.triangles_at(s) {
            self.marks[t as usize] = self.current;
            self.queue.push(t);
        }
        while let Some(t) = self.queue.pop() {
            let p = surface.corners(t);
            let corners = surface.triangles()[t as usize];
            let mut meets = false;
            for (q, v) in p.iter().zip(corners) {
                if (*q - c).length_squared() <= r2 {
                    meets = true;
                    self.found.push(v);
                }
            }
            meets =
                meets || closest_point_on_triangle(c, p[0], p[1], p[2], t as usize).distance2 <= r2;
            if !meets {
                continue;
            }
            for &n in surface.neighbours(t) {
                let m = &mut self.marks[n as usize];
                if *m != self.current {
                    *m = self.current;
                    self.queue.push(n);
                }
            }
        }
        self.found.sort_unstable();
        self.found.dedup();
        std::mem::take(&mut self.found).into_iter()
    }
}

/// The curvature descriptor's lower bound over covers: a point is a group
/// of [`Covers`], its running distance the least the exact descriptor can
/// give any member, layer by layer.
pub struct CoverDescriptor<'a> {
    surface: &'a Surface,
    covers: &'a Covers,
    radii: Vec<f64>,
    /// The template's layers, scaled by `scale`.
    template: Vec<f64>,
    scale: f64,
    threshold: f64,
}

impl<'a> CoverDescriptor<'a> {
    /// Bounds over `covers` of the exact descriptor with these radii,
    /// template layers (unscaled) and threshold. None unless the covers'
    /// reach is at most half of the first radius and of every gap between
    /// radii (the proof's condition, and each layer's two balls in order).
    pub fn new(
        surface: &'a Surface,
        covers: &'a Covers,
        radii: &[f64],
        template: &[f64],
        threshold: f64,
    ) -> Option<CoverDescriptor<'a>> {
        let first = radii.first().copied()?;
        let gap = radii.windows(2).map(|w| w[1] - w[0]).fold(first, f64::min);
        if 2.0 * covers.reach > gap || covers.reach.is_nan() {
            return None;
        }
        let outer = radii.last().copied().unwrap_or(1.0);
        let scale = outer * outer;
        Some(CoverDescriptor {
            surface,
            covers,
            radii: radii.to_vec(),
            template: template.iter().map(|g| g * scale).collect(),
            scale,
            threshold,
        })
    }
}

/// A layer's exact sums at radius `r` around the state's vertex.
fn sums_at(surface: &Surface, v: u32, r: f64, state: &mut CurvatureState) -> Sums {
    let ball = gather(surface, v, r, state);
    let (sums, _) = add_cut_edges(surface, &ball, state);
    clip_cut_areas(surface, &ball, state, sums)
}

/// Sorted eigenvalues (ascending) of an upper triangle, row by row.
fn sorted_eigenvalues(upper: [f64; 6]) -> [f64; 3] {
    let (mut values, _) = symmetric_eigen(full_tensor(upper));
    values.sort_by(f64::total_cmp);
    values
}

/// An interval holding the Gaussian curvature at every member of a cover,
/// from the sample's sums on the ball r - reach (`inner`) and r + reach
/// (`outer`).
fn cover_interval(inner: &Sums, outer: &Sums) -> (f64, f64) {
    let sub = |a: [f64; 6], b: [f64; 6]| std::array::from_fn::<f64, 6, _>(|i| a[i] - b[i]);
    let add = |a: [f64; 6], b: [f64; 6]| std::array::from_fn::<f64, 6, _>(|i| a[i] + b[i]);
    // tensor = positive - negative, so positive = tensor + negative.
    let low = sub(add(inner.tensor, inner.negative), outer.negative);
    let high = sub(add(outer.tensor, outer.negative), inner.negative);
    let (low, high) = (sorted_eigenvalues(low), sorted_eigenvalues(high));
    // Rounding: the members' tensors are summed in another order and
    // divided by the area before their eigenvalues are taken.
    let scale = low.iter().chain(&high).map(|x| x.abs()).fold(0.0, f64::max);
    let widen = outer.wobble + 1e-9 * scale;
    let ranges = std::array::from_fn(|i| (low[i] - widen, high[i] + widen));
    gaussian_range(ranges, inner.area, outer.area)
}

impl OnionDescriptor for CoverDescriptor<'_> {
    type State = CurvatureState;

    fn name(&self) -> &'static str {
        "curvature-cover"
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

    fn start(&self, group: u32, _anchors: Anchors) -> CurvatureState {
        let mut state = CurvatureState::at(self.surface, self.covers.sample(group));
        state.turn = Some(self.covers.turns[group as usize]);
        state
    }

    fn extend(&self, group: u32, layer: usize, state: &mut CurvatureState) -> f64 {
        let s = self.covers.sample(group);
        let (r, reach) = (self.radii[layer], self.covers.reach);
        let inner = sums_at(self.surface, s, r - reach, state);
        let outer = sums_at(self.surface, s, r + reach, state);
        let (low, high) = cover_interval(&inner, &outer);
        let t = self.template[layer];
        let gap = (low * self.scale - t).max(t - high * self.scale).max(0.0);
        state.distance += gap * gap;
        // Kept a little longer than the exact pass would be: the bound must
        // never drop what the exact value keeps.
        state.distance / (1.0 + BOUND_MARGIN)
    }
}
