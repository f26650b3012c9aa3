//! Grouping survivors into instances.
//!
//! The points that pass the cascade gather in small clusters around each
//! occurrence's centre. Grouping is a greedy non-maximum suppression: the best
//! remaining point (smallest distance) founds an instance, and every survivor
//! within the grouping radius of it joins that instance. The radius is a
//! fraction of the template's outer radius: occurrences whose centres are
//! closer than that would overlap almost entirely.

use crate::cascade::Survivor;
use crate::math::Vec3;

/// One occurrence of the template.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Instance {
    /// World position of the best point.
    pub position: [f64; 3],
    /// Its final descriptor distance.
    pub distance: f64,
    /// How many surviving points the instance gathered.
    pub support: usize,
}

/// Groups survivors (deterministically: ties go to the lower point index).
pub fn group(survivors: &[Survivor], position: impl Fn(u32) -> Vec3, radius: f64) -> Vec<Instance> {
    let mut order: Vec<&Survivor> = survivors.iter().collect();
    order.sort_by(|a, b| {
        a.distance
            .total_cmp(&b.distance)
            .then(a.point.cmp(&b.point))
    });
    let mut found: Vec<(Vec3, Instance)> = Vec::new();
    let r2 = radius * radius;
    for s in order {
        let p = position(s.point);
        match found.iter_mut().find(|(c, _)| (*c - p).norm2() <= r2) {
            Some((_, inst)) => inst.support += 1,
            None => found.push((
                p,
                Instance {
                    position: p.to_array(),
                    distance: s.distance,
                    support: 1,
                },
            )),
        }
    }
    found.into_iter().map(|(_, i)| i).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clusters_become_instances_at_their_best_point() {
        let pts = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.1, 0.0, 0.0),
            Vec3::new(5.0, 0.0, 0.0),
            Vec3::new(5.1, 0.1, 0.0),
            Vec3::new(5.2, 0.0, 0.0),
        ];
        let d = [0.3, 0.2, 0.5, 0.1, 0.4];
        let s: Vec<Survivor> = (0..5)
            .map(|i| Survivor {
                point: i,
                distance: d[i as usize],
            })
            .collect();
        let g = group(&s, |i| pts[i as usize], 1.0);
        assert_eq!(g.len(), 2);
        assert_eq!(g[0].position, [5.1, 0.1, 0.0]);
        assert_eq!(g[0].support, 3);
        assert_eq!(g[1].position, [0.1, 0.0, 0.0]);
        assert_eq!(g[1].support, 2);
    }
}
