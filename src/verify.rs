//! Verification: does the template, placed at a matched point with a proper
//! rotation, occupy the same space as the scene there?
//!
//! The onion descriptors are invariant to rotations, which is what makes them
//! fast, but also to reflections, and they summarize a ball by a few numbers.
//! So a point of a mirror-symmetric template and its mirror twin look the
//! same (the flank of a cow and the other flank), and so can two merely
//! similar parts. The cascade cannot tell; the template's actual placement
//! can. For each candidate point, the solid in the ball around it gives a
//! frame (centroid and principal axes of its second moments, from a coarse
//! pyramid level), and so does the template's ball: aligning the two fixes
//! the pose up to the signs of the axes. Of the four sign choices that make a
//! proper rotation, the one whose placed template best overlaps the scene is
//! kept; the overlap (an intersection over union estimated from samples of
//! the template's ball) is the score, and the pose tells where the
//! template's own point c_T lands. That is where the instance is reported: a
//! mirror twin of c_T, or any other point of the same object, implies the
//! same placement, since a proper rotation cannot turn the object into its
//! mirror image. Aligning centroids rather than the candidate points also
//! absorbs the voxel or two by which the best candidate misses c_T, which on
//! thin templates would otherwise cost much of the overlap.

use crate::descriptor::volume::Ball;
use crate::exec::Backend;
use crate::math::{Vec3, symmetric_eigen};
use crate::voxel::{Solid, level_for_radius};

/// Samples of each kind (solid, empty) taken from the template's ball.
const SAMPLES: usize = 4096;

/// Blocks per radius for the moments.
const MOMENT_BLOCKS: f64 = 10.0;

/// Scores closer than this are a tie between placements.
const TIE: f64 = 0.02;

/// The local frame of the solid around a point: its centroid (relative to
/// the point, in voxels) and principal axes.
#[derive(Clone, Copy, Debug)]
struct Frame {
    centroid: Vec3,
    axes: [Vec3; 3],
    values: [f64; 3],
}

/// A template prepared for verification.
pub struct Verifier {
    ball: Ball,
    frame: Frame,
    solid: Vec<Vec3>,
    empty: Vec<Vec3>,
    /// Share of the template's ball that is solid.
    solid_share: f64,
    /// c_T relative to the anchor, in voxels.
    target: Vec3,
}

/// The outcome of one check.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Intersection over union of template and scene in the template's ball.
    pub score: f64,
    /// Share of the template's solid that the scene covers.
    pub covered: f64,
    /// Rotation from template to scene (rows).
    pub rotation: [Vec3; 3],
    /// Where the template's point c_T lands, relative to the checked voxel
    /// (in voxels).
    pub offset: Vec3,
}

impl Verifier {
    /// Prepares the template whose descriptors are taken at voxel `anchor` of
    /// `solid`, over a ball of `radius` voxels.
    /// `target` is the template's point c_T relative to the anchor's centre
    /// (voxels): placements report where it lands.
    pub fn new(
        solid: &Solid,
        anchor: [u16; 3],
        target: Vec3,
        radius: f64,
        backend: Backend,
    ) -> Verifier {
        let ball = Ball::at_level(radius, level_for_radius(radius, MOMENT_BLOCKS).max(1))
            .bind(solid, backend);
        let frame = local_frame(&ball, solid, anchor);
        // A sub-lattice of the ball, fine enough for about SAMPLES points of
        // each kind: sampling beats scanning millions of voxels.
        let volume = 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
        let step = ((volume / (2 * SAMPLES) as f64).cbrt().floor() as i64).max(1);
        let (mut solid_pts, mut empty_pts) = (Vec::new(), Vec::new());
        let e = radius.floor() as i64 / step * step;
        let bits = solid.bits();
        for dz in (-e..=e).step_by(step as usize) {
            for dy in (-e..=e).step_by(step as usize) {
                for dx in (-e..=e).step_by(step as usize) {
                    if ((dx * dx + dy * dy + dz * dz) as f64) > radius * radius {
                        continue;
                    }
                    let v = Vec3::new(dx as f64, dy as f64, dz as f64);
                    if bits.get(
                        anchor[0] as i64 + dx,
                        anchor[1] as i64 + dy,
                        anchor[2] as i64 + dz,
                    ) {
                        solid_pts.push(v);
                    } else {
                        empty_pts.push(v);
                    }
                }
            }
        }
        let solid_share =
            solid_pts.len() as f64 / (solid_pts.len() + empty_pts.len()).max(1) as f64;
        Verifier {
            ball,
            frame,
            solid: spread(solid_pts),
            empty: spread(empty_pts),
            solid_share,
            target,
        }
    }

    /// Places the template at voxel `v` of the scene `solid` (which the
    /// verifier's ball must be usable with: same voxel size) and scores it.
    pub fn check(&self, solid: &Solid, v: [u16; 3]) -> Placement {
        let frame = local_frame(&self.ball, solid, v);
        let bits = solid.bits();
        let t = &self.frame.axes;
        let s = &frame.axes;
        let handed = det(t) * det(s);
        let mut best: Option<Placement> = None;
        // Axis signs whose product makes det(R) = +1.
        for signs in [
            [1.0, 1.0, 1.0],
            [1.0, -1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
        ] {
            let signs = signs.map(|x: f64| x * handed.signum());
            // R = sum_i s_i scene_axis_i template_axis_i^T, as rows.
            let mut rows = [Vec3::ZERO; 3];
            for r in 0..3 {
                rows[r] = (0..3).fold(Vec3::ZERO, |acc, i| acc + t[i] * (signs[i] * s[i][r]));
            }
            // Centroids coincide: q = c_S + R (a - c_T).
            let shift = frame.centroid
                - Vec3::new(
                    rows[0].dot(self.frame.centroid),
                    rows[1].dot(self.frame.centroid),
                    rows[2].dot(self.frame.centroid),
                );
            let hit = |pts: &[Vec3]| {
                pts.iter()
                    .filter(|a| {
                        let q = [
                            rows[0].dot(**a) + shift.x,
                            rows[1].dot(**a) + shift.y,
                            rows[2].dot(**a) + shift.z,
                        ];
                        bits.get(
                            v[0] as i64 + q[0].round() as i64,
                            v[1] as i64 + q[1].round() as i64,
                            v[2] as i64 + q[2].round() as i64,
                        )
                    })
                    .count() as f64
            };
            let covered = hit(&self.solid) / self.solid.len().max(1) as f64;
            let extra = hit(&self.empty) / self.empty.len().max(1) as f64;
            let inter = self.solid_share * covered;
            let union = self.solid_share + (1.0 - self.solid_share) * extra;
            let score = if union > 0.0 { inter / union } else { 0.0 };
            // Near-ties (a template symmetric under a rotation): keep the
            // placement that moves the candidate least.
            let better = match best {
                None => true,
                Some(b) if (score - b.score).abs() <= TIE => {
                    shift.norm() < (b.offset - self.rotate_target(&b.rotation)).norm()
                }
                Some(b) => score > b.score,
            };
            if better {
                best = Some(Placement {
                    score,
                    covered,
                    rotation: rows,
                    offset: shift
                        + Vec3::new(
                            rows[0].dot(self.target),
                            rows[1].dot(self.target),
                            rows[2].dot(self.target),
                        ),
                });
            }
        }
        best.expect("four candidates")
    }

    fn rotate_target(&self, rows: &[Vec3; 3]) -> Vec3 {
        Vec3::new(
            rows[0].dot(self.target),
            rows[1].dot(self.target),
            rows[2].dot(self.target),
        )
    }

    /// Eigenvalues of the template's local second moments (descending): how
    /// well its frame is defined.
    pub fn moment_values(&self) -> [f64; 3] {
        self.frame.values
    }
}

fn det(a: &[Vec3; 3]) -> f64 {
    a[0].dot(a[1].cross(a[2]))
}

/// Centroid and central second moments of the solid in the ball around
/// voxel `v`, from the ball's blocks.
fn local_frame(ball: &Ball, solid: &Solid, v: [u16; 3]) -> Frame {
    let mut mass = 0.0;
    let mut first = Vec3::ZERO;
    let mut m = [[0.0f64; 3]; 3];
    ball.for_each_block(solid, v, |o, n| {
        let w = n as f64;
        mass += w;
        first += o * w;
        let o = [o.x, o.y, o.z];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += w * o[i] * o[j];
            }
        }
    });
    let centroid = if mass > 0.0 {
        first * (1.0 / mass)
    } else {
        Vec3::ZERO
    };
    let c = [centroid.x, centroid.y, centroid.z];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] -= mass * c[i] * c[j];
        }
    }
    let (values, axes) = symmetric_eigen(m);
    Frame {
        centroid,
        axes,
        values,
    }
}

/// At most [`SAMPLES`] points spread evenly over the list (deterministic).
fn spread(points: Vec<Vec3>) -> Vec<Vec3> {
    if points.len() <= SAMPLES {
        return points;
    }
    let step = points.len() as f64 / SAMPLES as f64;
    (0..SAMPLES)
        .map(|i| points[(i as f64 * step) as usize])
        .collect()
}
