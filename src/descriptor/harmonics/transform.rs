//! The spherical harmonics transform of one sphere's samples: a DFT per
//! ring, Fejer's quadrature against normalized associated Legendre
//! functions, and the per-degree energies.

use super::{
    ALTERNATING, BANDWIDTH, DEGREES, HALF_ORDERS, HALF_RINGS, HALF_SECTORS, PARITY_LANES,
    QUARTER_SECTORS, RINGS, SECTORS, Signature,
};
use std::f64::consts::PI;

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
    /// [`Self::ring_coefficients`] of a ring of zeros and of a ring of ones.
    empty_ring: [[f32; HALF_ORDERS]; 4],
    full_ring: [[f32; HALF_ORDERS]; 4],
}

/// A ring whose samples are all 0 or all 1.
enum Uniform {
    Empty,
    Full,
}

/// Whether every sample of `ring` is 0 (+0.0, as the samplers write it) or
/// every one is 1. Folded over bits, not short-circuited, so that it
/// vectorizes.
fn uniform(ring: &[f32; SECTORS]) -> Option<Uniform> {
    let one = 1.0f32.to_bits();
    let (any, all_one) = ring.iter().fold((0u32, true), |(any, all_one), &x| {
        (any | x.to_bits(), all_one & (x.to_bits() == one))
    });
    if any == 0 {
        Some(Uniform::Empty)
    } else if all_one {
        Some(Uniform::Full)
    } else {
        None
    }
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
            empty_ring: [[0.0; HALF_ORDERS]; 4],
            full_ring: [[0.0; HALF_ORDERS]; 4],
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
        t.empty_ring = t.ring_coefficients(&[0.0; SECTORS]);
        t.full_ring = t.ring_coefficients(&[1.0; SECTORS]);
        t
    }

    /// The per-degree energies of samples `f[j * SECTORS + k]` taken at
    /// (theta_j, phi_k), normalized as the module doc says.
    pub fn signature(&self, f: &[f32; RINGS * SECTORS]) -> Signature {
        self.signature_of(f, true)
    }

    /// [`Self::signature`] with every ring transformed, uniform or not: what
    /// the cached rings must reproduce bit for bit.
    #[cfg(test)]
    pub(super) fn signature_of_every_ring(&self, f: &[f32; RINGS * SECTORS]) -> Signature {
        self.signature_of(f, false)
    }

    fn signature_of(&self, f: &[f32; RINGS * SECTORS], cached_rings: bool) -> Signature {
        // Fourier coefficients per ring for m < L. Most rings of a sphere
        // on a sheet or a large solid lie wholly outside or inside it: those
        // take the coefficients of an empty or a full ring, computed once
        // the same way.
        let mut coefficients = [[[0.0f32; HALF_ORDERS]; 4]; RINGS];
        for (j, acc) in coefficients.iter_mut().enumerate() {
            let ring: &[f32; SECTORS] = f[j * SECTORS..(j + 1) * SECTORS]
                .try_into()
                .expect("a ring is SECTORS samples");
            *acc = match uniform(ring).filter(|_| cached_rings) {
                Some(Uniform::Empty) => self.empty_ring,
                Some(Uniform::Full) => self.full_ring,
                None => self.ring_coefficients(ring),
            };
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

    /// The Fourier coefficients of one ring for m < L. phi + pi: even orders
    /// see g = f(phi) + f(phi + pi), odd ones h = the difference. Then
    /// pi - phi: cos(m (pi - phi)) = (-1)^m cos(m phi) and
    /// sin(m (pi - phi)) = -(-1)^m sin(m phi), so each order reads the sum or
    /// the difference of g (or h) at k and HALF_SECTORS - k. Sectors 0 and
    /// QUARTER_SECTORS pair with themselves: they start the sums, with
    /// cos(m pi / 2) and sin(m pi / 2) = (-1)^i or 0. `[a][i]`: accumulator
    /// a (even re, even im, odd re, odd im), order 2i or 2i + 1; stored as
    /// accumulated, so that the products vectorize over i.
    fn ring_coefficients(&self, ring: &[f32; SECTORS]) -> [[f32; HALF_ORDERS]; 4] {
        let g = |k: usize| ring[k] + ring[k + HALF_SECTORS];
        let h = |k: usize| ring[k] - ring[k + HALF_SECTORS];
        let (g0, gq, h0, hq) = (g(0), g(QUARTER_SECTORS), h(0), h(QUARTER_SECTORS));
        let mut acc = [
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
        acc
    }
}

/// The transform's tables unfolded, for a kernel that sums every ring and
/// sector plainly (the GPU's): `fourier[k * DEGREES + m]` = (cos m phi_k,
/// -sin m phi_k) for every sector, and `legendre[(m * DEGREES + l) * RINGS +
/// j]` = the quadrature weight times the normalized Legendre value for every
/// ring (0 for l < m). Computed in f64 like [`SphericalTransform`]'s.
#[cfg(any(feature = "gpu", feature = "internals"))]
pub fn unfolded_tables() -> (Vec<[f32; 2]>, Vec<f32>) {
    let mut fourier = Vec::with_capacity(SECTORS * DEGREES);
    for k in 0..SECTORS {
        for m in 0..DEGREES {
            let (s, c) = (m as f64 * phi(k)).sin_cos();
            fourier.push([c as f32, -s as f32]);
        }
    }
    let weights = fejer_weights();
    let rings: Vec<Vec<Vec<f64>>> = (0..RINGS)
        .map(|j| normalized_legendre(theta(j).cos()))
        .collect();
    let mut legendre = vec![0.0f32; DEGREES * DEGREES * RINGS];
    for m in 0..DEGREES {
        for l in m..DEGREES {
            for j in 0..RINGS {
                let w = weights[j] * (2.0 * PI / SECTORS as f64);
                legendre[(m * DEGREES + l) * RINGS + j] = (w * rings[j][l][m]) as f32;
            }
        }
    }
    (fourier, legendre)
}

pub(super) fn theta(j: usize) -> f64 {
    PI * (2 * j + 1) as f64 / (4 * BANDWIDTH) as f64
}

pub(super) fn phi(k: usize) -> f64 {
    PI * k as f64 / BANDWIDTH as f64
}

/// Fejer's first rule on the nodes cos(theta_j): exact for polynomials of
/// degree < RINGS in x = cos theta over [-1, 1].
pub(super) fn fejer_weights() -> [f64; RINGS] {
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
pub(super) fn normalized_legendre(x: f64) -> Vec<Vec<f64>> {
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
