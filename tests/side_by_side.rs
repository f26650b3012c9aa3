//! Copies standing side by side on one base, closer than the template's
//! radius r_k: a tall block with a setback near one corner, as a city's
//! towers on their lots or fins on a plate stand. The template is two
//! shells, so each copy is searched with the base it touches, and the
//! copies found are merged where the same copy was seen twice. Merged by
//! the ball alone, every other copy joined its neighbour, as one tower of
//! three did in the city of `make-city-scenes.py --seed 8 --variants 2`.

use fast_reject::math::Vec3;
use fast_reject::mesh::TriMesh;
use fast_reject::mesh::shapes::cuboid;
use fast_reject::{MatchOptions, Scene, SceneOptions, TemplateSource, search};

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

#[test]
fn copies_closer_than_the_radius_but_apart_are_each_found() {
    let template = tower();
    let lots: Vec<(f64, Vec3)> = (0..4)
        .map(|k| (0.0, Vec3::new(2.6 * k as f64, 0.0, 0.0)))
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
    let (c, radius) = (
        Vec3::from_array(report.template.center),
        report.template.radius,
    );
    let centres: Vec<Vec3> = lots
        .iter()
        .map(|&(angle, shift)| {
            let (s, k) = angle.sin_cos();
            Vec3::new(k * c.x - s * c.y, s * c.x + k * c.y, c.z) + shift
        })
        .collect();
    // Neighbours stand under three quarters of r_k apart.
    let apart = centres[0].distance(centres[1]);
    assert!(
        apart < 0.75 * radius,
        "{apart} apart, r_k {radius}, c_T {c}"
    );
    let found: Vec<Vec3> = report
        .instances
        .iter()
        .map(|i| Vec3::from_array(i.position))
        .collect();
    for (k, centre) in centres.iter().enumerate() {
        assert!(
            found.iter().any(|p| p.distance(*centre) < 0.02 * radius),
            "copy {k} at {centre} missed: found {found:?}"
        );
    }
    assert_eq!(found.len(), centres.len(), "a false hit: {found:?}");
}
