//! Digital balls on the voxel grid: the runs along x of the voxels (or
//! count-pyramid blocks) whose centres lie within a radius of a voxel
//! centre, one set of runs per position of the centre inside its block.
//! The volume descriptor counts solid voxels in them, verification reads
//! moments over them, and the harmonics clutter guard reuses the volume
//! stage's balls.

use std::sync::{Arc, OnceLock};

use crate::exec::Threads;
use crate::math::Vec3;
use crate::voxel::{CountLevel, Grid, Solid};

/// One run of a digital ball: blocks (or voxels) `x0..=x1` of the row
/// `(dy, dz)`, relative to the block holding the centre.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Span {
    dy: i16,
    dz: i16,
    x0: i16,
    x1: i16,
}

/// Runs `start..end` of a phase: rows `dy, dy + 1, ...` of the slice
/// `dz`, one run each, so that a counting loop finds each row from the
/// last by one addition.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Slab {
    dy: i16,
    dz: i16,
    start: u32,
    end: u32,
}

impl Span {
    /// The run's (first, one past the last) entries in the running sums of
    /// a level with `ny` rows of blocks a slice and `stride` entries a row,
    /// relative to the centre block's.
    #[inline]
    fn sums_range(&self, ny: i64, stride: i64) -> (i64, i64) {
        let row = (i64::from(self.dz) * ny + i64::from(self.dy)) * stride;
        (row + i64::from(self.x0), row + i64::from(self.x1) + 1)
    }
}

/// The runs of the ball for one position of the centre inside its block.
#[derive(Clone, Debug)]
struct Phase {
    spans: Vec<Span>,
    /// The runs grouped into slabs of consecutive rows.
    slabs: Vec<Slab>,
    voxels: u64,
    /// Reach of the runs below and above the centre block, per axis.
    lo: [i64; 3],
    hi: [i64; 3],
}

impl Phase {
    fn new(spans: Vec<Span>, voxels: u64, lo: [i64; 3], hi: [i64; 3]) -> Phase {
        let mut slabs: Vec<Slab> = Vec::new();
        for (i, sp) in spans.iter().enumerate() {
            match slabs.last_mut() {
                Some(slab)
                    if slab.dz == sp.dz
                        && i64::from(slab.dy) + i64::from(slab.end - slab.start)
                            == i64::from(sp.dy) =>
                {
                    slab.end += 1
                }
                _ => slabs.push(Slab {
                    dy: sp.dy,
                    dz: sp.dz,
                    start: i as u32,
                    end: i as u32 + 1,
                }),
            }
        }
        Phase {
            spans,
            slabs,
            voxels,
            lo,
            hi,
        }
    }

    /// Whether every run around block (or voxel) `c` lies inside a grid
    /// of `dims`: then counting needs no test per run.
    #[inline]
    fn fits(&self, c: [i64; 3], dims: [i64; 3]) -> bool {
        (0..3).all(|a| c[a] + self.lo[a] >= 0 && c[a] + self.hi[a] < dims[a])
    }

    /// The runs for the centre mirrored along the axes `flip` (x, y, z)
    /// within its block, in the order [`Ball::phase`] would list them
    /// (rows by z, then y), which the exact arithmetic there reproduces
    /// bit for bit.
    fn mirrored(&self, flip: [bool; 3]) -> Phase {
        if flip == [false; 3] {
            return self.clone();
        }
        let turn = |sp: &Span| {
            let (x0, x1) = if flip[0] {
                (-sp.x1, -sp.x0)
            } else {
                (sp.x0, sp.x1)
            };
            Span {
                dy: if flip[1] { -sp.dy } else { sp.dy },
                dz: if flip[2] { -sp.dz } else { sp.dz },
                x0,
                x1,
            }
        };
        // Rows of one z run together, by increasing y: reverse the order of
        // the rows (z flipped) and within them (y flipped).
        let mut rows: Vec<&[Span]> = self.spans.chunk_by(|a, b| a.dz == b.dz).collect();
        if flip[2] {
            rows.reverse();
        }
        let mut spans = Vec::with_capacity(self.spans.len());
        for row in rows {
            if flip[1] {
                spans.extend(row.iter().rev().map(turn));
            } else {
                spans.extend(row.iter().map(turn));
            }
        }
        let (lo, hi) = (self.lo, self.hi);
        Phase::new(
            spans,
            self.voxels,
            [0, 1, 2].map(|a| if flip[a] { -hi[a] } else { lo[a] }),
            [0, 1, 2].map(|a| if flip[a] { -lo[a] } else { hi[a] }),
        )
    }
}

/// The ball of a radius (in voxels) around a voxel centre, as runs of the
/// pyramid level it is read from.
#[derive(Clone, Debug)]
pub struct Ball {
    radius: f64,
    level: u32,
    /// One per position of the centre voxel in its block (s^3 of them),
    /// shared by clones: a search hands the same ball to every part.
    phases: Arc<[Phase]>,
    /// The runs' places in the running sums of the solid it was made for
    /// (see [`Ball::for_solid`]); shared by clones.
    bound: Option<Arc<BoundRuns>>,
}

/// Per phase, a ball's runs as index pairs into one level's running sums,
/// relative to the centre block's entry: what the CPU's counting reads
/// fastest (a third less time than finding each row as it reads). Each
/// phase is bound when a point first reads it, so a part that few points
/// reach pays for few.
#[derive(Debug)]
struct BoundRuns {
    /// The level's blocks along y, and its stride: the layout bound to.
    layout: [usize; 2],
    phases: Box<[OnceLock<RunOffsets>]>,
}

/// A phase's runs as (first, one past the last) entries of the running
/// sums, relative to the centre block's.
type RunOffsets = Box<[(i64, i64)]>;

impl BoundRuns {
    fn new(level: &CountLevel, phases: usize) -> BoundRuns {
        BoundRuns {
            layout: [level.dims()[1], level.stride()],
            phases: (0..phases).map(|_| OnceLock::new()).collect(),
        }
    }

    /// Phase `p`'s runs, bound now if no point has read them yet.
    fn phase(&self, p: usize, phase: &Phase) -> &[(i64, i64)] {
        self.phases[p].get_or_init(|| {
            let [ny, stride] = self.layout.map(|x| x as i64);
            phase
                .spans
                .iter()
                .map(|sp| sp.sums_range(ny, stride))
                .collect()
        })
    }
}

impl Ball {
    /// The ball of `radius` voxels read at pyramid level `level`.
    pub fn at_level(radius: f64, level: u32) -> Ball {
        Ball::build(radius, level, Threads::Serial)
    }

    /// Like [`Ball::at_level`], computing the phases with `backend`.
    pub fn build(radius: f64, level: u32, backend: Threads) -> Ball {
        let s = 1i64 << level;
        // A centre in the upper half of its block along an axis sees the
        // ball of the mirrored position, mirrored: only the lower halves
        // are computed (an eighth of the phases from level 1 on).
        let half = (s + 1) / 2;
        let lower = backend.map((half * half * half) as usize, |i| {
            let i = i as i64;
            Ball::phase(radius, s, [i % half, (i / half) % half, i / (half * half)])
        });
        let phases = backend.map((s * s * s) as usize, |i| {
            let i = i as i64;
            let p = [i % s, (i / s) % s, i / (s * s)];
            let flip = p.map(|c| c >= half);
            let q = p.map(|c| if c >= half { s - 1 - c } else { c });
            lower[(q[0] + half * (q[1] + half * q[2])) as usize].mirrored(flip)
        });
        Ball {
            radius,
            level,
            phases: phases.into(),
            bound: None,
        }
    }

    /// Blocks of edge `s` whose centres lie within `radius` of a voxel centre
    /// at position `p` inside its block.
    fn phase(radius: f64, s: i64, p: [i64; 3]) -> Phase {
        let sf = s as f64;
        // The voxel centre relative to its block's centre, in voxels.
        let o = p.map(|c| c as f64 - (sf - 1.0) / 2.0);
        let r2 = radius * radius + 1e-9;
        let range = |o: f64, reach: f64| {
            (
                ((o - reach) / sf).ceil() as i64,
                ((o + reach) / sf).floor() as i64,
            )
        };
        let mut spans = Vec::new();
        let mut blocks = 0u64;
        let (z0, z1) = range(o[2], radius);
        for dz in z0..=z1 {
            let ez = (sf * dz as f64 - o[2]).powi(2);
            let (y0, y1) = range(o[1], (r2 - ez).max(0.0).sqrt());
            for dy in y0..=y1 {
                let rest = r2 - ez - (sf * dy as f64 - o[1]).powi(2);
                if rest < 0.0 {
                    continue;
                }
                let (x0, x1) = range(o[0], rest.sqrt());
                if x0 > x1 {
                    continue;
                }
                spans.push(Span {
                    dy: dy as i16,
                    dz: dz as i16,
                    x0: x0 as i16,
                    x1: x1 as i16,
                });
                blocks += (x1 - x0 + 1) as u64;
            }
        }
        let mut lo = [0i64; 3];
        let mut hi = [0i64; 3];
        for sp in &spans {
            lo = [
                lo[0].min(sp.x0 as i64),
                lo[1].min(sp.dy as i64),
                lo[2].min(sp.dz as i64),
            ];
            hi = [
                hi[0].max(sp.x1 as i64),
                hi[1].max(sp.dy as i64),
                hi[2].max(sp.dz as i64),
            ];
        }
        Phase::new(spans, blocks * (s * s * s) as u64, lo, hi)
    }

    /// The radius in voxels.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The pyramid level it is read from.
    pub fn level(&self) -> u32 {
        self.level
    }

    /// Bytes its run tables hold once every phase is bound (what
    /// [`crate::voxel::ball_bytes`] estimates ahead): the runs, shared by
    /// its clones, and one solid's offsets.
    #[cfg(test)]
    pub(crate) fn table_bytes(&self) -> u64 {
        let runs: usize = self.phases.iter().map(|p| p.spans.len()).sum();
        let slabs: usize = self.phases.iter().map(|p| p.slabs.len()).sum();
        (runs * (size_of::<Span>() + size_of::<(i64, i64)>()) + slabs * size_of::<Slab>()) as u64
    }

    /// The ball for counting in `solid`: builds the level it reads (if
    /// needed), so that counting there never builds it, and binds its runs
    /// to the level's layout as points read them. The runs themselves fit
    /// any solid, so one ball serves every part of a search (clones share
    /// them).
    pub fn for_solid(self, solid: &Solid, backend: Threads) -> Ball {
        if self.level == 0 {
            return self;
        }
        let level = solid.level(self.level, backend);
        Ball {
            bound: Some(Arc::new(BoundRuns::new(level, self.phases.len()))),
            ..self
        }
    }

    /// Solid voxels in the ball around voxel `v`, and the voxels the ball
    /// covers (voxels outside the grid count as empty). Builds the level
    /// it reads on this thread if [`Ball::for_solid`] has not.
    pub fn count(&self, solid: &Solid, v: [u16; 3]) -> (u64, u64) {
        if self.level == 0 {
            let phase = &self.phases[0];
            return (count_bits(phase, solid.bits(), v), phase.voxels);
        }
        let level = solid.level(self.level, Threads::Serial);
        let (p, c) = self.phase_at(v);
        let phase = &self.phases[p];
        let d = level.dims().map(|x| x as i64);
        if !phase.fits(c, d) {
            return (count_runs(level, phase, c), phase.voxels);
        }
        // Every run lies in the grid: no test per run.
        let sums = level.prefix();
        let base = level.row_start(c[1] as usize, c[2] as usize) as i64 + c[0];
        let mut total = 0u64;
        match &self.bound {
            Some(bound) if bound.layout == [level.dims()[1], level.stride()] => {
                for &(lo, hi) in bound.phase(p, phase) {
                    total += u64::from(sums[(base + hi) as usize] - sums[(base + lo) as usize]);
                }
            }
            _ => {
                let (ny, stride) = (d[1], level.stride() as i64);
                for sp in &phase.spans {
                    let (lo, hi) = sp.sums_range(ny, stride);
                    total += u64::from(sums[(base + hi) as usize] - sums[(base + lo) as usize]);
                }
            }
        }
        (total, phase.voxels)
    }

    /// The phase of voxel `v` (level > 0), and the block holding it.
    fn phase_at(&self, v: [u16; 3]) -> (usize, [i64; 3]) {
        let s = 1usize << self.level;
        let p = v.map(|c| c as usize & (s - 1));
        let block = v.map(|x| (x as usize >> self.level) as i64);
        (p[0] + s * (p[1] + s * p[2]), block)
    }

    /// Calls `visit(offset, solid voxels)` for every block of the ball around
    /// voxel `v` (level > 0; `offset` from the voxel's centre to the block's,
    /// in voxels): what moments of the local solid are computed from.
    pub(crate) fn for_each_block(
        &self,
        solid: &Solid,
        v: [u16; 3],
        mut visit: impl FnMut(Vec3, u32),
    ) {
        assert!(self.level > 0, "blocks exist from level 1");
        let level = solid.level(self.level, Threads::Serial);
        let s = 1i64 << self.level;
        let (p, c) = self.phase_at(v);
        let phase = &self.phases[p];
        let d = level.dims().map(|x| x as i64);
        let half = (s as f64 - 1.0) / 2.0;
        let centre = |b: i64, a: usize| (b * s) as f64 + half - v[a] as f64;
        for sp in &phase.spans {
            let (y, z) = (c[1] + sp.dy as i64, c[2] + sp.dz as i64);
            if y < 0 || z < 0 || y >= d[1] || z >= d[2] {
                continue;
            }
            let row = level.row_start(y as usize, z as usize);
            for x in (c[0] + sp.x0 as i64).max(0)..=(c[0] + sp.x1 as i64).min(d[0] - 1) {
                let n = level.run(row, x as usize, x as usize);
                if n > 0 {
                    visit(Vec3::new(centre(x, 0), centre(y, 1), centre(z, 2)), n);
                }
            }
        }
    }

    /// Solid voxels in the ball around voxel `v` (level > 0), the voxels
    /// it covers, and their first moment about the voxel's centre, in
    /// voxels (each block's voxels counted at the block's centre).
    pub fn moment(&self, solid: &Solid, v: [u16; 3]) -> BallMoment {
        assert!(self.level > 0, "moments are read from level 1 on");
        let level = solid.level(self.level, Threads::Serial);
        let (p, c) = self.phase_at(v);
        let phase = &self.phases[p];
        let (mut n, mut m) = (0i64, [0i64; 3]);
        for_each_clipped_run(level, phase, c, |row, x0, x1, sp| {
            let (count, along_x) = level.run_moment(row, x0, x1, c[0]);
            let count = i64::from(count);
            n += count;
            m[0] += along_x;
            m[1] += count * sp.dy as i64;
            m[2] += count * sp.dz as i64;
        });
        // From the centre block's centre to the voxel's, in voxels.
        let s = (1i64 << self.level) as f64;
        let offset = v.map(|x| (x as i64 & ((1 << self.level) - 1)) as f64 - (s - 1.0) / 2.0);
        BallMoment {
            solid: n as u64,
            covered: phase.voxels,
            first: [0, 1, 2].map(|a| m[a] as f64 * s - n as f64 * offset[a]),
        }
    }

    /// The voxels the ball around voxel `v` covers (its phase's blocks
    /// times their size): what [`Ball::count`]'s solid voxels are divided
    /// by.
    pub fn covered(&self, v: [u16; 3]) -> u64 {
        if self.level == 0 {
            return self.phases[0].voxels;
        }
        self.phases[self.phase_at(v).0].voxels
    }

    /// The runs as a kernel reads them: (dy, dz, x0, x1) relative to the
    /// block holding the centre, phase after phase, and where each phase's
    /// runs start (one more entry than phases). A voxel's phase is its
    /// position in its block, x fastest.
    pub fn run_tables(&self) -> (Vec<[i32; 4]>, Vec<u32>) {
        let mut runs = Vec::new();
        let mut starts = vec![0u32];
        for phase in self.phases.iter() {
            runs.extend(phase.spans.iter().map(|sp| {
                [
                    i32::from(sp.dy),
                    i32::from(sp.dz),
                    i32::from(sp.x0),
                    i32::from(sp.x1),
                ]
            }));
            starts.push(runs.len() as u32);
        }
        (runs, starts)
    }

    /// The solid fraction of the ball around voxel `v` (Eq. 3).
    pub fn fraction(&self, solid: &Solid, v: [u16; 3]) -> f64 {
        let (inside, all) = self.count(solid, v);
        inside as f64 / all as f64
    }
}

/// What [`Ball::moment`] reads: the ball's solid voxels, the voxels it
/// covers, and the solid's first moment about the centre (voxels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BallMoment {
    pub solid: u64,
    pub covered: u64,
    pub first: [f64; 3],
}

impl BallMoment {
    /// The solid fraction (Eq. 3).
    pub fn fraction(&self) -> f64 {
        self.solid as f64 / self.covered as f64
    }

    /// The centroid's distance from the centre as a share of the radius,
    /// weighted by the solid fraction: |first moment| / (covered x
    /// radius), in 0..=1. Rotation invariant, and moved by material added
    /// anywhere in the ball by at most the fraction added.
    pub fn offset(&self, radius: f64) -> f64 {
        let [x, y, z] = self.first;
        (x * x + y * y + z * z).sqrt() / (self.covered as f64 * radius)
    }
}

/// Solid voxels in the runs of `phase` around block `c` of `level`, run by
/// run (runs outside the grid count as empty).
fn count_runs(level: &CountLevel, phase: &Phase, c: [i64; 3]) -> u64 {
    let mut total = 0u64;
    for_each_clipped_run(level, phase, c, |row, x0, x1, _| {
        total += u64::from(level.run(row, x0, x1));
    });
    total
}

/// Calls `visit(row start, x0, x1, run)` for each run of `phase` around
/// block `c`, cut to the blocks of `level` (runs wholly outside skipped).
#[inline]
fn for_each_clipped_run(
    level: &CountLevel,
    phase: &Phase,
    c: [i64; 3],
    mut visit: impl FnMut(usize, usize, usize, &Span),
) {
    let d = level.dims().map(|x| x as i64);
    for sp in &phase.spans {
        let (y, z) = (c[1] + sp.dy as i64, c[2] + sp.dz as i64);
        if y < 0 || z < 0 || y >= d[1] || z >= d[2] {
            continue;
        }
        let (x0, x1) = (
            (c[0] + sp.x0 as i64).max(0),
            (c[0] + sp.x1 as i64).min(d[0] - 1),
        );
        if x0 <= x1 {
            let row = level.row_start(y as usize, z as usize);
            visit(row, x0 as usize, x1 as usize, sp);
        }
    }
}

/// Set voxels of the bit grid in the runs of `phase` around voxel `v`.
fn count_bits(phase: &Phase, grid: &Grid, v: [u16; 3]) -> u64 {
    let [nx, ny, nz] = grid.dims().map(|d| d as i64);
    let c = v.map(|x| x as i64);
    let words = grid.words();
    let wpr = grid.words_per_row();
    let mut total = 0u64;
    if phase.fits(c, [nx, ny, nz]) {
        // No test per run, and each row of a slab one step from the last.
        for slab in &phase.slabs {
            let first = (c[2] + i64::from(slab.dz)) * ny + c[1] + i64::from(slab.dy);
            let mut row = first as usize * wpr;
            for sp in &phase.spans[slab.start as usize..slab.end as usize] {
                let lo = (c[0] + i64::from(sp.x0)) as usize;
                let hi = (c[0] + i64::from(sp.x1)) as usize;
                total += u64::from(count_span(words, row, lo, hi));
                row += wpr;
            }
        }
        return total;
    }
    for s in &phase.spans {
        let (y, z) = (c[1] + s.dy as i64, c[2] + s.dz as i64);
        if y < 0 || z < 0 || y >= ny || z >= nz {
            continue;
        }
        let (lo, hi) = (
            (c[0] + s.x0 as i64).max(0),
            (c[0] + s.x1 as i64).min(nx - 1),
        );
        if lo <= hi {
            total += count_span(
                words,
                ((z * ny + y) * wpr as i64) as usize,
                lo as usize,
                hi as usize,
            ) as u64;
        }
    }
    total
}

/// Set bits `lo..=hi` of the row starting at word `row`.
#[inline]
fn count_span(words: &[u64], row: usize, lo: usize, hi: usize) -> u32 {
    let wl = row + (lo >> 6);
    if hi - lo < 64 {
        // At most two words, read as one: the grid keeps a word past its
        // last row for this.
        let pair = u128::from(words[wl]) | (u128::from(words[wl + 1]) << 64);
        let bits = (pair >> (lo & 63)) as u64 & (!0u64 >> (63 - (hi - lo)));
        return bits.count_ones();
    }
    let wh = row + (hi >> 6);
    let lo_mask = !0u64 << (lo & 63);
    let hi_mask = !0u64 >> (63 - (hi & 63));
    let mut n = (words[wl] & lo_mask).count_ones() + (words[wh] & hi_mask).count_ones();
    for w in &words[wl + 1..wh] {
        n += w.count_ones();
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::uv_sphere;
    use crate::voxel::level_for_radius;
    use crate::voxel::{GridSpec, skin, voxelize};
    use std::f64::consts::PI;

    /// The volume stage's block spacing (`descriptor::volume::BLOCKS_PER_RADIUS`).
    const VOLUME_BLOCKS: f64 = 4.5;

    fn exact(r: f64) -> Ball {
        Ball::at_level(r, 0)
    }

    #[test]
    fn ball_holds_about_its_volume_in_lattice_points() {
        for r in [3.0, 7.5, 20.0, 41.3] {
            let b = exact(r);
            let want = 4.0 / 3.0 * PI * r * r * r;
            let got = b.phases[0].voxels as f64;
            assert!(
                (got - want).abs() / want < 3.0 / r,
                "r {r}: {got} vs {want}"
            );
        }
        assert_eq!(exact(1.0).phases[0].voxels, 7);
        assert_eq!(exact(0.5).phases[0].voxels, 1);
    }

    fn brute(g: &Grid, v: [u16; 3], r: f64) -> u64 {
        let e = r.ceil() as i64;
        let mut n = 0;
        for dz in -e..=e {
            for dy in -e..=e {
                for dx in -e..=e {
                    if ((dx * dx + dy * dy + dz * dz) as f64) <= r * r
                        && g.get(v[0] as i64 + dx, v[1] as i64 + dy, v[2] as i64 + dz)
                    {
                        n += 1;
                    }
                }
            }
        }
        n
    }

    #[test]
    fn exact_counting_matches_brute_force_near_and_away_from_the_border() {
        let m = uv_sphere(Vec3::ZERO, 1.0, 24, 48);
        let spec = GridSpec::for_scene(m.bounds(), 40).unwrap();
        let solid = Solid::new(voxelize(&m, &spec, Threads::Serial));
        let ball = exact(6.7);
        for v in [
            [20u16, 20, 20],
            [3, 20, 20],
            [21, 1, 38],
            [0, 0, 0],
            [41, 30, 5],
        ] {
            assert_eq!(
                ball.count(&solid, v).0,
                brute(solid.bits(), v, 6.7),
                "at {v:?}"
            );
        }
    }

    #[test]
    fn coarse_levels_agree_with_exact_counts() {
        // A real, irregular model, at the radii the pipeline uses.
        let m = crate::mesh::io::load(&crate::shared_bytes("models/cow.obj"), None).unwrap();
        let spec = GridSpec::for_scene(m.bounds(), 160).unwrap();
        let solid = Solid::new(voxelize(&m, &spec, Threads::Parallel));
        let skin: Vec<[u16; 3]> = skin(solid.bits(), Threads::Serial)
            .iter_ones()
            .step_by(37)
            .collect();
        for r in [13.0, 26.0, 41.0, 70.0] {
            let coarse = Ball::at_level(r, level_for_radius(r, VOLUME_BLOCKS))
                .for_solid(&solid, Threads::Serial);
            assert!(coarse.level() > 0);
            let fine = exact(r);
            let (mut worst, mut sum) = (0.0f64, 0.0);
            for &v in &skin {
                let d = (coarse.fraction(&solid, v) - fine.fraction(&solid, v)).abs();
                worst = worst.max(d);
                sum += d;
            }
            let mean = sum / skin.len() as f64;
            assert!(
                mean < 0.004 && worst < 0.02,
                "r {r} (level {}): mean {mean} worst {worst}",
                coarse.level()
            );
        }
    }

    #[test]
    fn mirrored_phases_are_the_phases_computed_directly() {
        for (r, level) in [(3.0, 1), (12.3, 1), (24.6, 2), (36.9, 3), (30.5, 3)] {
            let ball = Ball::at_level(r, level);
            let s = 1i64 << level;
            for (i, phase) in ball.phases.iter().enumerate() {
                let i = i as i64;
                let direct = Ball::phase(r, s, [i % s, (i / s) % s, i / (s * s)]);
                assert_eq!(phase.spans, direct.spans, "r {r} level {level} phase {i}");
                assert_eq!(phase.slabs, direct.slabs, "r {r} level {level} phase {i}");
                assert_eq!(
                    (phase.voxels, phase.lo, phase.hi),
                    (direct.voxels, direct.lo, direct.hi)
                );
            }
        }
    }

    /// Solid voxels in the ball's runs around `v`, voxel by voxel or
    /// block by block, each tested against the grid.
    fn counted_one_by_one(ball: &Ball, solid: &Solid, v: [u16; 3]) -> u64 {
        let (p, c) = if ball.level == 0 {
            (0, v.map(i64::from))
        } else {
            ball.phase_at(v)
        };
        let phase = &ball.phases[p];
        if ball.level > 0 {
            return count_runs(solid.level(ball.level, Threads::Serial), phase, c);
        }
        let bits = solid.bits();
        phase
            .spans
            .iter()
            .flat_map(|sp| {
                (sp.x0..=sp.x1).map(move |x| {
                    let at = [
                        c[0] + i64::from(x),
                        c[1] + i64::from(sp.dy),
                        c[2] + i64::from(sp.dz),
                    ];
                    u64::from(bits.get(at[0], at[1], at[2]))
                })
            })
            .sum()
    }

    #[test]
    fn counting_fast_matches_counting_one_by_one() {
        // Inside the grid (the fast paths) and across its border, at every
        // level: at level 0 runs cross word boundaries and the last word.
        // A ball made for the solid reads its bound runs; one made for none,
        // or for a solid of another layout, finds each row as it reads.
        let m = uv_sphere(Vec3::ZERO, 1.0, 24, 48);
        let spec = GridSpec::for_scene(m.bounds(), 150).unwrap();
        let solid = Solid::new(voxelize(&m, &spec, Threads::Serial));
        let other_spec = GridSpec::for_scene(m.bounds(), 117).unwrap();
        let other = Solid::new(voxelize(&m, &other_spec, Threads::Serial));
        let mut points: Vec<[u16; 3]> = skin(solid.bits(), Threads::Serial)
            .iter_ones()
            .step_by(7)
            .collect();
        let far = spec.dims.map(|d| d as u16 - 1);
        points.extend([
            [0, 0, 0],
            [75, 75, 75],
            [2, 77, 148],
            far,
            [63, 64, 70],
            [64, 60, 80],
        ]);
        let coarse = |r| (r, level_for_radius(r, VOLUME_BLOCKS));
        for (r, level) in [
            (3.0, 0),
            (7.5, 0),
            (40.0, 0),
            coarse(10.0),
            coarse(20.0),
            coarse(40.0),
        ] {
            let made = Ball::at_level(r, level);
            let ball = made.clone().for_solid(&solid, Threads::Serial);
            let elsewhere = made.clone().for_solid(&other, Threads::Serial);
            for &v in &points {
                let want = counted_one_by_one(&ball, &solid, v);
                assert_eq!(
                    ball.count(&solid, v).0,
                    want,
                    "r {r} level {level} at {v:?}"
                );
                assert_eq!(
                    made.count(&solid, v).0,
                    want,
                    "r {r} level {level} at {v:?}"
                );
                assert_eq!(
                    elsewhere.count(&solid, v).0,
                    want,
                    "r {r} level {level} at {v:?}"
                );
            }
        }
    }

    #[test]
    fn slabs_hold_every_run_once_in_order() {
        for (r, level) in [(3.0, 0), (12.3, 1), (36.9, 3)] {
            let ball = Ball::at_level(r, level);
            for phase in ball.phases.iter() {
                let mut next = 0;
                for slab in &phase.slabs {
                    assert_eq!(slab.start, next);
                    let runs = &phase.spans[slab.start as usize..slab.end as usize];
                    for (k, sp) in runs.iter().enumerate() {
                        assert_eq!((sp.dz, sp.dy), (slab.dz, slab.dy + k as i16));
                    }
                    next = slab.end;
                }
                assert_eq!(next as usize, phase.spans.len());
            }
        }
    }
}
