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
//! - Normalization: `s_l = ||f_l|| / sqrt(4 pi)`. By Parseval,
//!   `sum_l s_l^2` is the mean of f^2 over the sphere, at most 1 (a sphere
//!   wholly inside the solid gives s_0 = 1 and nothing else). The values do
//!   not depend on the radius, the voxel size or the scene, so one distance
//!   threshold serves every sphere and every scene; the running distance is
//!   the L2 norm over all spheres so far (monotonic in the layer).

use super::OnionDescriptor;
use crate::voxel::Grid;
use std::f64::consts::PI;

/// Bandwidth: 2B x 2B samples per sphere.
pub const BANDWIDTH: usize = 32;
/// Degrees kept: l < L.
pub const DEGREES: usize = 16;

const RINGS: usize = 2 * BANDWIDTH;
const HALF_RINGS: usize = BANDWIDTH;
const SECTORS: usize = 2 * BANDWIDTH;
const HALF_SECTORS: usize = BANDWIDTH;

/// The per-degree energies of one sphere.
pub type Signature = [f32; DEGREES];

/// Orders with even and odd m: the phi + pi fold treats them apart.
const HALF_ORDERS: usize = DEGREES / 2;

/// Precomputed tables for the transform (independent of radius and grid).
///
/// The loops below keep their innermost index over independent
/// accumulators (orders m, then degrees l) so that they vectorize.
pub struct SphericalTransform {
    /// cos(m phi_k) and sin(m phi_k) for k < SECTORS / 2, m = 2i (even) or
    /// 2i + 1 (odd): `[k][i]`.
    cos_even: [[f32; HALF_ORDERS]; HALF_SECTORS],
    sin_even: [[f32; HALF_ORDERS]; HALF_SECTORS],
    cos_odd: [[f32; HALF_ORDERS]; HALF_SECTORS],
    sin_odd: [[f32; HALF_ORDERS]; HALF_SECTORS],
    /// Quadrature weight x normalized Legendre value, `[m][j][l]` for the
    /// northern rings j < RINGS / 2 (southern ones fold in by parity); zero
    /// for l < m.
    legendre: Vec<[[f32; DEGREES]; HALF_RINGS]>,
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
            cos_even: [[0.0; HALF_ORDERS]; HALF_SECTORS],
            sin_even: [[0.0; HALF_ORDERS]; HALF_SECTORS],
            cos_odd: [[0.0; HALF_ORDERS]; HALF_SECTORS],
            sin_odd: [[0.0; HALF_ORDERS]; HALF_SECTORS],
            legendre: vec![[[0.0; DEGREES]; HALF_RINGS]; DEGREES],
        };
        for k in 0..HALF_SECTORS {
            for i in 0..HALF_ORDERS {
                let (se, ce) = ((2 * i) as f64 * phi(k)).sin_cos();
                let (so, co) = ((2 * i + 1) as f64 * phi(k)).sin_cos();
                t.cos_even[k][i] = ce as f32;
                t.sin_even[k][i] = se as f32;
                t.cos_odd[k][i] = co as f32;
                t.sin_odd[k][i] = so as f32;
            }
        }
        let weights = fejer_weights();
        for j in 0..HALF_RINGS {
            let p = normalized_legendre(theta(j).cos());
            let w = weights[j] * (2.0 * PI / SECTORS as f64);
            for m in 0..DEGREES {
                for l in m..DEGREES {
                    t.legendre[m][j][l] = (w * p[l][m]) as f32;
                }
            }
        }
        t
    }

    /// The per-degree energies of samples `f[j * SECTORS + k]` taken at
    /// (theta_j, phi_k), normalized as the module doc says.
    pub fn signature(&self, f: &[f32; RINGS * SECTORS]) -> Signature {
        // Fourier coefficients per ring for m < L, folding phi and phi + pi:
        // even orders see f(phi) + f(phi + pi), odd ones the difference.
        let mut re = [[0.0f32; DEGREES]; RINGS];
        let mut im = [[0.0f32; DEGREES]; RINGS];
        for j in 0..RINGS {
            let ring = &f[j * SECTORS..(j + 1) * SECTORS];
            let (mut er, mut ei) = ([0.0f32; HALF_ORDERS], [0.0f32; HALF_ORDERS]);
            let (mut or, mut oi) = ([0.0f32; HALF_ORDERS], [0.0f32; HALF_ORDERS]);
            for k in 0..HALF_SECTORS {
                let sum = ring[k] + ring[k + HALF_SECTORS];
                let diff = ring[k] - ring[k + HALF_SECTORS];
                for i in 0..HALF_ORDERS {
                    er[i] += sum * self.cos_even[k][i];
                    ei[i] -= sum * self.sin_even[k][i];
                    or[i] += diff * self.cos_odd[k][i];
                    oi[i] -= diff * self.sin_odd[k][i];
                }
            }
            for i in 0..HALF_ORDERS {
                re[j][2 * i] = er[i];
                im[j][2 * i] = ei[i];
                re[j][2 * i + 1] = or[i];
                im[j][2 * i + 1] = oi[i];
            }
        }
        // Legendre step, folding theta and pi - theta: P_l^m is even or odd
        // in cos theta as l + m is.
        let mut energy = [0.0f64; DEGREES];
        for m in 0..DEGREES {
            let (mut ar_e, mut ai_e) = ([0.0f32; DEGREES], [0.0f32; DEGREES]);
            let (mut ar_o, mut ai_o) = ([0.0f32; DEGREES], [0.0f32; DEGREES]);
            for j in 0..HALF_RINGS {
                let s = RINGS - 1 - j;
                let (sr, si) = (re[j][m] + re[s][m], im[j][m] + im[s][m]);
                let (dr, di) = (re[j][m] - re[s][m], im[j][m] - im[s][m]);
                let table = &self.legendre[m][j];
                for l in 0..DEGREES {
                    ar_e[l] += table[l] * sr;
                    ai_e[l] += table[l] * si;
                    ar_o[l] += table[l] * dr;
                    ai_o[l] += table[l] * di;
                }
            }
            for l in m..DEGREES {
                let (a, b) = if (l + m) % 2 == 0 {
                    (ar_e[l], ai_e[l])
                } else {
                    (ar_o[l], ai_o[l])
                };
                let e = (a as f64) * (a as f64) + (b as f64) * (b as f64);
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

/// Where the samples of one sphere fall relative to a voxel centre: integer
/// offset of the lower interpolation corner and the fractional position,
/// bound to one grid's layout so that a sample costs an add and four reads.
pub struct SphereSampler {
    radius: f64,
    /// Word offset of the lower corner's row (y, z) from the centre's row.
    row: Vec<i64>,
    /// Offsets in voxels, for samples near the grid border.
    offset: Vec<[i32; 3]>,
    frac: Vec<[f32; 3]>,
    reach: i64,
    /// Words per row and per z plane of the bound grid.
    wpr: usize,
    plane: usize,
    dims: [usize; 3],
}

impl SphereSampler {
    /// The sampling pattern of a sphere of `radius` voxels on `grid`.
    pub fn new(radius: f64, grid: &Grid) -> SphereSampler {
        let dims = grid.dims();
        let wpr = grid.words_per_row();
        let mut s = SphereSampler {
            radius,
            row: Vec::with_capacity(RINGS * SECTORS),
            offset: Vec::with_capacity(RINGS * SECTORS),
            frac: Vec::with_capacity(RINGS * SECTORS),
            reach: radius.ceil() as i64 + 1,
            wpr,
            plane: wpr * dims[1],
            dims,
        };
        for j in 0..RINGS {
            let (st, ct) = theta(j).sin_cos();
            for k in 0..SECTORS {
                let (sp, cp) = phi(k).sin_cos();
                let d = [st * cp * radius, st * sp * radius, ct * radius];
                let b = d.map(|c| c.floor());
                let o = [b[0] as i32, b[1] as i32, b[2] as i32];
                s.row
                    .push((o[2] as i64 * dims[1] as i64 + o[1] as i64) * wpr as i64);
                s.offset.push(o);
                s.frac.push([
                    (d[0] - b[0]) as f32,
                    (d[1] - b[1]) as f32,
                    (d[2] - b[2]) as f32,
                ]);
            }
        }
        s
    }

    /// The radius in voxels.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Samples the solid on the sphere around voxel `v` of `grid` (the grid
    /// it was made for; voxels outside the grid read as empty).
    pub fn sample(&self, grid: &Grid, v: [u16; 3], out: &mut [f32; RINGS * SECTORS]) {
        debug_assert_eq!(grid.dims(), self.dims);
        let c = v.map(|x| x as i64);
        let words = grid.words();
        let base = (c[2] * self.dims[1] as i64 + c[1]) * self.wpr as i64;
        let (wpr, plane) = (self.wpr, self.plane);
        // The lower corner must leave room for the upper one.
        let limit = self.dims.map(|d| d as u64 - 1);
        let whole =
            (0..3).all(|a| c[a] - self.reach >= 0 && c[a] + self.reach < self.dims[a] as i64);
        for (s, o) in out.iter_mut().enumerate() {
            let d = self.offset[s];
            let (x, y, z) = (c[0] + d[0] as i64, c[1] + d[1] as i64, c[2] + d[2] as i64);
            let code = if whole
                || ((x as u64) < limit[0] && (y as u64) < limit[1] && (z as u64) < limit[2])
            {
                let i = (base + self.row[s]) as usize + (x >> 6) as usize;
                let b = (x & 63) as u32;
                pair(words, i, b)
                    | pair(words, i + wpr, b) << 2
                    | pair(words, i + plane, b) << 4
                    | pair(words, i + plane + wpr, b) << 6
            } else {
                corners_near_border(grid, x, y, z)
            };
            *o = match code {
                0 => 0.0,
                255 => 1.0,
                _ => trilinear(code, self.frac[s]),
            };
        }
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

/// Interpolates the eight corner bits of `code` (pairs along x for rows
/// (y, z), (y + 1, z), (y, z + 1), (y + 1, z + 1)).
#[inline]
fn trilinear(code: u32, f: [f32; 3]) -> f32 {
    let along_x = |pair: u32| {
        let a = (pair & 1) as f32;
        let b = ((pair >> 1) & 1) as f32;
        a + (b - a) * f[0]
    };
    let v00 = along_x(code & 3);
    let v10 = along_x((code >> 2) & 3);
    let v01 = along_x((code >> 4) & 3);
    let v11 = along_x((code >> 6) & 3);
    let v0 = v00 + (v10 - v00) * f[1];
    let v1 = v01 + (v11 - v01) * f[1];
    v0 + (v1 - v0) * f[2]
}

/// The signature of one voxel on one sphere (`sampler` made for `grid`).
pub fn describe_sphere(
    grid: &Grid,
    v: [u16; 3],
    sampler: &SphereSampler,
    transform: &SphericalTransform,
) -> Signature {
    let mut samples = [0.0f32; RINGS * SECTORS];
    sampler.sample(grid, v, &mut samples);
    transform.signature(&samples)
}

/// The harmonics stage of the cascade: rejects a point once the L2 distance
/// between its signatures and the template's, over the spheres so far, passes
/// the threshold.
pub struct HarmonicsDescriptor<'a> {
    grid: &'a Grid,
    points: &'a [[u16; 3]],
    transform: &'a SphericalTransform,
    spheres: Vec<SphereSampler>,
    radii: Vec<f64>,
    template: Vec<Signature>,
    threshold: f64,
}

impl<'a> HarmonicsDescriptor<'a> {
    /// A stage over candidate voxels `points` of the scene `grid`, with the
    /// template's signatures at the same radii (world units).
    pub fn new(
        grid: &'a Grid,
        points: &'a [[u16; 3]],
        transform: &'a SphericalTransform,
        radii: &[f64],
        template: Vec<Signature>,
        threshold: f64,
    ) -> Self {
        let voxel = grid.spec().voxel_size;
        HarmonicsDescriptor {
            grid,
            points,
            transform,
            spheres: radii
                .iter()
                .map(|r| SphereSampler::new(r / voxel, grid))
                .collect(),
            radii: radii.to_vec(),
            template,
            threshold,
        }
    }

    /// The signatures of one voxel of any grid at `radii` (world units): what
    /// the template side computes.
    pub fn describe(
        grid: &Grid,
        v: [u16; 3],
        radii: &[f64],
        transform: &SphericalTransform,
    ) -> Vec<Signature> {
        let voxel = grid.spec().voxel_size;
        radii
            .iter()
            .map(|r| describe_sphere(grid, v, &SphereSampler::new(r / voxel, grid), transform))
            .collect()
    }
}

impl OnionDescriptor for HarmonicsDescriptor<'_> {
    type State = f64;

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

    fn start(&self, _point: u32) -> f64 {
        0.0
    }

    fn extend(&self, point: u32, layer: usize, sum2: &mut f64) -> f64 {
        let sig = describe_sphere(
            self.grid,
            self.points[point as usize],
            &self.spheres[layer],
            self.transform,
        );
        *sum2 += signature_distance2(&sig, &self.template[layer]);
        sum2.sqrt()
    }
}

/// Squared L2 distance between two signatures.
pub fn signature_distance2(a: &Signature, b: &Signature) -> f64 {
    a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum()
}

#[cfg(test)]
mod tests;
