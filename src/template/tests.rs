//! Templates against small scenes built from `crate::mesh::shapes`: the
//! errors a user can cause, each with the advice it gives.

use super::*;
use crate::exec::Threads;
use crate::mesh::shapes::{cuboid, uv_sphere};
use crate::options::MatchOptions;
use crate::scene::SceneOptions;

/// [`VoxelTemplate::new`] as every test here calls it: the one place to change
/// when its signature does.
fn voxel_template(source: &TemplateSource, scene: &Scene, layers: usize) -> Result<VoxelTemplate> {
    let options = MatchOptions {
        layers,
        backend: Threads::Serial,
        ..MatchOptions::DEFAULT
    };
    VoxelTemplate::new(source, scene, &scene.lattice(), &options)
}

/// [`CurvatureTemplate::new`], likewise.
fn surface_template(
    source: &TemplateSource,
    scene: &Scene,
    layers: usize,
) -> Result<CurvatureTemplate> {
    CurvatureTemplate::new(source, scene, layers)
}

/// A unit sphere (2 across, diagonal 2 sqrt 3) at `resolution`.
fn sphere_scene(resolution: u32) -> Scene {
    Scene::new(
        uv_sphere(Vec3::ZERO, 1.0, 24, 48),
        &SceneOptions::DEFAULT
            .with_resolution(resolution)
            .with_backend(Threads::Serial),
    )
    .unwrap()
}

fn selection(center: [f64; 3], radius: f64) -> TemplateSource {
    TemplateSource::Selection { center, radius }
}

/// A cube of side `side` centred at the origin.
fn cube(side: f64) -> TemplateSource {
    let h = side / 2.0;
    TemplateSource::Model(cuboid(Vec3::new(-h, -h, -h), Vec3::new(h, h, h)))
}

#[test]
fn a_selection_is_snapped_to_the_surface_with_evenly_spaced_radii() {
    let scene = sphere_scene(32);
    let t = voxel_template(&selection([1.3, 0.0, 0.0], 0.8), &scene, 4).unwrap();
    assert!((t.center().length() - 1.0).abs() < 0.01, "{:?}", t.center());
    assert!(t.center().x > 0.99, "{:?}", t.center());
    assert_eq!(t.radius(), 0.8);
    for (r, expected) in t.radii().iter().zip([0.2, 0.4, 0.6, 0.8]) {
        assert!((r - expected).abs() < 1e-12, "{:?}", t.radii());
    }
    assert_eq!(t.radii().len(), 4);
    let s = surface_template(&selection([1.3, 0.0, 0.0], 0.8), &scene, 4).unwrap();
    assert_eq!(s.radii(), t.radii());
    assert!(s.center().distance(t.center()) < 0.1);
}

#[test]
fn a_model_template_reaches_its_farthest_vertex() {
    let scene = sphere_scene(32);
    let t = voxel_template(&cube(0.5), &scene, 5).unwrap();
    // c_T is on the cube's surface; the farthest corner is at most a
    // diagonal (0.5 sqrt 3) away and at least half of one.
    let r = t.radius();
    assert!(
        (0.25 * 3f64.sqrt()..=0.5 * 3f64.sqrt() + 1e-9).contains(&r),
        "{r}"
    );
    assert_eq!(t.radii().len(), 5);
    assert_eq!(*t.radii().last().unwrap(), r);
}

#[test]
fn zero_layers_is_an_invalid_option() {
    let scene = sphere_scene(32);
    for source in [cube(0.5), selection([1.0, 0.0, 0.0], 0.8)] {
        let e = voxel_template(&source, &scene, 0).err().unwrap();
        assert!(
            matches!(e, Error::InvalidOption { name: "layers", .. }),
            "{e}"
        );
        let e = surface_template(&source, &scene, 0).err().unwrap();
        assert!(
            matches!(e, Error::InvalidOption { name: "layers", .. }),
            "{e}"
        );
    }
}

#[test]
fn a_selection_sphere_that_is_not_a_sphere_is_an_invalid_option() {
    let scene = sphere_scene(32);
    for (center, radius) in [
        ([1.0, 0.0, 0.0], f64::NAN),
        ([1.0, 0.0, 0.0], -0.5),
        ([1.0, 0.0, 0.0], 0.0),
        ([1.0, 0.0, 0.0], f64::INFINITY),
        ([f64::NAN, 0.0, 0.0], 0.5),
        ([1.0, f64::NEG_INFINITY, 0.0], 0.5),
    ] {
        let source = selection(center, radius);
        let e = voxel_template(&source, &scene, 4).err().unwrap();
        assert!(
            matches!(e, Error::InvalidOption { name: "select", .. }),
            "{center:?} {radius}: {e}"
        );
        assert!(e.to_string().contains("positive radius"), "{e}");
        let e = surface_template(&source, &scene, 4).err().unwrap();
        assert!(
            matches!(e, Error::InvalidOption { name: "select", .. }),
            "{e}"
        );
    }
}

#[test]
fn a_selection_that_misses_the_scene_says_how_far_it_is() {
    let scene = sphere_scene(32);
    // Outside, 4 from the surface; inside the solid, 1 from it.
    for (center, radius, gap) in [([5.0, 0.0, 0.0], 0.5, 4.0), ([0.0; 3], 0.5, 1.0)] {
        let source = selection(center, radius);
        for e in [
            voxel_template(&source, &scene, 4).err().unwrap(),
            surface_template(&source, &scene, 4).err().unwrap(),
        ] {
            let Error::SelectionMissesScene {
                center: c,
                radius: r,
                distance,
            } = e
            else {
                panic!("{center:?}: {e}");
            };
            assert_eq!((c, r), (center, radius));
            // The sphere's facets lie a little inside the unit sphere.
            assert!(
                (gap - 0.01..=gap + 0.01).contains(&distance),
                "{center:?}: {distance}"
            );
        }
    }
    // Touching the surface is enough.
    assert!(voxel_template(&selection([1.5, 0.0, 0.0], 0.51), &scene, 1).is_ok());
}

#[test]
fn a_template_larger_than_the_scene_is_refused_with_advice() {
    let scene = sphere_scene(32);
    let diagonal = scene.mesh().bounds().extent().length();
    // A model in millimetres against a scene in metres.
    let huge = cube(2000.0);
    for e in [
        voxel_template(&huge, &scene, 4).err().unwrap(),
        surface_template(&huge, &scene, 4).err().unwrap(),
    ] {
        let Error::TemplateLargerThanScene {
            template_size,
            scene_size,
            ref advice,
        } = e
        else {
            panic!("{e}");
        };
        assert_eq!(scene_size, diagonal);
        // The cube's bounding sphere: its diagonal.
        assert!(
            (template_size / (2000.0 * 3f64.sqrt()) - 1.0).abs() < 1e-6,
            "{template_size}"
        );
        assert!(advice.contains("same units"), "{advice}");
    }
    // A selection sphere wider than the whole scene.
    let wide = selection([1.0, 0.0, 0.0], 1.01 * diagonal);
    for e in [
        voxel_template(&wide, &scene, 4).err().unwrap(),
        surface_template(&wide, &scene, 4).err().unwrap(),
    ] {
        let Error::TemplateLargerThanScene {
            template_size,
            ref advice,
            ..
        } = e
        else {
            panic!("{e}");
        };
        assert_eq!(template_size, 2.02 * diagonal);
        assert!(advice.contains("pick a radius"), "{advice}");
    }
    // At the diagonal it is still accepted.
    assert!(voxel_template(&selection([1.0, 0.0, 0.0], diagonal), &scene, 4).is_ok());
}

/// The resolution a [`Error::TemplateTooSmall`] advises.
fn advised_resolution(e: &Error) -> u32 {
    let text = e.to_string();
    let Some(rest) = text.split("raise the resolution to at least ").nth(1) else {
        panic!("no resolution advised: {text}");
    };
    rest.split(' ').next().unwrap().parse().unwrap()
}

#[test]
fn a_template_too_small_names_the_lowest_resolution_that_fits() {
    // At 32 voxels across the sphere (voxel 1/16), a first radius of
    // 0.035 is 0.56 voxels: 1.5 needs 32 * 1.5 / 0.56 = 85.7, so 86.
    let source = selection([1.0, 0.0, 0.0], 0.35);
    let e = voxel_template(&source, &sphere_scene(32), 10)
        .err()
        .unwrap();
    let Error::TemplateTooSmall {
        radius_voxels,
        min_voxels,
        ..
    } = e
    else {
        panic!("{e}");
    };
    assert!((radius_voxels - 0.56).abs() < 1e-9, "{radius_voxels}");
    assert_eq!(min_voxels, MIN_RADIUS_VOXELS);
    let fits = advised_resolution(&e);
    assert_eq!(fits, 86, "{e}");
    assert!(voxel_template(&source, &sphere_scene(fits), 10).is_ok());
    let below = voxel_template(&source, &sphere_scene(fits - 1), 10);
    assert!(matches!(below, Err(Error::TemplateTooSmall { .. })));
    // Fewer layers, the other advice, fit too.
    assert!(voxel_template(&source, &sphere_scene(32), 3).is_ok());
}

#[test]
fn a_model_template_too_small_is_an_error_not_a_panic() {
    // Smaller than one voxel of the scene.
    let scene = sphere_scene(32);
    for side in [0.1, 0.01] {
        let e = voxel_template(&cube(side), &scene, 4).err().unwrap();
        assert!(matches!(e, Error::TemplateTooSmall { .. }), "{side}: {e}");
    }
}

#[test]
fn a_template_no_resolution_fits_says_so() {
    let source = selection([1.0, 0.0, 0.0], 1e-4);
    let e = voxel_template(&source, &sphere_scene(32), 10)
        .err()
        .unwrap();
    assert!(matches!(e, Error::TemplateTooSmall { .. }), "{e}");
    assert!(e.to_string().contains("no resolution fits"), "{e}");
}
