//! Conservative surface voxelization: every voxel a triangle touches.
//!
//! Each triangle is swept along its dominant normal axis, one column of
//! voxels at a time. The triangle is clipped to the column's square; since the
//! clipped piece is planar, its depth range is exactly the range over the
//! clipped polygon's corners (read from the strip's two sides where they
//! cross the square's lines, or from the plane where the square lies wholly
//! inside the triangle), so the voxels marked are exactly those the
//! triangle meets (a voxel spans `[i, i + 1)`; pieces that only touch a
//! column's side are left to the neighbouring column). Thin sheets and open
//! surfaces therefore always leave a gap-free (26-connected) trace, which the
//! solid fill then completes.

use super::grid::{AtomicGrid, Grid, GridSpec, Rows};
use crate::exec::Threads;
use crate::math::{Vec3, dominant_axis, max_each, max_of, min_each, min_of};
use crate::mesh::TriMesh;

/// The voxels touched by the mesh's surface.
pub fn voxelize_surface(mesh: &TriMesh, spec: &GridSpec, backend: Threads) -> Grid {
    let all: Vec<u32> = (0..mesh.triangles().len() as u32).collect();
    voxelize_triangles(mesh, &all, spec, backend)
}

/// The voxels touched by `triangles` of `mesh`.
pub(crate) fn voxelize_triangles(
    mesh: &TriMesh,
    triangles: &[u32],
    spec: &GridSpec,
    backend: Threads,
) -> Grid {
    let grid = AtomicGrid::new(*spec);
    backend.for_each_range(triangles.len(), 8192, |range| {
        for &t in &triangles[range] {
            let tri = mesh.corners(t as usize).map(|p| spec.to_grid(p));
            for_each_touched_voxel(tri, spec.dims, |x, y, z| grid.set(x, y, z));
        }
    });
    // A triangle marks voxels within its box only (clamped to the grid).
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for &t in triangles {
        for p in mesh.corners(t as usize) {
            let q = spec.to_grid(p);
            lo = [min_of(lo[0], q.y), min_of(lo[1], q.z)];
            hi = [max_of(hi[0], q.y), max_of(hi[1], q.z)];
        }
    }
    let rows = match triangles.is_empty() {
        true => Rows::NONE,
        false => Rows::around(lo, hi, spec.dims),
    };
    grid.into_grid().within(rows)
}

/// Calls `visit` for every voxel the triangle (in grid units) meets, clamped
/// to the grid: a triangle that reaches past the grid also marks the
/// outermost voxels it overhangs (a window's border, which nothing reads),
/// and one whose box misses the grid marks nothing.
pub(crate) fn for_each_touched_voxel(
    tri: [Vec3; 3],
    dims: [usize; 3],
    mut visit: impl FnMut(usize, usize, usize),
) {
    let lo_p = min_each(min_each(tri[0], tri[1]), tri[2]);
    let hi_p = max_each(max_each(tri[0], tri[1]), tri[2]);
    if (0..3).any(|a| hi_p[a] < 0.0 || lo_p[a] >= dims[a] as f64) {
        return;
    }
    // Truncation is floor here: mesh points never have negative grid
    // coordinates (the grid is padded around them), and `max(0.0)` guards
    // callers that pass points outside.
    let clamp = |v: f64, axis: usize| (max_of(v, 0.0) as usize).min(dims[axis] - 1);
    let lo = [0, 1, 2].map(|a| clamp(lo_p[a], a));
    // A voxel that the triangle's box only touches on its far face is not met.
    let hi = [0, 1, 2].map(|a| clamp(hi_p[a].ceil() - 1.0, a).max(lo[a]));
    if lo == hi {
        visit(lo[0], lo[1], lo[2]);
        return;
    }
    let span = [0, 1, 2].map(|a| hi[a] - lo[a] + 1);
    if span[0] * span[1] * span[2] <= SMALL_BOX {
        let test = OverlapTest::new(&tri);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    if test.meets(x as f64, y as f64, z as f64) {
                        visit(x, y, z);
                    }
                }
            }
        }
        return;
    }
    let normal = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
    let w = dominant_axis(normal);
    let (mut u, mut v) = ((w + 1) % 3, (w + 2) % 3);
    // Strips are cut along the triangle's shorter side in the sweep plane:
    // a strip costs a cut and its two sides, a cell along it a multiply-add
    // or two, and a long thin triangle (a cylinder's side) across its
    // strips cost a strip per cell.
    if span[u] > span[v] {
        std::mem::swap(&mut u, &mut v);
    }
    let mut at = [0usize; 3];
    let mut column = |cu: usize, cv: usize, dmin: f64, dmax: f64| {
        at[u] = cu;
        at[v] = cv;
        for k in clamp(dmin, w).max(lo[w])..=clamp(dmax, w).min(hi[w]) {
            at[w] = k;
            visit(at[0], at[1], at[2]);
        }
    };
    if lo[u] == hi[u] && lo[v] == hi[v] {
        // The whole triangle stands over one column (the common case for
        // fine meshes): no clipping needed.
        column(lo[u], lo[v], lo_p[w], hi_p[w]);
        return;
    }
    // Cut the triangle along every grid line it crosses in u: each cut
    // yields both sides in one pass, written into buffers owned here (these
    // polygons are too big to move around). Each strip is then read cell by
    // cell in v along its two sides.
    let mut strip = [Polygon::EMPTY, Polygon::EMPTY];
    for (i, q) in tri.iter().enumerate() {
        strip[0].p[i] = [q[u], q[v], q[w]];
    }
    strip[0].n = 3;
    let mut piece = Polygon::EMPTY;
    let mut sides = [Chain::EMPTY, Chain::EMPTY];
    let mut cur_strip = 0;
    let plane = Plane::new(&tri, u, v, w, (lo[v], hi[v]));
    for cu in lo[u]..=hi[u] {
        if cu < hi[u] {
            let [a, b] = &mut strip;
            let (src, above) = if cur_strip == 0 { (&*a, b) } else { (&*b, a) };
            split(src, 0, (cu + 1) as f64, &mut piece, above);
            cur_strip ^= 1;
        } else {
            piece = strip[cur_strip];
        }
        // `piece` holds the strip of column cu; it is read over its own
        // extent in v only, so the columns of the triangle's bounding box
        // that the strip misses cost nothing (a long thin triangle lying
        // diagonally would otherwise cost its box's area).
        if piece.n < 3 {
            continue;
        }
        let (mut vmin, mut vmax) = (f64::INFINITY, f64::NEG_INFINITY);
        for q in &piece.p[..piece.n] {
            vmin = min_of(vmin, q[1]);
            vmax = max_of(vmax, q[1]);
        }
        // The first column whose upper line reaches the strip (a strip
        // that only touches that line yields the same degenerate piece as
        // the full sweep), and the last column that it reaches.
        let first = clamp(vmin.ceil() - 1.0, v).max(lo[v]);
        let last = clamp(vmax, v).min(hi[v]);
        if first > last {
            continue;
        }
        // The cells wholly inside the triangle take their depth range from
        // the plane; the others from the strip's corners within the cell
        // and where its two sides cross the cell's lines.
        let inner = plane
            .inner_cells(cu)
            .filter(|&(a, b)| a > first && b < last);
        // A strip with no area (a degenerate triangle's) marks nothing.
        if piece.depth_range().is_none() {
            continue;
        }
        if !Chain::sides_of(&piece, &mut sides) {
            continue;
        }
        let mut cv = first;
        while cv <= last {
            if let Some((a, b)) = inner.filter(|&(a, _)| a == cv) {
                for cv in a..=b {
                    let (dmin, dmax) = plane.depth_range(cu, cv);
                    column(cu, cv, dmin, dmax);
                }
                cv = b + 1;
                continue;
            }
            let (c0, c1) = (cv as f64, cv as f64 + 1.0);
            // A strip that only touches the cell's line has no area in it
            // (the neighbouring cell has); inside, a convex strip always has.
            let touches_only = (cv == first && vmin >= c1) || (cv == last && vmax <= c0);
            // The last cell takes what is left above, past the grid too.
            let top = (cv < last).then_some(c1);
            let mut range = (f64::INFINITY, f64::NEG_INFINITY);
            for side in &mut sides {
                side.depths_between(c0, top, &mut range);
            }
            if !touches_only {
                column(cu, cv, range.0, range.1);
            }
            cv += 1;
        }
    }
}

/// One side of a convex strip polygon, from its lowest corner in v to its
/// highest: where it crosses a grid line v = c is one multiply-add on the
/// edge that spans c, so a cell costs its two lines, not a polygon cut.
#[derive(Clone, Copy)]
struct Chain {
    /// Corners in order of v (non-decreasing), as (v, depth).
    v: [f64; 9],
    w: [f64; 9],
    /// Depth per unit of v along the edge from corner i to i + 1.
    slope: [f64; 9],
    len: usize,
    /// The first corner not yet passed: every corner before it lies below
    /// the current cell's lower line.
    at: usize,
}

impl Chain {
    const EMPTY: Chain = Chain {
        v: [0.0; 9],
        w: [0.0; 9],
        slope: [0.0; 9],
        len: 0,
        at: 0,
    };

    /// Sets `sides` to the two sides of `poly` (at least 3 corners);
    /// false for a polygon with no extent in v. In place: the chains are
    /// too big to move around per strip.
    fn sides_of(poly: &Polygon, sides: &mut [Chain; 2]) -> bool {
        let pts = &poly.p[..poly.n];
        let n = pts.len();
        if n < 3 {
            return false;
        }
        let (mut low, mut high) = (0, 0);
        for (i, q) in pts.iter().enumerate() {
            if q[1] < pts[low][1] {
                low = i;
            }
            if q[1] > pts[high][1] {
                high = i;
            }
        }
        if pts[high][1] <= pts[low][1] {
            return false;
        }
        for (c, step) in sides.iter_mut().zip([1, n - 1]) {
            c.len = 0;
            c.at = 0;
            let mut i = low;
            loop {
                c.v[c.len] = pts[i][1];
                c.w[c.len] = pts[i][2];
                c.len += 1;
                if i == high || c.len == c.v.len() {
                    break;
                }
                // (i + step) mod n, without a division.
                i += step;
                if i >= n {
                    i -= n;
                }
            }
            for k in 0..c.len - 1 {
                let dv = c.v[k + 1] - c.v[k];
                c.slope[k] = if dv > 0.0 {
                    (c.w[k + 1] - c.w[k]) / dv
                } else {
                    0.0
                };
            }
        }
        true
    }

    /// The depth where this side crosses the line v = `c` strictly
    /// between two corners.
    #[inline]
    fn crossing(&self, c: f64) -> Option<f64> {
        let k = self.at;
        (k > 0 && k < self.len && self.v[k - 1] < c && c < self.v[k])
            .then(|| self.w[k - 1] + (c - self.v[k - 1]) * self.slope[k - 1])
    }

    /// Widens `range` by this side's depths over the cell from line `c0`
    /// up to line `top` (to its end when `None`), and moves past the
    /// corners below the next cell's lower line.
    #[inline]
    fn depths_between(&mut self, c0: f64, top: Option<f64>, range: &mut (f64, f64)) {
        let mut widen = |d: f64| {
            range.0 = min_of(range.0, d);
            range.1 = max_of(range.1, d);
        };
        if let Some(d) = self.crossing(c0) {
            widen(d);
        }
        let c1 = top.unwrap_or(f64::INFINITY);
        while self.at < self.len && self.v[self.at] <= c1 {
            widen(self.w[self.at]);
            // A corner on the upper line belongs to the next cell too.
            if self.v[self.at] == c1 {
                break;
            }
            self.at += 1;
        }
        if let Some(c1) = top
            && let Some(d) = self.crossing(c1)
        {
            widen(d);
        }
    }
}

/// A triangle's plane over the (u, v) cells of its sweep: which cells of a
/// strip lie wholly inside the triangle, and the depth range over such a
/// cell, both in closed form.
struct Plane {
    /// Per edge, (a, b, c) with a u + b v + c >= 0 inside.
    edges: [[f64; 3]; 3],
    /// Depth at (u, v) = `depth0 + slope_u u + slope_v v`.
    depth0: f64,
    slope_u: f64,
    slope_v: f64,
    /// The v range of the triangle's box, in cells.
    v_cells: (usize, usize),
}

/// Cells within this of the triangle's edges (grid units) are cut as
/// border cells: rounding never lets a cell the triangle only partly covers
/// be taken as inner.
const INNER_MARGIN: f64 = 1e-7;

impl Plane {
    fn new(tri: &[Vec3; 3], u: usize, v: usize, w: usize, v_cells: (usize, usize)) -> Plane {
        let p = tri.map(|q| [q[u], q[v], q[w]]);
        // Twice the signed area in (u, v): the edges' orientation.
        let area =
            (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
        let sign = if area >= 0.0 { 1.0 } else { -1.0 };
        let edges = [0, 1, 2].map(|i| {
            let (a, b) = (p[i], p[(i + 1) % 3]);
            // Left of a -> b (for counter-clockwise order) is inside.
            let eu = -(b[1] - a[1]) * sign;
            let ev = (b[0] - a[0]) * sign;
            [eu, ev, -(eu * a[0] + ev * a[1])]
        });
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let (slope_u, slope_v) = (-n[u] / n[w], -n[v] / n[w]);
        Plane {
            edges,
            depth0: p[0][2] - slope_u * p[0][0] - slope_v * p[0][1],
            slope_u,
            slope_v,
            v_cells,
        }
    }

    /// The cells `a..=b` of strip `cu` whose squares lie inside the
    /// triangle, if any.
    fn inner_cells(&self, cu: usize) -> Option<(usize, usize)> {
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for &[a, b, c] in &self.edges {
            for u in [cu as f64, cu as f64 + 1.0] {
                // a u + b v + c >= margin, for v.
                let rest = INNER_MARGIN * (a.abs() + b.abs()) - a * u - c;
                if b > 0.0 {
                    lo = max_of(lo, rest / b);
                } else if b < 0.0 {
                    hi = min_of(hi, rest / b);
                } else if rest > 0.0 {
                    return None;
                }
            }
        }
        if !(lo.is_finite() && hi.is_finite()) || hi - lo < 1.0 {
            return None;
        }
        let first = max_of(lo.ceil(), self.v_cells.0 as f64);
        let last = min_of(hi.floor() - 1.0, self.v_cells.1 as f64);
        (first <= last).then_some((first as usize, last as usize))
    }

    /// The depth range over cell (cu, cv): at two of its corners, as the
    /// plane is linear.
    fn depth_range(&self, cu: usize, cv: usize) -> (f64, f64) {
        let d = self.depth0 + self.slope_u * cu as f64 + self.slope_v * cv as f64;
        let (su, sv) = (self.slope_u, self.slope_v);
        (
            d + min_of(su, 0.0) + min_of(sv, 0.0),
            d + max_of(su, 0.0) + max_of(sv, 0.0),
        )
    }
}

/// Triangles whose voxel box has at most this many voxels are tested voxel by
/// voxel; larger ones are swept column by column.
const SMALL_BOX: usize = 27;

/// The triangle/box overlap test of Schwarz and Seidel (2010), set up once per
/// triangle: a unit voxel meets the triangle iff it straddles the triangle's
/// plane and, in each of the three axis projections, lies on the inner side
/// of all three edges (each edge function offset to the voxel's critical
/// corner). Together with the bounding-box test done by the caller, this is
/// the separating-axis test; contact on the boundary counts as meeting.
struct OverlapTest {
    normal: Vec3,
    plane: [f64; 2],
    /// Per projection (yz, zx, xy), per edge: the 2D normal and offset.
    edges: [[([f64; 2], f64); 3]; 3],
}

impl OverlapTest {
    fn new(tri: &[Vec3; 3]) -> OverlapTest {
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let critical = Vec3::new(
            if n.x > 0.0 { 1.0 } else { 0.0 },
            if n.y > 0.0 { 1.0 } else { 0.0 },
            if n.z > 0.0 { 1.0 } else { 0.0 },
        );
        let plane = [
            n.dot(critical - tri[0]),
            n.dot(Vec3::new(1.0, 1.0, 1.0) - critical - tri[0]),
        ];
        let mut edges = [[([0.0; 2], 0.0); 3]; 3];
        for (proj, e) in edges.iter_mut().enumerate() {
            // Projection onto the plane orthogonal to axis `proj`: coordinates (a, b).
            let (a, b) = ((proj + 1) % 3, (proj + 2) % 3);
            let sign = if n[proj] >= 0.0 { 1.0 } else { -1.0 };
            for i in 0..3 {
                let (p, q) = (tri[i], tri[(i + 1) % 3]);
                let en = [-(q[b] - p[b]) * sign, (q[a] - p[a]) * sign];
                let d = -(en[0] * p[a] + en[1] * p[b]) + max_of(en[0], 0.0) + max_of(en[1], 0.0);
                e[i] = (en, d);
            }
        }
        OverlapTest {
            normal: n,
            plane,
            edges,
        }
    }

    /// Does the voxel with lowest corner (x, y, z) meet the triangle?
    #[inline]
    fn meets(&self, x: f64, y: f64, z: f64) -> bool {
        let np = self.normal.x * x + self.normal.y * y + self.normal.z * z;
        if (np + self.plane[0]) * (np + self.plane[1]) > 0.0 {
            return false;
        }
        let p = [x, y, z];
        self.edges.iter().enumerate().all(|(proj, e)| {
            let (a, b) = (p[(proj + 1) % 3], p[(proj + 2) % 3]);
            e.iter().all(|(en, d)| en[0] * a + en[1] * b + d >= 0.0)
        })
    }
}

/// A polygon vertex: (u, v) in the projection plane and the depth w.
type P = [f64; 3];

/// A piece of a triangle: up to 3 + 4 vertices after cuts by grid lines.
#[derive(Clone, Copy)]
struct Polygon {
    p: [P; 8],
    n: usize,
}

impl Polygon {
    const EMPTY: Polygon = Polygon {
        p: [[0.0; 3]; 8],
        n: 0,
    };

    #[inline]
    fn push(&mut self, q: P) {
        // A convex polygon cut by grid lines never exceeds 3 + 4 corners;
        // saturate rather than index out of bounds on pathological input.
        if self.n < self.p.len() {
            self.p[self.n] = q;
            self.n += 1;
        }
    }

    /// The depth range of a piece with area; `None` for a piece that only
    /// touches a grid line (its neighbour on the other side has the area).
    fn depth_range(&self) -> Option<(f64, f64)> {
        if self.n < 3 {
            return None;
        }
        let pts = &self.p[..self.n];
        let mut area2 = 0.0;
        let (mut dmin, mut dmax) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut a = pts[pts.len() - 1];
        for &b in pts {
            area2 += a[0] * b[1] - a[1] * b[0];
            dmin = min_of(dmin, b[2]);
            dmax = max_of(dmax, b[2]);
            a = b;
        }
        (area2 != 0.0).then_some((dmin, dmax))
    }
}

/// Cuts a convex polygon by the line `p[axis] = bound` into the parts below
/// and above it (points on the line go to both). Cut points get the bound
/// exactly, so a part that only touches the line has zero area.
fn split(poly: &Polygon, axis: usize, bound: f64, below: &mut Polygon, above: &mut Polygon) {
    below.n = 0;
    above.n = 0;
    let n = poly.n;
    if n == 0 {
        return;
    }
    let mut a = poly.p[n - 1];
    let mut da = a[axis] - bound;
    for &b in &poly.p[..n] {
        let db = b[axis] - bound;
        if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
            let t = da / (da - db);
            let mut c = [
                a[0] + t * (b[0] - a[0]),
                a[1] + t * (b[1] - a[1]),
                a[2] + t * (b[2] - a[2]),
            ];
            c[axis] = bound;
            below.push(c);
            above.push(c);
        }
        if db <= 0.0 {
            below.push(b);
        }
        if db >= 0.0 {
            above.push(b);
        }
        a = b;
        da = db;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn touched(tri: [Vec3; 3], dims: [usize; 3]) -> Vec<[usize; 3]> {
        let mut out = Vec::new();
        for_each_touched_voxel(tri, dims, |x, y, z| out.push([x, y, z]));
        out.sort();
        out
    }

    /// Exact oracle (13 separating axes, Akenine-Moller): does the triangle
    /// meet the cube of half-size `half` around the voxel's centre?
    fn sat_overlap(tri: &[Vec3; 3], voxel: [usize; 3], half: f64) -> bool {
        let c = Vec3::new(
            voxel[0] as f64 + 0.5,
            voxel[1] as f64 + 0.5,
            voxel[2] as f64 + 0.5,
        );
        let p = tri.map(|q| q - c);
        let e = [p[1] - p[0], p[2] - p[1], p[0] - p[2]];
        let unit = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let mut axes = vec![e[0].cross(e[1])];
        axes.extend(unit);
        for ei in e {
            for a in unit {
                axes.push(a.cross(ei));
            }
        }
        axes.iter().all(|ax| {
            let r = half * (ax.x.abs() + ax.y.abs() + ax.z.abs());
            let d = p.map(|q| q.dot(*ax));
            let (mn, mx) = (d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2]));
            !(mn > r || mx < -r)
        })
    }

    /// Asserts that the voxels marked for `tri` in a grid of `dims` lie
    /// between the closed oracle (every marked voxel meets the triangle)
    /// and the open one (every voxel it meets by more than rounding is
    /// marked).
    fn assert_between_oracles(tri: [Vec3; 3], dims: [usize; 3]) {
        let got = touched(tri, dims);
        for x in 0..dims[0] {
            for y in 0..dims[1] {
                for z in 0..dims[2] {
                    let v = [x, y, z];
                    if got.binary_search(&v).is_ok() {
                        assert!(
                            sat_overlap(&tri, v, 0.5),
                            "marked {v:?}, which {tri:?} misses"
                        );
                    } else {
                        assert!(
                            !sat_overlap(&tri, v, 0.5 - 1e-9),
                            "missed {v:?} for {tri:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn lies_between_the_open_and_closed_separating_axis_oracles() {
        let mut rnd = crate::math::unit_rng(12345);
        let dims = [12, 12, 12];
        for _ in 0..300 {
            let tri =
                [0; 3].map(|_| Vec3::new(2.0 + 8.0 * rnd(), 2.0 + 8.0 * rnd(), 2.0 + 8.0 * rnd()));
            assert_between_oracles(tri, dims);
        }
    }

    #[test]
    fn long_thin_triangles_meet_the_oracle() {
        // Slivers lying diagonally: each strip spans few of the bounding
        // box's columns.
        let mut rnd = crate::math::unit_rng(777);
        let dims = [30, 30, 30];
        for _ in 0..60 {
            let a = Vec3::new(1.0 + 28.0 * rnd(), 1.0 + 28.0 * rnd(), 1.0 + 28.0 * rnd());
            let b = Vec3::new(1.0 + 28.0 * rnd(), 1.0 + 28.0 * rnd(), 1.0 + 28.0 * rnd());
            let c = a + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 0.6;
            let tri = [a, b, c];
            assert_between_oracles(tri, dims);
        }
    }

    #[test]
    fn large_triangles_meet_the_oracle() {
        // Most of their cells lie wholly inside: the plane's closed form
        // there, the cuts along the border.
        let mut rnd = crate::math::unit_rng(4242);
        let n = 40;
        let dims = [n; 3];
        for _ in 0..24 {
            let tri = [0; 3]
                .map(|_| Vec3::new(1.0 + 38.0 * rnd(), 1.0 + 38.0 * rnd(), 1.0 + 38.0 * rnd()));
            assert_between_oracles(tri, dims);
        }
        // Faces along the grid's planes and diagonals, where corners fall
        // on grid lines.
        for tri in [
            [
                Vec3::new(2.0, 2.0, 5.0),
                Vec3::new(30.0, 2.0, 5.0),
                Vec3::new(2.0, 30.0, 5.0),
            ],
            [
                Vec3::new(2.0, 2.0, 2.0),
                Vec3::new(30.0, 30.0, 2.0),
                Vec3::new(2.0, 30.0, 30.0),
            ],
            [
                Vec3::new(3.5, 2.0, 7.25),
                Vec3::new(33.5, 4.0, 9.25),
                Vec3::new(5.5, 36.0, 11.25),
            ],
        ] {
            assert_between_oracles(tri, dims);
        }
    }

    #[test]
    fn a_face_on_a_voxel_boundary_marks_one_layer() {
        // The square x = 3, y, z in [2, 5]: voxels x = 3 only.
        let a = Vec3::new(3.0, 2.0, 2.0);
        let b = Vec3::new(3.0, 5.0, 2.0);
        let c = Vec3::new(3.0, 5.0, 5.0);
        let got = touched([a, b, c], [8, 8, 8]);
        assert!(got.iter().all(|v| v[0] == 3));
        assert!(
            got.iter()
                .all(|v| (2..5).contains(&v[1]) && (2..5).contains(&v[2])),
            "{got:?}"
        );
        // The lower-right half of the 3x3 square; the diagonal may add the
        // voxels it touches at a corner.
        assert!((6..=8).contains(&got.len()), "{got:?}");
    }
}
