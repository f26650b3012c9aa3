//! The rotation-invariant spherical harmonics descriptor (paper, sec. 4.1,
//! after Kazhdan, Funkhouser and Rusinkiewicz 2003).
//!
//! Layer i samples the solid on the sphere of radius r_i around the point,
//! expands that function in spherical harmonics and keeps the energy of each
//! degree l < L: rotating the shape mixes the coefficients within a degree but
//! keeps each degree's norm, so the descriptor ignores orientation.
//!
//! - Sampling: 2B x 2B points on the Driscoll-Healy grid (theta_j =
//!   pi (2j + 1) / 4B, phi_k = pi k / B), the solid read with trilinear
//!   interpolation of the voxel occupancy so that a one-voxel shift does not
//!   flip samples.
//! - Transform: a DFT per ring for orders m < L, then Fejer's quadrature
//!   (exact for polynomials of degree < 2B in cos theta) against fully
//!   normalized associated Legendre functions.
//! - Signature normalization: `s_l = ||f_l|| / sqrt(4 pi)`. By Parseval,
//!   `sum_l s_l^2` is the mean of f^2 over the sphere, at most 1 (a sphere
//!   wholly inside the solid gives s_0 = 1 and nothing else), whatever the
//!   radius, voxel size or scene.
//! - Distance normalization: what separates a true occurrence from the
//!   template is discretization, not shape: the centre lands up to a voxel
//!   away, the rotated copy aliases differently, a remeshed surface moves by
//!   a fraction of a voxel. A deviation of delta voxels changes the
//!   signature of a sphere of R voxels by about delta / R, so small spheres
//!   are noisy and large ones are not (measured on the shared scenes: the
//!   error of true matches falls as 1/R while false matches differ most on
//!   the large spheres). Each sphere's L2 difference is therefore scaled by
//!   its radius in voxels, and the running distance is the root mean square
//!   of these over the k spheres:
//!   `D_i = sqrt(sum_{j <= i} (R_j / voxel)^2 ||s_j - t_j||^2 / k)`.
//!   D reads as "the template deviates like a shift of D voxels", the same
//!   scale for every sphere, template size and scene, which is what lets one
//!   threshold serve them all; it only grows with i (monotonic).
//! - Order: every sphere costs the same, so the stage computes them in the
//!   order that rejects soonest rather than innermost first, with the same
//!   survivors and distances ([`ClutterPolicy::selective_order`]).

use super::{ClutterPolicy, OnionDescriptor};
use crate::exec::Backend;
use crate::voxel::{Ball, Grid, Solid, level_for_radius};
use std::f64::consts::PI;

/// Bandwidth: 2B x 2B samples per sphere.
pub const BANDWIDTH: usize = 32;
/// Degrees kept: l < L.
pub const DEGREES: usize = 16;

const RINGS: usize = 2 * BANDWIDTH;
const HALF_RINGS: usize = BANDWIDTH;
const SECTORS: usize = 2 * BANDWIDTH;
const HALF_SECTORS: usize = BANDWIDTH;
const QUARTER_SECTORS: usize = BANDWIDTH / 2;
// A sampling chunk is one ring (one z): the samplers rely on it.
const _: () = assert!(CHUNK == SECTORS);

/// The per-degree energies of one sphere.
pub type Signature = [f32; DEGREES];

/// Orders with even and odd m: the phi + pi fold treats them apart.
const HALF_ORDERS: usize = DEGREES / 2;

/// (-1)^i for i < HALF_ORDERS.
const ALTERNATING: [f32; HALF_ORDERS] = {
    let mut a = [1.0f32; HALF_ORDERS];
    let mut i = 1;
    while i < HALF_ORDERS {
        a[i] = -a[i - 1];
        i += 1;
    }
    a
};

/// Degrees of one parity for one order: at most DEGREES / 2.
const PARITY_LANES: usize = DEGREES / 2;

/// Precomputed tables for the transform (independent of radius and grid).
///
/// The loops below keep their innermost index over independent
/// accumulators (orders m, then degrees l) so that they vectorize.
pub struct SphericalTransform {
    /// For k < SECTORS / 4 (the folds in `signature` cover the rest):
    /// `[k]` = [cos(m phi_k), -sin(m phi_k)] for the even orders m = 2i,
    /// then the same for the odd orders m = 2i + 1, each `[i]`: the real
    /// and imaginary parts of e^{-i m phi_k}.
    fourier: [[[f32; HALF_ORDERS]; 4]; QUARTER_SECTORS],
    /// Quadrature weight x normalized Legendre value, for the northern rings
    /// j < RINGS / 2 (southern ones fold in by parity): `legendre[m][p][j]`
    /// holds the degrees l >= m with l + m of parity p, in order, padded
    /// with zeros to a fixed width (P_l^m is even or odd in cos theta as
    /// l + m is, so each degree needs only one of the two folds).
    legendre: Vec<[[[f32; PARITY_LANES]; HALF_RINGS]; 2]>,
}

impl Default for SphericalTransform {
    fn default() -> Self {
        Self::new()
    }
}

impl SphericalTransform {
    /// Builds the tables.
    pub fn new() -> SphericalTransform {
        let mut t = SphericalTransform {
            fourier: [[[0.0; HALF_ORDERS]; 4]; QUARTER_SECTORS],
            legendre: vec![[[[0.0; PARITY_LANES]; HALF_RINGS]; 2]; DEGREES],
        };
        for k in 0..QUARTER_SECTORS {
            for i in 0..HALF_ORDERS {
                let (se, ce) = ((2 * i) as f64 * phi(k)).sin_cos();
                let (so, co) = ((2 * i + 1) as f64 * phi(k)).sin_cos();
                t.fourier[k][0][i] = ce as f32;
                t.fourier[k][1][i] = -se as f32;
                t.fourier[k][2][i] = co as f32;
                t.fourier[k][3][i] = -so as f32;
            }
        }
        let weights = fejer_weights();
        for j in 0..HALF_RINGS {
            let p = normalized_legendre(theta(j).cos());
            let w = weights[j] * (2.0 * PI / SECTORS as f64);
            for m in 0..DEGREES {
                for l in m..DEGREES {
                    t.legendre[m][(l + m) % 2][j][(l - m) / 2] = (w * p[l][m]) as f32;
                }
            }
        }
        t
    }

    /// The per-degree energies of samples `f[j * SECTORS + k]` taken at
    /// (theta_j, phi_k), normalized as the module doc says.
    pub fn signature(&self, f: &[f32; RINGS * SECTORS]) -> Signature {
        // Fourier coefficients per ring for m < L, folding twice. phi + pi:
        // even orders see g = f(phi) + f(phi + pi), odd ones h = the
        // difference. Then pi - phi: cos(m (pi - phi)) = (-1)^m cos(m phi)
        // and sin(m (pi - phi)) = -(-1)^m sin(m phi), so each order reads
        // the sum or the difference of g (or h) at k and HALF_SECTORS - k.
        // Sectors 0 and QUARTER_SECTORS pair with themselves: they start the
        // sums, with cos(m pi / 2) and sin(m pi / 2) = (-1)^i or 0.
        // `coefficients[j][a][i]`: ring j, accumulator a (even re, even im,
        // odd re, odd im), order 2i or 2i + 1; stored as accumulated, so that
        // the products vectorize over i.
        let mut coefficients = [[[0.0f32; HALF_ORDERS]; 4]; RINGS];
        for (j, acc) in coefficients.iter_mut().enumerate() {
            let ring = &f[j * SECTORS..(j + 1) * SECTORS];
            let g = |k: usize| ring[k] + ring[k + HALF_SECTORS];
            let h = |k: usize| ring[k] - ring[k + HALF_SECTORS];
            let (g0, gq, h0, hq) = (g(0), g(QUARTER_SECTORS), h(0), h(QUARTER_SECTORS));
            *acc = [
                ALTERNATING.map(|s| g0 + s * gq),
                [0.0f32; HALF_ORDERS],
                [h0; HALF_ORDERS],
                ALTERNATING.map(|s| -s * hq),
            ];
            for k in 1..QUARTER_SECTORS {
                let (ga, gb) = (g(k), g(HALF_SECTORS - k));
                let (ha, hb) = (h(k), h(HALF_SECTORS - k));
                // What each accumulator reads at this k, in its order.
                let folded = [ga + gb, ga - gb, ha - hb, ha + hb];
                let table = &self.fourier[k];
                for a in 0..4 {
                    for i in 0..HALF_ORDERS {
                        acc[a][i] += folded[a] * table[a][i];
                    }
                }
            }
        }
        // Legendre step, folding theta and pi - theta: degrees with l + m
        // even see the sum of the two rings, the others the difference.
        let mut energy = [0.0f64; DEGREES];
        for m in 0..DEGREES {
            let (mut ar, mut ai) = ([[0.0f32; PARITY_LANES]; 2], [[0.0f32; PARITY_LANES]; 2]);
            let (a, i) = (2 * (m % 2), m / 2);
            for j in 0..HALF_RINGS {
                let (north, south) = (&coefficients[j], &coefficients[RINGS - 1 - j]);
                let (nr, ni, sr, si) = (north[a][i], north[a + 1][i], south[a][i], south[a + 1][i]);
                let folded = [(nr + sr, ni + si), (nr - sr, ni - si)];
                for p in 0..2 {
                    let table = &self.legendre[m][p][j];
                    let (fr, fi) = folded[p];
                    for i in 0..PARITY_LANES {
                        ar[p][i] += table[i] * fr;
                        ai[p][i] += table[i] * fi;
                    }
                }
            }
            for l in m..DEGREES {
                let (p, i) = ((l + m) % 2, (l - m) / 2);
                let e = (ar[p][i] as f64).powi(2) + (ai[p][i] as f64).powi(2);
                energy[l] += if m == 0 { e } else { 2.0 * e };
            }
        }
        energy.map(|e| (e / (4.0 * PI)).sqrt() as f32)
    }
}

fn theta(j: usize) -> f64 {
    PI * (2 * j + 1) as f64 / (4 * BANDWIDTH) as f64
}

fn phi(k: usize) -> f64 {
    PI * k as f64 / BANDWIDTH as f64
}

/// Fejer's first rule on the nodes cos(theta_j): exact for polynomials of
/// degree < RINGS in x = cos theta over [-1, 1].
fn fejer_weights() -> [f64; RINGS] {
    let n = RINGS;
    let mut w = [0.0; RINGS];
    for (j, wj) in w.iter_mut().enumerate() {
        let t = theta(j);
        let s: f64 = (1..=n / 2)
            .map(|m| (2.0 * m as f64 * t).cos() / (4.0 * (m * m) as f64 - 1.0))
            .sum();
        *wj = 2.0 / n as f64 * (1.0 - 2.0 * s);
    }
    w
}

/// Fully normalized associated Legendre values `p[l][m]` at `x` (so that
/// `Y_lm = p[l][m] e^{i m phi}` is orthonormal on the sphere), by the standard
/// stable recurrences.
fn normalized_legendre(x: f64) -> Vec<Vec<f64>> {
    let s = (1.0 - x * x).max(0.0).sqrt();
    let mut p = vec![vec![0.0; DEGREES]; DEGREES];
    p[0][0] = (1.0 / (4.0 * PI)).sqrt();
    for m in 1..DEGREES {
        p[m][m] = -((2 * m + 1) as f64 / (2 * m) as f64).sqrt() * s * p[m - 1][m - 1];
    }
    for m in 0..DEGREES - 1 {
        p[m + 1][m] = ((2 * m + 3) as f64).sqrt() * x * p[m][m];
    }
    for m in 0..DEGREES {
        for l in m + 2..DEGREES {
            let (lf, mf) = (l as f64, m as f64);
            let a = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
            let b = (((lf - 1.0) * (lf - 1.0) - mf * mf) / (4.0 * (lf - 1.0) * (lf - 1.0) - 1.0))
                .sqrt();
            p[l][m] = a * (x * p[l - 1][m] - b * p[l - 2][m]);
        }
    }
    p
}

/// Spheres are sampled from pyramid blocks at least this many times smaller
/// than their radius: the degrees kept (l < 16) only resolve features of
/// about 0.2 r, so a block average up to 0.1 r loses nothing they could see,
/// and it removes the aliasing of sampling a binary grid far sparser than
/// its voxels.
pub const BLOCKS_PER_RADIUS: f64 = 10.0;

/// Fractional bits of the fixed-point sample positions: block coordinates
/// stay below 2^15, and 1/65536 of a block is far below any precision that
/// matters, while integer floors and fractions vectorize where float-to-int
/// conversions do not.
const FIXED: u32 = 16;

/// Samples are processed in chunks: positions and weights in one pass, the
/// scattered reads in another, the interpolation in a third, so that the
/// arithmetic passes vectorize.
const CHUNK: usize = 64;

/// Where the samples of one sphere fall, bound to one solid's layout (arrays
/// of structures are split into one array per field, for vectorization).
pub struct SphereSampler {
    radius: f64,
    level: u32,
    /// Level 0: offset of the lower interpolation corner (voxels), the byte
    /// offset of its row, and the fractional position.
    off: [Vec<i32>; 3],
    row: Vec<i32>,
    frac: [Vec<f32>; 3],
    /// Level > 0: the sample directions times the radius, in blocks, fixed
    /// point with [`FIXED`] fractional bits.
    reach: [Vec<i32>; 3],
    /// How far a sample's cell corners can lie from the centre's cell, in
    /// cells of the level read (voxels, or blocks with the centre's offset
    /// within its block).
    cell_reach: i64,
    wpr: usize,
    plane: usize,
    dims: [usize; 3],
}

impl SphereSampler {
    /// The sampling pattern of a sphere of `radius` voxels on `solid`.
    pub fn new(radius: f64, solid: &Solid, backend: Backend) -> SphereSampler {
        let level = level_for_radius(radius, BLOCKS_PER_RADIUS);
        let grid = solid.bits();
        let dims = grid.dims();
        let wpr = grid.words_per_row();
        let mut s = SphereSampler {
            radius,
            level,
            off: Default::default(),
            row: Vec::new(),
            frac: Default::default(),
            reach: Default::default(),
            cell_reach: if level == 0 {
                radius.ceil() as i64 + 1
            } else {
                (radius / f64::from(1u32 << level)).ceil() as i64 + 2
            },
            wpr,
            plane: wpr * dims[1],
            dims,
        };
        let scale = f64::from(1u32 << level);
        for j in 0..RINGS {
            let (st, ct) = theta(j).sin_cos();
            for k in 0..SECTORS {
                let (sp, cp) = phi(k).sin_cos();
                let d = [st * cp * radius, st * sp * radius, ct * radius];
                if level > 0 {
                    for a in 0..3 {
                        s.reach[a].push((d[a] / scale * f64::from(1u32 << FIXED)).round() as i32);
                    }
                    continue;
                }
                let b = d.map(|c| c.floor());
                for a in 0..3 {
                    s.off[a].push(b[a] as i32);
                    s.frac[a].push((d[a] - b[a]) as f32);
                }
                let row_words = (b[2] as i64 * dims[1] as i64 + b[1] as i64) * wpr as i64;
                s.row.push(
                    i32::try_from(8 * row_words).expect("a sphere spans less than 2 GiB of grid"),
                );
            }
        }
        if level > 0 {
            solid.level(level, backend);
        }
        s
    }

    /// The radius in voxels.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The pyramid level it reads.
    pub fn level(&self) -> u32 {
        self.level
    }

    /// Samples the solid fraction on the sphere around voxel `v` of `solid`
    /// (the solid it was made for; outside the grid reads as empty).
    pub fn sample(&self, solid: &Solid, v: [u16; 3], out: &mut [f32; RINGS * SECTORS]) {
        if self.level > 0 {
            return self.sample_blocks(solid, v, out);
        }
        let grid = solid.bits();
        debug_assert_eq!(grid.dims(), self.dims);
        let c = v.map(|x| x as i64);
        let words = grid.words();
        let bytes: &[u8] = bytemuck::cast_slice(words);
        let base = (c[2] * self.dims[1] as i64 + c[1]) * self.wpr as i64;
        let (wpr, plane) = (self.wpr, self.plane);
        let (row_bytes, plane_bytes) = (8 * wpr, 8 * plane);
        // The lower corner must leave room for the upper one.
        let limit = self.dims.map(|d| d as u64 - 1);
        let inside_xy = spans_xy(c, self.cell_reach, self.dims);
        // Little-endian words laid out as bytes: bit x of a row is bit x % 8
        // of its byte x / 8, so two neighbours are one u16 read away. The
        // centre's byte, and its bit within it.
        let origin = 8 * base + (c[0] >> 3);
        let phase = (c[0] & 7) as i32;
        let mut code = [0u32; CHUNK];
        let mut byte = [0i32; CHUNK];
        let mut shift = [0u32; CHUNK];
        for start in (0..out.len()).step_by(CHUNK) {
            let z = c[2] + self.off[2][start] as i64;
            let reads = ring_reads(z, limit[2] as i64, inside_xy);
            if reads == RingReads::Empty {
                out[start..start + CHUNK].fill(0.0);
                continue;
            }
            if reads == RingReads::Unchecked && cfg!(target_endian = "little") {
                // Byte offsets and shifts in one vector pass, the reads in
                // another.
                for i in 0..CHUNK {
                    let x = phase + self.off[0][start + i];
                    byte[i] = self.row[start + i] + (x >> 3);
                    shift[i] = (x & 7) as u32;
                }
                for i in 0..CHUNK {
                    let cell =
                        &bytes[(origin + byte[i] as i64) as usize..][..plane_bytes + row_bytes + 2];
                    let at = |o: usize| {
                        ((u16::from_le_bytes([cell[o], cell[o + 1]]) >> shift[i]) & 3) as u32
                    };
                    code[i] = at(0)
                        | at(row_bytes) << 2
                        | at(plane_bytes) << 4
                        | at(plane_bytes + row_bytes) << 6;
                }
            } else {
                for i in 0..CHUNK {
                    let s = start + i;
                    let (x, y) = (c[0] + self.off[0][s] as i64, c[1] + self.off[1][s] as i64);
                    code[i] = if (x as u64) < limit[0]
                        && (y as u64) < limit[1]
                        && (z as u64) < limit[2]
                    {
                        let w = (base + self.row[s] as i64 / 8) as usize + (x >> 6) as usize;
                        let b = (x & 63) as u32;
                        pair(words, w, b)
                            | pair(words, w + wpr, b) << 2
                            | pair(words, w + plane, b) << 4
                            | pair(words, w + plane + wpr, b) << 6
                    } else {
                        corners_near_border(grid, x, y, z)
                    };
                }
            }
            let (fx, fy, fz) = (
                &self.frac[0][start..start + CHUNK],
                &self.frac[1][start..start + CHUNK],
                &self.frac[2][start..start + CHUNK],
            );
            for i in 0..CHUNK {
                let corner = |k: u32| ((code[i] >> k) & 1) as f32;
                out[start + i] = trilinear(
                    [
                        corner(0),
                        corner(1),
                        corner(2),
                        corner(3),
                        corner(4),
                        corner(5),
                        corner(6),
                        corner(7),
                    ],
                    [fx[i], fy[i], fz[i]],
                );
            }
        }
    }

    /// Level > 0: trilinear interpolation of block occupancy.
    fn sample_blocks(&self, solid: &Solid, v: [u16; 3], out: &mut [f32; RINGS * SECTORS]) {
        let level = solid.level(self.level, Backend::Serial);
        let s = 1i64 << self.level;
        let dims = level.dims();
        let occ = level.occupancy();
        let (row, plane) = (dims[0], dims[0] * dims[1]);
        // The voxel centre in block coordinates (block b's centre at b), fixed point.
        let one = 1i64 << FIXED;
        let centre = v.map(|c| {
            let c = c as i64;
            ((c >> self.level) * one + ((c & (s - 1)) * 2 - (s - 1)) * one / (2 * s)) as i32
        });
        let limit = dims.map(|d| d as u32 - 1);
        let mask = (one - 1) as i32;
        let scale = 1.0 / one as f32;
        let home = centre.map(|c| c >> FIXED);
        let reach = self.cell_reach as i32;
        let inside_xy = spans_xy(home.map(i64::from), self.cell_reach, dims);
        let mut at = [[0i32; CHUNK]; 3];
        let mut frac = [[0.0f32; CHUNK]; 3];
        let mut offset = [0u32; CHUNK];
        // Occupancy of the lower and upper corner along x, as two bytes.
        let mut pairs = [[0u16; CHUNK]; 4];
        for start in (0..out.len()).step_by(CHUNK) {
            for a in 0..3 {
                let reach = &self.reach[a][start..start + CHUNK];
                for i in 0..CHUNK {
                    let q = centre[a] + reach[i];
                    at[a][i] = q >> FIXED;
                    frac[a][i] = (q & mask) as f32 * scale;
                }
            }
            let z = at[2][0];
            let reads = ring_reads(z as i64, limit[2] as i64, inside_xy);
            if reads == RingReads::Unchecked {
                // Offsets from the lowest cell corner the ring can reach.
                let corner = [home[0] - reach, home[1] - reach];
                let first = (z as usize * dims[1] + corner[1] as usize) * row + corner[0] as usize;
                let ring = &occ[first..];
                for i in 0..CHUNK {
                    offset[i] =
                        ((at[1][i] - corner[1]) * row as i32 + (at[0][i] - corner[0])) as u32;
                }
                for i in 0..CHUNK {
                    cell_pairs(&ring[offset[i] as usize..], row, plane, &mut pairs, i);
                }
            } else if reads == RingReads::Empty {
                out[start..start + CHUNK].fill(0.0);
                continue;
            } else {
                for i in 0..CHUNK {
                    pairs_near_border(occ, dims, [at[0][i], at[1][i], z], &mut pairs, i);
                }
            }
            const NORM: f32 = 1.0 / 255.0;
            for i in 0..CHUNK {
                let c =
                    [0, 1, 2, 3].map(|k| [(pairs[k][i] & 0xff) as f32, (pairs[k][i] >> 8) as f32]);
                let c = [
                    c[0][0], c[0][1], c[1][0], c[1][1], c[2][0], c[2][1], c[3][0], c[3][1],
                ];
                out[start + i] = trilinear(c, [frac[0][i], frac[1][i], frac[2][i]]) * NORM;
            }
        }
    }
}

/// How one ring of a sphere (one z: a chunk) reads its cells.
#[derive(Clone, Copy, PartialEq, Eq)]
enum RingReads {
    /// Both planes of its cells lie above or below the grid: all empty.
    Empty,
    /// Inside the grid across x and y and both planes inside: no checks.
    Unchecked,
    /// Crossing a border: every sample checked.
    Checked,
}

/// The reads of a ring whose cells' lower plane is `z`, on a grid whose
/// last plane is `last`, for a sphere whose cells `inside_xy` or not.
fn ring_reads(z: i64, last: i64, inside_xy: bool) -> RingReads {
    if z < -1 || z > last {
        RingReads::Empty
    } else if inside_xy && (0..last).contains(&z) {
        RingReads::Unchecked
    } else {
        RingReads::Checked
    }
}

/// Whether every cell within `reach` of cell `centre` lies inside `dims`
/// across x and y (most spheres: the shared scenes are flat, so it is z
/// where spheres leave the grid, ring by ring).
fn spans_xy(centre: [i64; 3], reach: i64, dims: [usize; 3]) -> bool {
    (0..2).all(|a| centre[a] - reach >= 0 && centre[a] + reach < dims[a] as i64)
}

/// The corner pairs (x, x + 1) of the four rows of the cell starting at
/// `cell[0]`, as sample `i` of `pairs` (one bounds check for all eight).
#[inline(always)]
fn cell_pairs(cell: &[u8], row: usize, plane: usize, pairs: &mut [[u16; CHUNK]; 4], i: usize) {
    let cell = &cell[..plane + row + 2];
    pairs[0][i] = u16::from_le_bytes([cell[0], cell[1]]);
    pairs[1][i] = u16::from_le_bytes([cell[row], cell[row + 1]]);
    pairs[2][i] = u16::from_le_bytes([cell[plane], cell[plane + 1]]);
    pairs[3][i] = u16::from_le_bytes([cell[plane + row], cell[plane + row + 1]]);
}

/// The corner pairs of sample `i` at block `at` of a level with `dims`,
/// checked against the level's bounds (outside reads as empty).
fn pairs_near_border(
    occ: &[u8],
    dims: [usize; 3],
    at: [i32; 3],
    pairs: &mut [[u16; CHUNK]; 4],
    i: usize,
) {
    let (row, plane) = (dims[0], dims[0] * dims[1]);
    let limit = dims.map(|d| d as u32 - 1);
    let [x, y, z] = at;
    // Negative coordinates wrap to large unsigned ones and fail too.
    if (x as u32) < limit[0] && (y as u32) < limit[1] && (z as u32) < limit[2] {
        let b = (z as usize * dims[1] + y as usize) * row + x as usize;
        cell_pairs(&occ[b..], row, plane, pairs, i);
        return;
    }
    for (k, (dy, dz)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
        let mut pair = 0u16;
        for dx in 0..2 {
            let (x, y, z) = (x + dx, y + dy, z + dz);
            let inside = x >= 0
                && y >= 0
                && z >= 0
                && x as u32 <= limit[0]
                && y as u32 <= limit[1]
                && z as u32 <= limit[2];
            if inside {
                pair |= (occ[(z as usize * dims[1] + y as usize) * row + x as usize] as u16)
                    << (8 * dx);
            }
        }
        pairs[k][i] = pair;
    }
}

/// The eight corner bits of a sample whose cell crosses the grid's border.
#[cold]
fn corners_near_border(grid: &Grid, x: i64, y: i64, z: i64) -> u32 {
    let mut code = 0u32;
    for (i, (dy, dz)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
        for dx in 0..2 {
            if grid.get(x + dx, y + dy, z + dz) {
                code |= 1 << (2 * i as i64 + dx);
            }
        }
    }
    code
}

/// Bits b and b + 1 counted from word `i` (b + 1 may fall in the next word,
/// which always exists: the grid keeps a trailing word).
#[inline]
fn pair(words: &[u64], i: usize, b: u32) -> u32 {
    let v = words[i] as u128 | (words[i + 1] as u128) << 64;
    ((v >> b) & 3) as u32
}

/// Trilinear interpolation of corners ordered (x, x + 1) along x for the
/// rows (y, z), (y + 1, z), (y, z + 1), (y + 1, z + 1).
#[inline(always)]
fn trilinear(c: [f32; 8], f: [f32; 3]) -> f32 {
    let x00 = c[0] + (c[1] - c[0]) * f[0];
    let x10 = c[2] + (c[3] - c[2]) * f[0];
    let x01 = c[4] + (c[5] - c[4]) * f[0];
    let x11 = c[6] + (c[7] - c[6]) * f[0];
    let y0 = x00 + (x10 - x00) * f[1];
    let y1 = x01 + (x11 - x01) * f[1];
    y0 + (y1 - y0) * f[2]
}

/// The signature of one voxel on one sphere (`sampler` made for `solid`).
pub fn describe_sphere(
    solid: &Solid,
    v: [u16; 3],
    sampler: &SphereSampler,
    transform: &SphericalTransform,
) -> Signature {
    let mut samples = [0.0f32; RINGS * SECTORS];
    sampler.sample(solid, v, &mut samples);
    transform.signature(&samples)
}

/// Candidates sampled to choose the order of the spheres.
pub const ORDER_SAMPLE: usize = 64;

/// The harmonics stage of the cascade: rejects a point once the L2 distance
/// between its signatures and the template's, over the spheres so far, passes
/// the threshold.
pub struct HarmonicsDescriptor<'a> {
    solid: &'a Solid,
    points: &'a [[u16; 3]],
    transform: &'a SphericalTransform,
    spheres: Vec<SphereSampler>,
    radii: Vec<f64>,
    /// (R_j / voxel)^2 / k: see the module doc.
    weights: Vec<f64>,
    clutter: Option<ClutterGuard<'a>>,
    /// Leading spheres that always count (see [`super::clutter`]).
    clean_layers: usize,
    template: Vec<Signature>,
    threshold: f64,
}

impl<'a> HarmonicsDescriptor<'a> {
    /// A stage over candidate voxels `points` of the scene `solid`, with the
    /// template's signatures at the same radii (world units).
    pub fn new(
        solid: &'a Solid,
        points: &'a [[u16; 3]],
        transform: &'a SphericalTransform,
        radii: &[f64],
        template: Vec<Signature>,
        threshold: f64,
        backend: Backend,
    ) -> Self {
        let voxel = solid.bits().spec().voxel_size;
        HarmonicsDescriptor {
            solid,
            points,
            transform,
            spheres: radii
                .iter()
                .map(|r| SphereSampler::new(r / voxel, solid, backend))
                .collect(),
            radii: radii.to_vec(),
            weights: radii
                .iter()
                .map(|r| (r / voxel).powi(2) / radii.len() as f64)
                .collect(),
            clutter: None,
            clean_layers: usize::MAX,
            template,
            threshold,
        }
    }

    /// Excuses cluttered spheres (see [`super::clutter`]); without a guard
    /// every sphere counts.
    pub fn with_clutter(mut self, guard: ClutterGuard<'a>) -> Self {
        let voxel = self.solid.bits().spec().voxel_size;
        let radii_voxels: Vec<f64> = self.radii.iter().map(|r| r / voxel).collect();
        self.clean_layers = guard.policy.clean_layers(&radii_voxels);
        self.clutter = Some(guard);
        self
    }

    /// The signatures of one voxel of any solid at `radii` (world units):
    /// what the template side computes.
    pub fn describe(
        solid: &Solid,
        v: [u16; 3],
        radii: &[f64],
        transform: &SphericalTransform,
        backend: Backend,
    ) -> Vec<Signature> {
        let voxel = solid.bits().spec().voxel_size;
        radii
            .iter()
            .map(|r| {
                describe_sphere(
                    solid,
                    v,
                    &SphereSampler::new(r / voxel, solid, backend),
                    transform,
                )
            })
            .collect()
    }
}

/// What the harmonics stage needs to recognize clutter: the volume balls at
/// its radii (bound to the scene) with the template's fractions, and the
/// policy.
pub struct ClutterGuard<'a> {
    /// The policy.
    pub policy: ClutterPolicy,
    /// Balls at the stage's radii, bound to the scene's solid.
    pub balls: &'a [Ball],
    /// The template's solid fraction at each radius.
    pub template: &'a [f64],
}

/// The running state of a point in the harmonics stage.
#[derive(Clone, Copy, Debug, Default)]
pub struct HarmonicsState {
    /// Weighted squared differences of the spheres compared so far.
    sum2: f64,
    /// The first cluttered sphere met: it and the larger ones are not
    /// compared, and the point is judged over the spheres inside it.
    excused_at: Option<usize>,
}

impl OnionDescriptor for HarmonicsDescriptor<'_> {
    type State = HarmonicsState;

    fn name(&self) -> &'static str {
        "harmonics"
    }

    fn layers(&self) -> usize {
        self.spheres.len()
    }

    fn radius(&self, layer: usize) -> f64 {
        self.radii[layer]
    }

    fn threshold(&self) -> f64 {
        self.threshold
    }

    /// The selective order ([`ClutterPolicy::selective_order`]) with the
    /// lead that passes fewer of [`ORDER_SAMPLE`] candidates spread over the
    /// list (an excused sphere passes): about 130 spheres to save thousands
    /// where the scene favours the other lead. Only speed depends on it.
    fn order(&self, candidates: &[u32], backend: Backend) -> Vec<usize> {
        let (clean, k) = (
            self.clean_layers.min(self.spheres.len()),
            self.spheres.len(),
        );
        let excusable_first = (1..k).contains(&clean) && {
            let sample: Vec<u32> = candidates
                .iter()
                .step_by((candidates.len() / ORDER_SAMPLE).max(1))
                .copied()
                .collect();
            let passes = backend.map(sample.len(), |i| {
                let p = sample[i];
                let pass = |layer| self.extend(p, layer, &mut self.start(p)) <= self.threshold;
                [pass(clean - 1), pass(clean)]
            });
            let count = |lead: usize| passes.iter().filter(|p| p[lead]).count();
            count(1) < count(0)
        };
        ClutterPolicy::selective_order(clean, k, excusable_first)
    }

    fn start(&self, _point: u32) -> HarmonicsState {
        HarmonicsState::default()
    }

    fn extend(&self, point: u32, layer: usize, state: &mut HarmonicsState) -> f64 {
        let excusable = layer >= self.clean_layers;
        // Excusable spheres come outward: this one lies beyond the first
        // cluttered sphere and is not compared.
        if excusable && state.excused_at.is_some() {
            return state.sum2.sqrt();
        }
        let v = self.points[point as usize];
        let guard = self.clutter.as_ref().filter(|_| excusable);
        let cluttered_ball = guard.is_some_and(|g| {
            g.balls[layer].fraction(self.solid, v) - g.template[layer] > g.policy.volume_tolerance
        });
        // Degree 0 of the signature is the sphere's mean occupancy.
        let sig = (!cluttered_ball)
            .then(|| describe_sphere(self.solid, v, &self.spheres[layer], self.transform));
        let cluttered = cluttered_ball
            || guard.is_some_and(|g| {
                sig.is_some_and(|s| {
                    (s[0] - self.template[layer][0]) as f64 > g.policy.sphere_tolerance
                })
            });
        match sig {
            Some(sig) if !cluttered => {
                state.sum2 +=
                    self.weights[layer] * signature_distance2(&sig, &self.template[layer]);
            }
            _ => state.excused_at = Some(layer),
        }
        // Compared over the `e` spheres inside the first cluttered one only:
        // their root mean square must meet the threshold (the weights carry
        // 1 / k). The spheres inside it still to come only add to the sum.
        let budget = match state.excused_at {
            Some(e) => self.threshold.powi(2) * e as f64 / self.spheres.len() as f64,
            None => self.threshold.powi(2),
        };
        if state.sum2 > budget {
            f64::INFINITY
        } else {
            state.sum2.sqrt()
        }
    }
}

/// Squared L2 distance between two signatures.
pub fn signature_distance2(a: &Signature, b: &Signature) -> f64 {
    a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum()
}

#[cfg(test)]
mod tests;
