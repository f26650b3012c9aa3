//! Whole copy or part of a larger whole: each instance says which it is,
//! and `whole_copies` keeps the whole ones. The template is a block with a
//! cap (two shells, as CAD bodies come); the scene holds one copy alone,
//! one standing on a plate (a neighbour whose surface meets the copy's),
//! one whose block runs on below (the template inside a larger whole), and
//! one bent at the cap (a near copy the template could not replace).

use fast_reject::math::Vec3;
use fast_reject::mesh::TriMesh;
use fast_reject::mesh::shapes::cuboid;
use fast_reject::{MatchOptions, MatchReport, Scene, SceneOptions, TemplateSource, search};

/// A 2 x 1 x 1 block whose bottom is at `floor` (the top stays at 1), and
/// a cap of 0.5 overlapping its top, `cap_shift` along x off the middle.
fn capped_block(floor: f64, cap_shift: f64) -> TriMesh {
    let mut body = cuboid(Vec3::new(0.0, 0.0, floor), Vec3::new(2.0, 1.0, 1.0));
    let x = 1.2 + cap_shift;
    body.append(&cuboid(
        Vec3::new(x, 0.25, 0.9),
        Vec3::new(x + 0.5, 0.75, 1.4),
    ));
    body
}

/// `p` turned by `angle` about z and moved by `shift`.
fn moved(p: Vec3, angle: f64, shift: Vec3) -> Vec3 {
    let (s, c) = angle.sin_cos();
    Vec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z) + shift
}

/// `mesh` turned by `angle` about z and moved by `shift`.
fn placed(mesh: &TriMesh, angle: f64, shift: Vec3) -> TriMesh {
    mesh.map_positions(|p| moved(p, angle, shift)).unwrap()
}

/// Where each scene copy's template point lies, and the report.
fn search_scene(options: &MatchOptions) -> (Vec<Vec3>, f64, MatchReport) {
    let template = capped_block(0.0, 0.0);
    let shifts = [
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(0.0, 10.0, 0.0),
        Vec3::new(10.0, 10.0, 0.0),
        Vec3::new(0.0, 0.0, 0.0),
    ];
    let angle = 0.7;
    let mut scene = placed(&template, angle, shifts[0]);
    scene.append(&placed(&template, angle, shifts[1]));
    scene.append(&cuboid(
        Vec3::new(-3.0, 7.0, -0.5),
        Vec3::new(4.0, 13.0, 0.0),
    ));
    scene.append(&placed(&capped_block(-0.5, 0.0), angle, shifts[2]));
    scene.append(&placed(&capped_block(0.0, 0.3), angle, shifts[3]));
    let scene = Scene::new(scene, &SceneOptions::DEFAULT).unwrap();
    let report = search(&scene, &TemplateSource::Model(template), options, &mut ()).unwrap();
    let c = Vec3::from_array(report.template.center);
    let copies = shifts.iter().map(|&shift| moved(c, angle, shift)).collect();
    (copies, report.template.radius, report)
}

/// The instance at each copy, if any.
fn at_copies<'a>(
    report: &'a MatchReport,
    copies: &[Vec3],
    radius: f64,
) -> Vec<Option<&'a fast_reject::Instance>> {
    copies
        .iter()
        .map(|&c| {
            report
                .instances
                .iter()
                .find(|i| Vec3::from_array(i.position).distance(c) < 0.2 * radius)
        })
        .collect()
}

#[test]
fn each_instance_says_whether_it_is_a_whole_copy() {
    let (copies, radius, report) = search_scene(&MatchOptions::DEFAULT);
    let found = at_copies(&report, &copies, radius);
    let [alone, on_plate, _, bent] = found[..] else {
        unreachable!()
    };
    // The template may slide down the longer block, its cap hidden in it
    // (hidden surface is excused): the placement is ambiguous there, and
    // any within r_k of the copy is it.
    let inside = report
        .instances
        .iter()
        .find(|i| Vec3::from_array(i.position).distance(copies[2]) < radius);
    let alone = alone.expect("the copy alone is found");
    let on_plate = on_plate.expect("the copy on a plate is found");
    let inside =
        inside.expect("part-in-whole is the default: the copy inside a larger block is found");
    assert_eq!(alone.whole, Some(true), "{alone:?}");
    assert_eq!(on_plate.whole, Some(true), "{on_plate:?}");
    assert_eq!(inside.whole, Some(false), "{inside:?}");
    if let Some(bent) = bent {
        assert_eq!(bent.whole, Some(false), "{bent:?}");
    }
    // Exact copies fit within float rounding; the bent one measurably worse.
    for exact in [alone, on_plate] {
        assert!(exact.residual.unwrap() < 1e-4 * radius, "{exact:?}");
    }
    if let Some(bent) = bent {
        assert!(
            bent.residual.unwrap() > 10.0 * alone.residual.unwrap(),
            "{bent:?}"
        );
    }
}

#[test]
fn whole_copies_keeps_only_them() {
    let mut options = MatchOptions::DEFAULT;
    options.whole_copies = true;
    let (copies, radius, report) = search_scene(&options);
    let found = at_copies(&report, &copies, radius);
    assert!(found[0].is_some() && found[1].is_some(), "{report:?}");
    assert!(found[3].is_none(), "{report:?}");
    assert_eq!(report.instances.len(), 2, "{:?}", report.instances);
    assert!(report.instances.iter().all(|i| i.whole == Some(true)));
}
