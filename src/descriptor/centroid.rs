//! The ball's centroid: a cheap, selective stage between the volume and
//! the harmonics.
//!
//! On box-like parts (walls, slabs, ducts) most candidates survive the
//! volume layers: a ball on a flat face or an edge is as full as one on the
//! template. What tells them apart is where the material lies, which the
//! harmonics see through degree 1 of their spheres (on a building of 3 000
//! distinct parts, degree 1 alone rejects 99.7% of what the volume keeps)
//! at the price of sampling whole spheres. The ball's first moment says the
//! same thing for about the price of a volume layer: the count pyramid's
//! running sums give it run by run.
//!
//! The stage compares the centroid's offset from the centre, |M| / (V r)
//! (V the voxels the ball covers, r its radius), which no rotation changes.
//! What may differ at a true copy, and is allowed for:
//! - clutter: material added anywhere in the ball moves the offset by at
//!   most the fraction added (each voxel lies within r), so the allowance
//!   grows by the difference of the solid fractions, which is observed;
//! - the candidate is a skin voxel near the copy's anchor, not the anchor:
//!   the template's own offset over the skin voxels around its anchor (as
//!   far as the candidate spacing reaches) bounds the change;
//! - the voxelization's phase: the template is read at two phases (see
//!   the search's signatures), and their difference is added;
//! - what is left (a turned copy's staircase): [`BASE_TOLERANCE`].
//!
//! A point is dropped when, for every anchor still matched, some layer's
//! offset differs from the template's by more than that allowance. Only
//! the clutter term is a proof; the others are measured, so the stage is
//! held to the harmonics' own survivors by comparison: the same instances
//! on every shared and generated scene compared (see docs/CHANGELOG.md).
//! It runs only where both the volume and the harmonics are searched.

use super::{Anchors, ClutterPolicy, MAX_ANCHORS, OnionDescriptor, all_anchors};
use crate::exec::Threads;
use crate::voxel::{Ball, BallMoment, Solid};

/// The offset a turned copy may differ by beyond what the template's
/// neighbourhood and phases account for: the staircase of a face at an
/// angle, a fraction of a voxel over a ball many voxels wide.
pub const BASE_TOLERANCE: f64 = 0.02;

/// Candidates sampled to choose the layers that pay.
const ORDER_SAMPLE: usize = 256;

/// The share of the sampled points still alive that a layer must drop to
/// be run.
const MIN_DROPPED: f64 = 0.1;

/// The template's reading at one layer and one anchor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CentroidTemplate {
    /// The solid fraction of the ball.
    pub fraction: f64,
    /// The centroid's offset (see [`BallMoment::offset`]).
    pub offset: f64,
    /// How far a true copy's offset may differ, clutter aside.
    pub tolerance: f64,
}

/// The centroid stage over the candidate voxels `points` of `solid`.
pub struct CentroidDescriptor<'a> {
    solid: &'a Solid,
    points: &'a [[u16; 3]],
    balls: Vec<Ball>,
    radii: Vec<f64>,
    /// Per anchor, per layer.
    templates: Vec<Vec<CentroidTemplate>>,
    /// Leading layers that clutter seldom reaches (see
    /// [`CentroidDescriptor::with_clutter`]).
    clean_layers: usize,
}

/// The state of a point: the anchors still matched.
#[derive(Clone, Copy, Debug, Default)]
pub struct CentroidState {
    alive: Anchors,
}

impl<'a> CentroidDescriptor<'a> {
    /// The balls of the volume stage's `volume` balls, shared where they
    /// are read from level 1 or above (the same runs: building the tables
    /// again cost a real scene's template a third more time), and made at
    /// level 1 where they are read from the bit grid.
    pub fn balls_like(volume: &[Ball], backend: Threads) -> Vec<Ball> {
        volume
            .iter()
            .map(|b| match b.level() {
                0 => Ball::build(b.radius(), 1, backend),
                _ => b.clone(),
            })
            .collect()
    }

    /// Makes the levels the balls read in `solid`.
    pub fn ready(solid: &Solid, balls: &[Ball], backend: Threads) {
        for b in balls {
            solid.level(b.level(), backend);
        }
    }

    /// The stage over `points` of `solid`, with `balls` from
    /// [`Self::balls_like`] and the template's readings, one list per
    /// anchor.
    pub fn new(
        solid: &'a Solid,
        points: &'a [[u16; 3]],
        radii: &[f64],
        balls: Vec<Ball>,
        templates: Vec<Vec<CentroidTemplate>>,
        backend: Threads,
    ) -> Self {
        assert!((1..=MAX_ANCHORS).contains(&templates.len()));
        Self::ready(solid, &balls, backend);
        CentroidDescriptor {
            solid,
            points,
            balls,
            radii: radii.to_vec(),
            clean_layers: usize::MAX,
            templates,
        }
    }

    /// Orders the layers for `policy`'s clean layers. The test holds under
    /// clutter at every layer, but its allowance grows with the material
    /// added, which is most where the ball is largest: so, as the
    /// harmonics do, the largest always-counted ball leads (on a building
    /// of distinct parts it keeps 2% of what the volume keeps, the
    /// outermost 99%).
    pub fn with_clutter(mut self, policy: ClutterPolicy) -> Self {
        let voxel = self.solid.bits().spec().voxel_size;
        let radii_voxels: Vec<f64> = self.radii.iter().map(|r| r / voxel).collect();
        self.clean_layers = policy.clean_layers(&radii_voxels);
        self
    }

    /// The readings at voxel `v` of `solid`, one per ball (what the
    /// template side computes).
    pub fn describe(
        solid: &Solid,
        v: [u16; 3],
        balls: &[Ball],
        backend: Threads,
    ) -> Vec<BallMoment> {
        Self::ready(solid, balls, backend);
        balls.iter().map(|b| b.moment(solid, v)).collect()
    }
}

impl OnionDescriptor for CentroidDescriptor<'_> {
    type State = CentroidState;
    type Value = ();

    fn name(&self) -> &'static str {
        "centroid"
    }

    fn layers(&self) -> usize {
        self.balls.len()
    }

    fn radius(&self, layer: usize) -> f64 {
        self.radii[layer]
    }

    /// The distance is 0 while an anchor matches, infinite after.
    fn threshold(&self) -> f64 {
        0.0
    }

    /// The layers that pay, judged on a sample of many candidates: in the
    /// selective order, each layer that drops at least [`MIN_DROPPED`] of
    /// the sampled points still alive; none where the first does not (the
    /// bunnies of the shared scenes: their candidates' centroids already
    /// lie where the template's does). A layer costs a twentieth of a
    /// harmonics sphere or less, so one that drops a tenth of its points
    /// pays; leaving layers out only keeps more points for the harmonics,
    /// which decide as they would without this stage.
    fn order(&self, candidates: &[u32], backend: Threads) -> Vec<usize> {
        let every = ClutterPolicy::selective_order(self.clean_layers, self.layers(), false);
        if candidates.len() < 2 * ORDER_SAMPLE {
            // Judging would cost about what it could save.
            return every;
        }
        let sample: Vec<u32> = candidates
            .iter()
            .step_by((candidates.len() / ORDER_SAMPLE).max(1))
            .copied()
            .collect();
        let mut states: Vec<CentroidState> = sample
            .iter()
            .map(|&p| self.start(p, Anchors::MAX))
            .collect();
        let mut chosen = Vec::new();
        for (i, &layer) in every.iter().enumerate() {
            let alive = states.iter().filter(|s| s.alive != 0).count();
            if (alive as f64) < MIN_DROPPED * sample.len() as f64 {
                // Few points are left to these layers: running them costs
                // less than judging them.
                chosen.extend(&every[i..]);
                break;
            }
            let after: Vec<CentroidState> = backend.map(sample.len(), |i| {
                let mut state = states[i];
                self.extend(sample[i], layer, &mut state);
                state
            });
            let dropped = alive - after.iter().filter(|s| s.alive != 0).count();
            if (dropped as f64) < MIN_DROPPED * alive as f64 {
                continue;
            }
            states = after;
            chosen.push(layer);
        }
        chosen
    }

    fn start(&self, _point: u32, anchors: Anchors) -> CentroidState {
        CentroidState {
            alive: anchors & all_anchors(self.templates.len()),
        }
    }

    fn anchors(&self, state: &CentroidState) -> Anchors {
        state.alive
    }

    fn extend(&self, point: u32, layer: usize, state: &mut CentroidState) -> f64 {
        if state.alive != 0 {
            let ball = &self.balls[layer];
            let here = ball.moment(self.solid, self.points[point as usize]);
            let (fraction, offset) = (here.fraction(), here.offset(ball.radius()));
            for (a, template) in self.templates.iter().enumerate() {
                let t = template[layer];
                let allowed = t.tolerance + (fraction - t.fraction).abs();
                if (offset - t.offset).abs() > allowed {
                    state.alive &= !(1 << a);
                }
            }
        }
        if state.alive == 0 { f64::INFINITY } else { 0.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::mesh::shapes::cuboid;
    use crate::voxel::{GridSpec, voxelize};

    /// The stage's balls for `radii` on voxels of `voxel_size`, as a search
    /// makes them.
    fn balls_at(radii: &[f64], voxel_size: f64, backend: Threads) -> Vec<Ball> {
        let volume = crate::descriptor::VolumeDescriptor::balls_at(radii, voxel_size, backend);
        CentroidDescriptor::balls_like(&volume, backend)
    }

    /// A voxel on the top face of a large slab, away from its edges.
    fn slab_top(n: u32) -> (Solid, [u16; 3], GridSpec) {
        let slab = cuboid(Vec3::new(-4.0, -4.0, -1.0), Vec3::new(4.0, 4.0, 0.0));
        let spec = GridSpec::for_scene(slab.bounds(), n).unwrap();
        let solid = Solid::new(voxelize(&slab, &spec, Threads::Serial));
        let top = spec.to_grid(Vec3::new(0.1, -0.2, 0.0));
        let (x, y) = (top.x as u16, top.y as u16);
        let z = (0..spec.dims[2] as u16)
            .rev()
            .find(|&z| solid.bits().get(x as i64, y as i64, z as i64))
            .unwrap();
        (solid, [x, y, z], spec)
    }

    #[test]
    fn a_half_ball_has_its_centroid_three_eighths_of_the_radius_away() {
        // The solid half of a ball (volume V/2) has its centroid at 3r/8:
        // |M| = V/2 * 3r/8, so |M| / (V r) = 3/16.
        let (solid, v, spec) = slab_top(256);
        for r in [0.2, 0.4, 0.8] {
            let rv = r / spec.voxel_size;
            let balls = balls_at(&[r], spec.voxel_size, Threads::Serial);
            let m = CentroidDescriptor::describe(&solid, v, &balls, Threads::Serial)[0];
            // The surface layer of voxels, counted solid, lifts the
            // fraction and shifts the centroid by about a voxel's share.
            let layer = 1.0 / rv;
            assert!(
                (m.fraction() - 0.5).abs() < layer,
                "r {r}: {}",
                m.fraction()
            );
            assert!(
                (m.offset(balls[0].radius()) - 3.0 / 16.0).abs() < layer,
                "r {r}"
            );
            // The moment points into the slab.
            assert!(m.first[2] < 0.0 && m.first[2].abs() > 10.0 * m.first[0].abs());
        }
    }

    #[test]
    fn moments_match_a_brute_force_sum_over_the_blocks() {
        let (solid, v, spec) = slab_top(128);
        let balls = balls_at(&[0.7, 1.9], spec.voxel_size, Threads::Serial);
        for (ball, got) in balls.iter().zip(CentroidDescriptor::describe(
            &solid,
            v,
            &balls,
            Threads::Serial,
        )) {
            let (mut n, mut m) = (0u64, Vec3::ZERO);
            ball.for_each_block(&solid, v, |at, k| {
                n += u64::from(k);
                m += at * f64::from(k);
            });
            assert_eq!(got.solid, n);
            for (a, want) in [m.x, m.y, m.z].into_iter().enumerate() {
                assert!(
                    (got.first[a] - want).abs() < 1e-6,
                    "{a}: {} vs {want}",
                    got.first[a]
                );
            }
        }
    }

    #[test]
    fn added_material_moves_the_offset_by_at_most_the_fraction_added() {
        let (solid, v, spec) = slab_top(128);
        let balls = balls_at(&[0.6], spec.voxel_size, Threads::Serial);
        let clean = CentroidDescriptor::describe(&solid, v, &balls, Threads::Serial)[0];
        // A wall standing on the slab beside the point.
        let mut bits = solid.bits().clone();
        let dims = spec.dims;
        let (x, y) = (v[0] as usize, v[1] as usize);
        for z in v[2] as usize..dims[2] {
            for y in y - 30..(y + 30).min(dims[1]) {
                for x in x + 4..(x + 12).min(dims[0]) {
                    bits.set(x, y, z);
                }
            }
        }
        let cluttered = Solid::new(bits);
        let moved = CentroidDescriptor::describe(&cluttered, v, &balls, Threads::Serial)[0];
        let r = balls[0].radius();
        let added = moved.fraction() - clean.fraction();
        assert!(added > 0.01, "the wall adds material: {added}");
        assert!((moved.offset(r) - clean.offset(r)).abs() <= added + 1e-12);
    }

    #[test]
    fn only_layers_that_drop_a_tenth_of_a_sample_are_run() {
        // Candidates all over the slab's top face: they read as the
        // template's own reading there, or not at all like a far-off one.
        let (solid, v, spec) = slab_top(128);
        let points: Vec<[u16; 3]> = crate::voxel::skin(solid.bits(), Threads::Serial)
            .iter_ones()
            .filter(|p| p[2] == v[2] && (0..2).all(|a| p[a].abs_diff(v[a]) <= 40))
            .collect();
        assert!(
            points.len() >= 4 * ORDER_SAMPLE,
            "{} candidates",
            points.len()
        );
        let radii = [0.2, 0.4, 0.6];
        let balls = balls_at(&radii, spec.voxel_size, Threads::Serial);
        let read = CentroidDescriptor::describe(&solid, v, &balls, Threads::Serial);
        let template = |shift: f64| -> Vec<CentroidTemplate> {
            read.iter()
                .zip(&balls)
                .map(|(m, b)| CentroidTemplate {
                    fraction: m.fraction(),
                    offset: m.offset(b.radius()) + shift,
                    tolerance: 0.05,
                })
                .collect()
        };
        let ids: Vec<u32> = (0..points.len() as u32).collect();
        let order = |shift: f64| {
            CentroidDescriptor::new(
                &solid,
                &points,
                &radii,
                balls.clone(),
                vec![template(shift)],
                Threads::Serial,
            )
            .order(&ids, Threads::Serial)
        };
        // Like the template: no layer pays.
        assert_eq!(order(0.0), Vec::<usize>::new());
        // Far from it: the lead layer drops them all, and the others are
        // left to run on what is left.
        assert_eq!(order(0.5).len(), radii.len());
    }
}
