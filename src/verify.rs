//! Verification: does the template, placed at a matched point with a proper
//! rotation, occupy the same space as the scene there?
//!
//! The onion descriptors are invariant to rotations, which is what makes them
//! fast, but also to reflections, and they summarize a ball by a few numbers.
//! So a point of a mirror-symmetric template and its mirror twin look the
//! same (the flank of a cow and the other flank), and so can two merely
//! similar parts. The cascade cannot tell; the template's actual placement
//! can.
//!
//! For a candidate point, the solid in a ball around it gives a frame
//! (centroid and principal axes of its second moments, from a coarse pyramid
//! level), and so does the template's ball of the same radius: aligning the
//! two fixes the pose up to the signs of the axes. Of the four sign choices
//! that make a proper rotation, the best placement is kept, and the pose
//! tells where the template's own point c_T lands: that is where the
//! instance is reported. A mirror twin of c_T, or any other point of the
//! same object, implies the same placement, since a proper rotation cannot
//! turn the object into its mirror image; aligning centroids rather than the
//! candidate points also absorbs the voxel or two by which the best candidate
//! misses c_T.
//!
//! Other objects fused to or touching the occurrence bend the frame of any
//! ball they reach, and which balls they reach is unknown: so the frame of
//! every layer's ball is tried, and a bent frame cannot fake a good score.
//! The placement is scored by the share of the template's surface, over its
//! whole extent, that lands within a voxel of the scene's surface. Samples landing
//!   inside the scene's solid are hidden by added material (a neighbour, the
//!   ground) and count neither way, up to a limit: a template pushed into a
//!   solid hides most of itself. Samples landing in empty space are missing
//!   material and count against: a template floating in space, wrongly
//!   turned or at the wrong scale misses most of its surface.
//!
//! A frame read from moments is off by a degree or two, which at the
//! template's rim is more than the one voxel the surface test allows, so the
//! best pose is refined by hill-climbing small rotations and shifts. A true
//! occurrence then agrees almost everywhere (0.99-1.0 on the shared and
//! held-out scenes, about 0.9 on figures twisted by 30 degrees), while the
//! best wrong placements found reach 0.75-0.8: the default threshold, 0.85,
//! sits between.

use crate::exec::Threads;
use crate::math::{Vec3, symmetric_eigen};
use crate::voxel::{Ball, Grid, Solid, dilate, level_for_radius};

/// Surface samples taken from the template.
const SAMPLES: usize = 4096;

/// Blocks per radius for the moments.
const MOMENT_BLOCKS: f64 = 10.0;

/// The pyramid level the moment ball of `radius` voxels is read from.
pub(crate) fn moment_level(radius: f64) -> u32 {
    level_for_radius(radius, MOMENT_BLOCKS).max(1)
}

/// First rotation step of the pose refinement (radians, about 2 degrees).
const REFINE_ANGLE: f64 = 0.035;

/// Placements scoring less than this before refinement are not refined.
const REFINE_FROM: f64 = 0.4;

/// Refinement counts every this many surface samples per trial pose: 1024
/// of the 4096 resolve its steps (a standard deviation of 0.01 at most
/// against the full count, which scores the result). Counting 2048 made
/// the climb half the cost of checking a near twin, for the same verdicts.
const REFINE_STRIDE: usize = 4;

/// Poses are ranked on every this many surface samples first.
const ROUGH_STRIDE: usize = 16;

/// How far a rough score (256 of the 4096 samples: a standard deviation
/// of 0.03 at most) may lie below the full count's.
const ROUGH_MARGIN: f64 = 0.15;

/// Scores closer than this are a tie between placements.
const TIE: f64 = 0.02;

/// The local frame of the solid around a point: its centroid (relative to
/// the point, in voxels) and principal axes.
#[derive(Clone, Copy, Debug)]
struct Frame {
    centroid: Vec3,
    axes: [Vec3; 3],
}

/// A template prepared for verification.
pub struct Verifier {
    /// The template's skin grown by two voxels: what explains scene
    /// surface. One more than the forward test allows, so that a bent copy
    /// (the scene's surface a voxel or two off the rigid template's) is
    /// explained while extra material, many voxels off, is not.
    explains: Grid,
    /// The voxel the template is placed by.
    anchor: [i64; 3],
    /// The template's extent from c_T, in voxels.
    reach: f64,
    /// The balls frames are taken from, one per layer radius.
    balls: Vec<Ball>,
    /// The template's frame in each of them.
    frames: Vec<Frame>,
    /// Template surface samples relative to the anchor (voxels).
    surface: Vec<Vec3>,
    /// c_T relative to the anchor, in voxels.
    target: Vec3,
    /// The largest share of the surface other material may hide.
    max_hidden: f64,
}

/// The outcome of one check.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Share of the template's surface that lands on the scene's surface.
    pub surface: f64,
    /// Share of the template's surface buried in the scene's solid.
    pub buried: f64,
    /// Share of the scene part's surface within the template's extent that
    /// lands on the template's surface.
    pub explained: f64,
    /// Rotation from template to scene (rows).
    pub rotation: [Vec3; 3],
    /// Where the template's point c_T lands, relative to the checked voxel
    /// (in voxels).
    pub offset: Vec3,
}

impl Placement {
    /// The placement's score: its surface agreement both ways.
    pub fn score(&self) -> f64 {
        self.surface.min(self.explained)
    }
}

impl Verifier {
    /// Prepares the template whose descriptors are taken at voxel `anchor` of
    /// `solid`, whose skin voxels are `skin` (grown by a voxel:
    /// `near_surface`); `target` is c_T relative to the anchor's centre and
    /// `radii` the layer radii, all in voxels (the last is the template's
    /// extent). Up to `max_hidden` of its surface may land inside the
    /// scene's solid.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        solid: &Solid,
        skin: &[[u16; 3]],
        near_surface: &Grid,
        anchor: [u16; 3],
        target: Vec3,
        radii: &[f64],
        max_hidden: f64,
        backend: Threads,
    ) -> Verifier {
        // Frames are read block by block, run by run: the balls need no
        // binding, only their levels.
        let balls: Vec<Ball> = radii
            .iter()
            .map(|&r| {
                let ball = Ball::build(r, moment_level(r), backend);
                solid.level(ball.level(), backend);
                ball
            })
            .collect();
        let frames = balls
            .iter()
            .map(|b| local_frame(b, solid, anchor))
            .collect();
        let radius = *radii.last().expect("at least one layer");
        let a = anchor.map(|c| c as i64);
        let surface_pts: Vec<Vec3> = skin
            .iter()
            .map(|s| {
                Vec3::new(
                    (s[0] as i64 - a[0]) as f64,
                    (s[1] as i64 - a[1]) as f64,
                    (s[2] as i64 - a[2]) as f64,
                )
            })
            // The template within r_k of c_T: all of it, wherever the
            // anchor is.
            .filter(|p| p.distance(target) <= radius)
            .collect();
        Verifier {
            explains: dilate(near_surface, backend),
            anchor: a,
            reach: radius,
            balls,
            frames,
            surface: spread(surface_pts),
            target,
            max_hidden,
        }
    }

    /// Places the template at voxel `v` of the scene `solid` with the frame
    /// of every layer's ball and keeps the best placement. Poses are ranked
    /// by surface agreement on every 16th surface sample first; only those
    /// within reach of the best are counted in full, and the winner is
    /// refined. `near_surface` is the scene's skin grown by a voxel, `skin`
    /// its skin voxels in (z, y, x) order. The
    /// other way, what the template explains of the scene, is measured
    /// only for a placement whose surface agreement reaches `threshold`,
    /// and only when `two_sided`: where the scene around a point may hold
    /// other objects (a part joined with what overlaps it), their surface
    /// is clutter, not the copy's.
    pub fn check(
        &self,
        solid: &Solid,
        near_surface: &Grid,
        skin: &[[u16; 3]],
        v: [u16; 3],
        threshold: f64,
        two_sided: bool,
    ) -> Placement {
        let vi = v.map(|c| c as i64);
        let mut poses = Vec::with_capacity(4 * self.balls.len());
        for (ball, ft) in self.balls.iter().zip(&self.frames) {
            let fs = local_frame(ball, solid, v);
            let handed = det(&ft.axes) * det(&fs.axes);
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
                    rows[r] = (0..3).fold(Vec3::ZERO, |acc, i| {
                        acc + ft.axes[i] * (signs[i] * fs.axes[i][r])
                    });
                }
                // Centroids coincide: q = c_S + R (a - c_T).
                let shift = fs.centroid - rotate_with(&rows, ft.centroid);
                poses.push(Pose { rows, shift });
            }
        }
        let bits = solid.bits();
        let rough_counts: Vec<SurfaceCounts> = poses
            .iter()
            .map(|p| self.surface_counts(near_surface, bits, vi, p, ROUGH_STRIDE))
            .collect();
        let rough: Vec<f64> = rough_counts
            .iter()
            .map(|c| c.score(self.max_hidden))
            .collect();
        let best_rough = rough.iter().copied().fold(0.0, f64::max);
        // Far below what refinement starts from and the threshold: no
        // full count can change the verdict.
        if best_rough + ROUGH_MARGIN < REFINE_FROM.min(threshold) {
            let at = rough.iter().position(|&r| r == best_rough).unwrap_or(0);
            let counts = &rough_counts[at];
            return Placement {
                surface: best_rough,
                buried: counts.buried as f64 / counts.total.max(1) as f64,
                explained: 0.0,
                rotation: poses[at].rows,
                offset: poses[at].shift + rotate_with(&poses[at].rows, self.target),
            };
        }
        let mut best: Option<(f64, &Pose)> = None;
        for (pose, r) in poses.iter().zip(&rough) {
            if *r < best_rough - ROUGH_MARGIN {
                continue;
            }
            // A count that can no longer come within a tie of the best
            // stops: that pose cannot be chosen.
            let hopeless = |counts: &SurfaceCounts, left| {
                best.is_some_and(|(b, _)| counts.best_with(left) < b - TIE)
            };
            let Some(counts) = self.counts_unless(near_surface, bits, vi, pose, 1, hopeless) else {
                continue;
            };
            let surface = counts.score(self.max_hidden);
            // Near-ties (a template symmetric under a rotation): keep the
            // placement that moves the candidate least.
            let better = match best {
                None => true,
                Some((b, bp)) if (surface - b).abs() <= TIE => {
                    pose.shift.length() < bp.shift.length()
                }
                Some((b, _)) => surface > b,
            };
            if better {
                best = Some((surface, pose));
            }
        }
        let (surface, pose) = best.expect("at least one pose");
        // Refinement gains up to 0.4 on a true placement; below that there
        // is nothing worth the time.
        let pose = &if surface >= REFINE_FROM {
            self.refine(near_surface, bits, vi, pose).1
        } else {
            *pose
        };
        let counts = self.surface_counts(near_surface, bits, vi, pose, 1);
        let surface = counts.score(self.max_hidden);
        Placement {
            surface,
            buried: counts.buried as f64 / counts.total.max(1) as f64,
            explained: if !two_sided {
                1.0
            } else if surface >= threshold {
                self.explained(skin, vi, pose)
            } else {
                0.0
            },
            rotation: pose.rows,
            offset: pose.shift + rotate_with(&pose.rows, self.target),
        }
    }

    /// The share of the scene's surface voxels within the template's extent
    /// around its placed c_T that land within two voxels of the template's
    /// surface. The scene is one part here, so what the template does not
    /// explain is the part's own: a longer pin holds a shorter one's
    /// surface, but not the other way round.
    fn explained(&self, skin: &[[u16; 3]], v: [i64; 3], pose: &Pose) -> f64 {
        let centre = pose.shift + rotate_with(&pose.rows, self.target);
        // The rim voxel's rounding aside.
        let reach = (self.reach - 1.0).max(0.0);
        let r = reach.ceil() as i64;
        let c = [0, 1, 2].map(|i| v[i] + centre[i].round() as i64);
        let (mut total, mut hits) = (0usize, 0usize);
        // The skin is sorted by (z, y, x): each row of the ball is a range
        // of it. Every other row along y and z: a quarter of the work, and
        // still thousands of samples on a template of tens of voxels.
        for z in (c[2] - r..=c[2] + r).step_by(2) {
            for y in (c[1] - r..=c[1] + r).step_by(2) {
                let (dy, dz) = ((y - c[1]) as f64, (z - c[2]) as f64);
                let across = reach * reach - dy * dy - dz * dz;
                if across < 0.0
                    || !(0..=u16::MAX as i64).contains(&y)
                    || !(0..=u16::MAX as i64).contains(&z)
                {
                    continue;
                }
                let half = across.sqrt() as i64;
                let key = |x: i64| [x.clamp(0, u16::MAX as i64) as u16, y as u16, z as u16];
                let (lo, hi) = (key(c[0] - half), key(c[0] + half));
                let order = |s: &[u16; 3]| (s[2], s[1], s[0]);
                let first = skin.partition_point(|s| order(s) < order(&lo));
                let last = skin.partition_point(|s| order(s) <= order(&hi));
                for s in &skin[first..last.max(first)] {
                    total += 1;
                    let d = Vec3::new(
                        (s[0] as i64 - v[0]) as f64,
                        (s[1] as i64 - v[1]) as f64,
                        (s[2] as i64 - v[2]) as f64,
                    );
                    // Back into the template: a = R^T (d - shift).
                    let q = d - pose.shift;
                    let a = pose.rows[0] * q.x + pose.rows[1] * q.y + pose.rows[2] * q.z;
                    if self.explains.get(
                        self.anchor[0] + a.x.round() as i64,
                        self.anchor[1] + a.y.round() as i64,
                        self.anchor[2] + a.z.round() as i64,
                    ) {
                        hits += 1;
                    }
                }
            }
        }
        if total == 0 {
            1.0
        } else {
            hits as f64 / total as f64
        }
    }

    /// Counts where every `stride`-th surface sample lands.
    fn surface_counts(
        &self,
        near_surface: &Grid,
        bits: &Grid,
        v: [i64; 3],
        pose: &Pose,
        stride: usize,
    ) -> SurfaceCounts {
        self.counts_unless(near_surface, bits, v, pose, stride, |_, _| false)
            .expect("never given up")
    }

    /// The refinement score of `pose` when it beats `best`, or `None`: the
    /// count stops as soon as the samples left cannot lift the score above
    /// `best` even if every one of them hits (most trial poses of a good
    /// placement lose, and they lose early).
    fn score_above(
        &self,
        near_surface: &Grid,
        bits: &Grid,
        v: [i64; 3],
        pose: &Pose,
        best: f64,
    ) -> Option<f64> {
        let lost = |counts: &SurfaceCounts, left| counts.best_with(left) <= best;
        let counts = self.counts_unless(near_surface, bits, v, pose, REFINE_STRIDE, lost)?;
        let score = counts.score(self.max_hidden);
        (score > best).then_some(score)
    }

    /// Counts where every `stride`-th surface sample lands, asking
    /// `give_up(counts so far, samples left)` every 64 samples.
    fn counts_unless(
        &self,
        near_surface: &Grid,
        bits: &Grid,
        v: [i64; 3],
        pose: &Pose,
        stride: usize,
        give_up: impl Fn(&SurfaceCounts, usize) -> bool,
    ) -> Option<SurfaceCounts> {
        let samples = self.surface.len().div_ceil(stride);
        let mut counts = SurfaceCounts {
            hits: 0,
            buried: 0,
            total: 0,
        };
        for a in self.surface.iter().step_by(stride) {
            counts.total += 1;
            let [x, y, z] = pose.voxel(v, *a);
            if near_surface.get(x, y, z) {
                counts.hits += 1;
            } else if bits.get(x, y, z) {
                counts.buried += 1;
            }
            if counts.total.is_multiple_of(64) && give_up(&counts, samples - counts.total) {
                return None;
            }
        }
        Some(counts)
    }

    /// Hill-climbs the pose by small rotations (about the placed centroid)
    /// and shifts while the surface agreement grows: a frame read from a
    /// ball's moments is off by a degree or two, which at the template's
    /// rim is more than the one voxel the agreement allows.
    fn refine(&self, near_surface: &Grid, bits: &Grid, v: [i64; 3], start: &Pose) -> (f64, Pose) {
        let score = |p: &Pose| {
            self.surface_counts(near_surface, bits, v, p, REFINE_STRIDE)
                .score(self.max_hidden)
        };
        let mut pose = Pose { ..*start };
        let mut best = score(&pose);
        let mut angle = REFINE_ANGLE;
        let mut step = 1.0;
        // A perfect score cannot be beaten: the rest would only confirm it.
        while angle >= REFINE_ANGLE / 8.0 && best < 1.0 {
            let pivot = pose.shift;
            let mut improved = false;
            for axis in 0..3 {
                for sign in [-1.0, 1.0] {
                    let turned = pose.turned(axis, sign * angle, pivot);
                    let mut shift = [0.0; 3];
                    shift[axis] = sign * step;
                    let moved = Pose {
                        shift: pose.shift + Vec3::new(shift[0], shift[1], shift[2]),
                        ..pose
                    };
                    for cand in [turned, moved] {
                        if let Some(s) = self.score_above(near_surface, bits, v, &cand, best) {
                            best = s;
                            pose = cand;
                            improved = true;
                        }
                    }
                }
            }
            if !improved {
                angle /= 2.0;
                step /= 2.0;
            }
        }
        (best, pose)
    }
}

/// Where the template's surface samples land in a placement.
struct SurfaceCounts {
    /// On the scene's surface.
    hits: usize,
    /// Inside the scene's solid: hidden by extra material.
    buried: usize,
    /// All samples counted.
    total: usize,
}

impl SurfaceCounts {
    /// The agreement: buried samples count neither way, unless more than
    /// `max_hidden` of them are.
    fn score(&self, max_hidden: f64) -> f64 {
        if self.total == 0 || self.buried as f64 > max_hidden * self.total as f64 {
            return 0.0;
        }
        self.hits as f64 / (self.total - self.buried).max(1) as f64
    }

    /// The highest agreement (buried samples aside) the count can still
    /// reach with `left` samples to come: all of them hits.
    fn best_with(&self, left: usize) -> f64 {
        let misses = self.total - self.hits - self.buried;
        (self.hits + left) as f64 / (self.hits + misses + left).max(1) as f64
    }
}

/// A candidate placement: rotation (rows) and shift, in voxels.
#[derive(Clone, Copy)]
struct Pose {
    rows: [Vec3; 3],
    shift: Vec3,
}

impl Pose {
    /// The pose turned by `angle` about coordinate `axis` through `pivot`.
    fn turned(&self, axis: usize, angle: f64, pivot: Vec3) -> Pose {
        let (s, c) = angle.sin_cos();
        let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
        let turn = |p: Vec3| {
            let mut q = [p.x, p.y, p.z];
            let (a, b) = (q[i], q[j]);
            q[i] = c * a - s * b;
            q[j] = s * a + c * b;
            Vec3::new(q[0], q[1], q[2])
        };
        // Rows of R' = T R: column k of R' is T applied to column k of R.
        let col = |k: usize| turn(Vec3::new(self.rows[0][k], self.rows[1][k], self.rows[2][k]));
        let cols = [col(0), col(1), col(2)];
        let rows = [
            Vec3::new(cols[0].x, cols[1].x, cols[2].x),
            Vec3::new(cols[0].y, cols[1].y, cols[2].y),
            Vec3::new(cols[0].z, cols[1].z, cols[2].z),
        ];
        Pose {
            rows,
            shift: turn(self.shift - pivot) + pivot,
        }
    }

    /// The voxel template offset `a` lands in, placed around voxel `v`.
    fn voxel(&self, v: [i64; 3], a: Vec3) -> [i64; 3] {
        let q = rotate_with(&self.rows, a) + self.shift;
        [
            v[0] + q.x.round() as i64,
            v[1] + q.y.round() as i64,
            v[2] + q.z.round() as i64,
        ]
    }
}

fn rotate_with(rows: &[Vec3; 3], a: Vec3) -> Vec3 {
    Vec3::new(rows[0].dot(a), rows[1].dot(a), rows[2].dot(a))
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
    let (_, axes) = symmetric_eigen(m);
    Frame { centroid, axes }
}

/// At most [`SAMPLES`] items spread evenly over the list (deterministic).
fn spread<T: Copy>(items: Vec<T>) -> Vec<T> {
    if items.len() <= SAMPLES {
        return items;
    }
    let step = items.len() as f64 / SAMPLES as f64;
    (0..SAMPLES)
        .map(|i| items[(i as f64 * step) as usize])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::{cuboid, uv_sphere};
    use crate::voxel::{GridSpec, skin, voxelize};

    #[test]
    fn stopping_a_losing_pose_early_decides_as_the_full_count() {
        let mut m = uv_sphere(Vec3::ZERO, 0.6, 32, 64);
        m.append(&cuboid(
            Vec3::new(0.3, -0.15, -0.15),
            Vec3::new(1.1, 0.15, 0.15),
        ));
        let spec = GridSpec::around(m.bounds(), 0.04).unwrap();
        let solid = Solid::new(voxelize(&m, &spec, Threads::Serial));
        let near = dilate(&skin(solid.bits(), Threads::Serial), Threads::Serial);
        let surface: Vec<[u16; 3]> = skin(solid.bits(), Threads::Serial).iter_ones().collect();
        let anchor = surface[0];
        let radii = [8.0, 16.0, 24.0, 32.0];
        let verifier = Verifier::new(
            &solid,
            &surface,
            &near,
            anchor,
            Vec3::ZERO,
            &radii,
            0.3,
            Threads::Serial,
        );
        let v = anchor.map(|c| c as i64);
        let identity = Pose {
            rows: [
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(0.0, 0.0, 1.0),
            ],
            shift: Vec3::ZERO,
        };
        let mut decided = [0usize; 2];
        for k in 0..24 {
            let pose = identity
                .turned(k % 3, 0.01 * k as f64, Vec3::new(5.0, 0.0, 0.0))
                .turned((k + 1) % 3, -0.004 * k as f64, Vec3::ZERO);
            let full = verifier
                .surface_counts(&near, solid.bits(), v, &pose, REFINE_STRIDE)
                .score(verifier.max_hidden);
            for best in [0.0, 0.5, 0.9, 0.97, 0.99, full, 0.999] {
                let got = verifier.score_above(&near, solid.bits(), v, &pose, best);
                assert_eq!(got, (full > best).then_some(full), "pose {k}, best {best}");
                decided[got.is_some() as usize] += 1;
            }
        }
        // Both outcomes occur, so the comparison means something.
        assert!(decided[0] > 10 && decided[1] > 10, "{decided:?}");
    }

    /// The voxels of `mesh` on a grid of `voxel` around `bounds`: solid,
    /// skin list and skin grown by a voxel.
    fn voxels(mesh: &crate::mesh::TriMesh, spec: &GridSpec) -> (Solid, Vec<[u16; 3]>, Grid) {
        let solid = Solid::new(voxelize(mesh, spec, Threads::Serial));
        let skin_grid = skin(solid.bits(), Threads::Serial);
        let near = dilate(&skin_grid, Threads::Serial);
        (solid, skin_grid.iter_ones().collect(), near)
    }

    #[test]
    fn a_part_with_more_surface_than_the_template_is_not_explained() {
        // A rod, and the same rod twice as long: the short one's surface
        // lies on the long one's, but the long one's extra surface within
        // the short one's extent has nothing to explain it.
        let short = cuboid(Vec3::new(-0.5, -0.1, -0.1), Vec3::new(0.5, 0.1, 0.1));
        let long = cuboid(Vec3::new(-0.5, -0.1, -0.1), Vec3::new(1.5, 0.1, 0.1));
        let spec = GridSpec::around(long.bounds(), 0.02).unwrap();
        let (tsolid, tskin, tnear) = voxels(&short, &spec);
        // c_T at the middle of the short rod's top face.
        let anchor = tskin
            .iter()
            .copied()
            .min_by(|a, b| {
                let d = |v: &[u16; 3]| (spec.center(*v) - Vec3::new(0.0, 0.1, 0.0)).length();
                d(a).total_cmp(&d(b))
            })
            .unwrap();
        let target = (Vec3::new(0.0, 0.1, 0.0) - spec.center(anchor)) / spec.voxel_size;
        let radii: Vec<f64> = (1..=4).map(|i| 13.0 * i as f64).collect();
        let verifier = Verifier::new(
            &tsolid,
            &tskin,
            &tnear,
            anchor,
            target,
            &radii,
            0.3,
            Threads::Serial,
        );
        let same = verifier.check(&tsolid, &tnear, &tskin, anchor, 0.85, true);
        assert!(same.surface > 0.95 && same.explained > 0.95, "{same:?}");
        let (lsolid, lskin, lnear) = voxels(&long, &spec);
        let longer = verifier.check(&lsolid, &lnear, &lskin, anchor, 0.85, true);
        let one_sided = verifier.check(&lsolid, &lnear, &lskin, anchor, 0.85, false);
        assert!(one_sided.score() > 0.95, "{one_sided:?}");
        assert!(longer.surface > 0.95, "{longer:?}");
        assert!(longer.explained < 0.85, "{longer:?}");
        assert!(longer.score() < 0.85);
    }
}
