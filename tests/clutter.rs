//! Clutter on a scene built in code, where the truth is exact: a template
//! standing free, the same template sunk into a slab, and a smaller decoy.
//! The sunk copy is found, and the decoy is not, because missing material
//! is not excused.

use fast_reject::TemplateSource;
use fast_reject::math::Vec3;
use fast_reject::mesh::TriMesh;
use fast_reject::mesh::shapes::{cuboid, uv_sphere};
use fast_reject::scene::{Scene, SceneOptions};
use fast_reject::search::{MatchOptions, MatchReport, search};

/// An asymmetric figure about 1.4 units tall: a block, a head off to one
/// side, a knob on the other (three overlapping shells).
fn figure() -> TriMesh {
    let mut m = cuboid(Vec3::new(-0.5, -0.3, 0.0), Vec3::new(0.5, 0.3, 0.8));
    m.append(&uv_sphere(Vec3::new(0.25, 0.0, 1.0), 0.35, 24, 48));
    m.append(&uv_sphere(Vec3::new(-0.45, 0.25, 0.3), 0.2, 16, 32));
    m
}

/// Rotation by `angle` about the unit axis `axis` (Rodrigues).
fn rotation(axis: Vec3, angle: f64) -> impl Fn(Vec3) -> Vec3 {
    let k = axis * (1.0 / axis.length());
    let (s, c) = angle.sin_cos();
    move |p: Vec3| p * c + k.cross(p) * s + k * (k.dot(p) * (1.0 - c))
}

struct Placed {
    turn: Box<dyn Fn(Vec3) -> Vec3>,
    scale: f64,
    shift: Vec3,
}

impl Placed {
    fn apply(&self, p: Vec3) -> Vec3 {
        (self.turn)(p * self.scale) + self.shift
    }
}

/// The slab, a free copy, a copy sunk 0.15 into the slab and tilted, a
/// decoy at 0.75 scale resting on the slab; returns the scene and the true
/// placements (free, sunk).
fn cluttered_scene() -> (TriMesh, Vec<Placed>) {
    let placements = vec![
        Placed {
            turn: Box::new(rotation(Vec3::new(0.0, 0.0, 1.0), 0.7)),
            scale: 1.0,
            shift: Vec3::new(-2.6, 0.0, 0.5),
        },
        Placed {
            turn: Box::new(rotation(Vec3::new(0.3, 1.0, 0.2), 0.25)),
            scale: 1.0,
            shift: Vec3::new(0.0, 0.3, -0.15),
        },
        Placed {
            turn: Box::new(rotation(Vec3::new(0.0, 0.0, 1.0), -1.1)),
            scale: 0.75,
            shift: Vec3::new(2.6, -0.2, 0.0),
        },
    ];
    let mut scene = cuboid(Vec3::new(-4.0, -2.0, -0.4), Vec3::new(4.0, 2.0, 0.0));
    let template = figure();
    for p in &placements {
        scene.append(&template.map_positions(|q| p.apply(q)).unwrap());
    }
    (scene, placements)
}

fn run(options: &MatchOptions) -> (MatchReport, Vec<Vec3>) {
    let (mesh, placements) = cluttered_scene();
    let scene = Scene::new(mesh, &SceneOptions::DEFAULT).unwrap();
    let report = search(&scene, &TemplateSource::Model(figure()), options, &mut ()).unwrap();
    let c = report.template.center;
    let c = Vec3::new(c[0], c[1], c[2]);
    let truth = placements.iter().map(|p| p.apply(c)).collect();
    (report, truth)
}

/// Which of `truth` the report found (within a tenth of the template's
/// radius), and how many reported instances match nothing.
fn found(report: &MatchReport, truth: &[Vec3]) -> (Vec<bool>, usize) {
    let tol = 0.1 * report.template.radius;
    let positions: Vec<Vec3> = report
        .instances
        .iter()
        .map(|i| Vec3::new(i.position[0], i.position[1], i.position[2]))
        .collect();
    let hits = truth
        .iter()
        .map(|t| positions.iter().any(|p| p.distance(*t) < tol))
        .collect();
    let stray = positions
        .iter()
        .filter(|p| truth.iter().all(|t| p.distance(*t) >= tol))
        .count();
    (hits, stray)
}

#[test]
fn finds_the_free_and_the_sunk_copy_but_not_the_decoy() {
    let (report, truth) = run(&MatchOptions::DEFAULT);
    let (hits, stray) = found(&report, &truth);
    assert_eq!(hits, [true, true, false], "{report:?}");
    assert_eq!(stray, 0, "{report:?}");
}

#[test]
fn the_slab_is_not_in_the_sunk_copys_part() {
    // The slab is larger than any of the figure's shells, so it is not
    // gathered with them: the copy's surface inside it is not hidden, and
    // the copy is found with no hidden surface excused.
    let mut options = MatchOptions::DEFAULT;
    options.hidden_surface = 0.0;
    let (report, truth) = run(&options);
    let (hits, stray) = found(&report, &truth);
    assert_eq!(hits, [true, true, false], "{report:?}");
    assert_eq!(stray, 0, "{report:?}");
}
