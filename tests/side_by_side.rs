//! Copies standing side by side on one base, closer than the template's
//! radius r_k: a tall block with a setback near one corner, as a city's
//! towers on their lots or fins on a plate stand. The template is two
//! shells, so the copies found are merged where the same copy was seen
//! twice. Merged by the ball alone, every other copy joined its neighbour,
//! as one tower of three did in the city of `make-city-scenes.py --seed 8
//! --variants 2`; with every other copy turned half way, their c_T lie on
//! opposite faces, diagonally apart, and the line between them crosses
//! both copies: a plane square to the row tells them apart.

use fast_reject::math::Vec3;
use fast_reject::mesh::TriMesh;
use fast_reject::mesh::shapes::cuboid;
use fast_reject::{MatchOptions, MatchReport, Scene, SceneOptions, TemplateSource, search};

/// A 2 x 1.2 x 6 shaft on z = 0 and a 0.9 x 0.5 x 1.5 setback on its top
/// near one corner (two shells that touch, sharing no vertex).
fn tower() -> TriMesh {
    let mut body = cuboid(Vec3::ZERO, Vec3::new(2.0, 1.2, 6.0));
    body.append(&cuboid(Vec3::new(1.0, 0.6, 6.0), Vec3::new(1.9, 1.1, 7.5)));
    body
}

/// `mesh` turned by `angle` about z and moved by `shift`.
fn placed(mesh: &TriMesh, angle: f64, shift: Vec3) -> TriMesh {
    let (s, c) = angle.sin_cos();
    mesh.map_positions(|p| Vec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z) + shift)
        .unwrap()
}

/// Four copies in a row on one base, 0.6 apart between walls, every
/// other one turned by `turn` about the vertical: the report, and where
/// each copy's c_T lies.
fn row_of_towers(turn: f64) -> (MatchReport, Vec<Vec3>) {
    let template = tower();
    // A half turn keeps the footprint (the setback goes to the far corner);
    // the turned copies' c_T lie on the other long face.
    let lots: Vec<(f64, Vec3)> = (0..4)
        .map(|k| {
            let angle = if k % 2 == 1 { turn } else { 0.0 };
            // The turned footprint's low corner on the lot's.
            let (s, c) = f64::sin_cos(angle);
            let corners = [(0.0, 0.0), (2.0, 0.0), (0.0, 1.2), (2.0, 1.2)];
            let low = |f: &dyn Fn(f64, f64) -> f64| {
                corners
                    .iter()
                    .map(|&(x, y)| f(x, y))
                    .fold(f64::INFINITY, f64::min)
            };
            let shift = Vec3::new(
                2.6 * k as f64 - low(&|x, y| c * x - s * y),
                -low(&|x, y| s * x + c * y),
                0.0,
            );
            (angle, shift)
        })
        .collect();
    let mut scene = cuboid(Vec3::new(-2.0, -2.0, -0.5), Vec3::new(12.0, 3.2, 0.0));
    for &(angle, shift) in &lots {
        scene.append(&placed(&template, angle, shift));
    }
    let scene = Scene::new(scene, &SceneOptions::DEFAULT).unwrap();
    let report = search(
        &scene,
        &TemplateSource::Model(template),
        &MatchOptions::DEFAULT,
        &mut (),
    )
    .unwrap();
    let c = Vec3::from_array(report.template.center);
    let centres = lots
        .iter()
        .map(|&(angle, shift)| {
            let (s, k) = angle.sin_cos();
            Vec3::new(k * c.x - s * c.y, s * c.x + k * c.y, c.z) + shift
        })
        .collect();
    (report, centres)
}

#[test]
fn copies_closer_than_the_radius_but_apart_are_each_found() {
    for turn in [0.0, std::f64::consts::PI] {
        let (report, centres) = row_of_towers(turn);
        let radius = report.template.radius;
        // Neighbours stand under three quarters of r_k apart.
        let apart = centres[0].distance(centres[1]);
        assert!(apart < 0.75 * radius, "{apart} apart, r_k {radius}");
        let found: Vec<Vec3> = report
            .instances
            .iter()
            .map(|i| Vec3::from_array(i.position))
            .collect();
        for (k, centre) in centres.iter().enumerate() {
            assert!(
                found.iter().any(|p| p.distance(*centre) < 0.02 * radius),
                "turn {turn}: copy {k} at {centre} missed: found {found:?}"
            );
        }
        assert_eq!(
            found.len(),
            centres.len(),
            "turn {turn}: a false hit: {found:?}"
        );
    }
}
