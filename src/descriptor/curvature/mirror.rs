//! Telling a point from its mirror twin: the Gaussian curvature is the
//! same on both flanks of a symmetric shape, the way the neighbourhood
//! turns around the normal is not.

use super::Layer;
use crate::math::Vec3;

/// Which way the neighbourhood of a vertex turns from an inner layer to an
/// outer one, seen along the vertex normal: the sine of the angle between
/// the two centroids' tangential parts (positive counter-clockwise). A
/// mirror image flips its sign, a rotation or a bending does not; the
/// Gaussian curvature cannot tell a point from its mirror twin (the other
/// flank of a symmetric shape), this can. Zero where a centroid has no
/// tangential part.
pub fn handedness(normal: Vec3, inner: Vec3, outer: Vec3) -> f64 {
    let flat = |m: Vec3| m - normal * normal.dot(m);
    let (a, b) = (flat(inner), flat(outer));
    let scale = a.length() * b.length();
    if scale > 0.0 {
        normal.dot(a.cross(b)) / scale
    } else {
        0.0
    }
}

/// Tells a point from its mirror twin, which has the same Gaussian
/// curvatures (the other flank of a symmetric shape): the innermost pair of
/// layers whose centroids turn clearly one way around the template's normal
/// must turn the same way around the candidate's. "Clearly": both centroids
/// lie off the normal by at least [`MirrorTest::OFFSET`] of their radius
/// (closer, their direction is tessellation noise) and [`handedness`] is at
/// least [`MirrorTest::TURN`]. Where no pair qualifies, the template is
/// about mirror-symmetric at c_T and has no twin to tell apart.
pub struct MirrorTest {
    /// Layers (inner, outer) and the template's sign, if any pair is clear.
    pair: Option<(usize, usize, f64)>,
}

impl MirrorTest {
    const OFFSET: f64 = 0.05;
    const TURN: f64 = 0.5;

    /// The test for a template with `layers` at `radii` around `normal`.
    pub fn new(normal: Vec3, layers: &[Layer], radii: &[f64]) -> MirrorTest {
        let off_normal = |i: usize| {
            let m = layers[i].centroid;
            (m - normal * normal.dot(m)).length() >= Self::OFFSET * radii[i]
        };
        let k = layers.len();
        let pair = (1..k)
            .flat_map(|outer| (0..outer).rev().map(move |inner| (inner, outer)))
            .filter(|&(a, b)| off_normal(a) && off_normal(b))
            .map(|(a, b)| {
                (
                    a,
                    b,
                    handedness(normal, layers[a].centroid, layers[b].centroid),
                )
            })
            .find(|&(_, _, turn)| turn.abs() >= Self::TURN)
            .map(|(a, b, turn)| (a, b, turn.signum()));
        MirrorTest { pair }
    }

    /// Whether a candidate with `layers` around `normal` turns the template's way.
    pub fn passes(&self, normal: Vec3, layers: &[Layer]) -> bool {
        match self.pair {
            Some((a, b, sign)) => {
                handedness(normal, layers[a].centroid, layers[b].centroid) * sign >= 0.0
            }
            None => true,
        }
    }
}
