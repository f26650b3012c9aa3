//! Parts that repeat, found without a template.
//!
//! CAD and BIM exports reach the web flattened: every copy of a bolt or a
//! light fitting is stored again, already moved into place. Each copy
//! keeps its source mesh's triangles in their order, so a rigid copy is
//! found vertex for vertex ([`congruent_parts`]): the scene's connected
//! pieces are grouped by the motion that takes one onto another, and
//! pieces that repeat together, at the same relative pose, are one part
//! (`bodies`): a CAD body arrives as tens of unwelded face pieces, and a
//! user counts the body.

mod bodies;
mod congruent;
mod instanced;
mod mirrors;
mod overlaps;

pub use congruent::{CopyOf, MirrorImages, congruent_parts};
pub use instanced::{Instanced, Placement, instanced_model, split_by_material};

use crate::cascade::{Observer, Progress, Steps};
use crate::error::Result;
use crate::exec::Threads;
use crate::math::Vec3;
use crate::mesh::{
    TriMesh, connected_components, minimal_bounding_sphere, stored_pieces, weld_vertices_on,
};

/// One place a repeated part stands.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct RepeatCopy {
    /// The motion from the family's representative (its first copy, where
    /// it stands in the scene) to this copy: a row-major 4x4, as an
    /// instance's pose.
    pub pose: [[f64; 4]; 4],
    /// The farthest a vertex of the representative, moved by `pose`,
    /// lands from this copy's: float rounding for an exact copy.
    pub residual: f64,
    /// Whether the copy is the representative's mirror image: `pose` is
    /// a reflection.
    pub mirrored: bool,
    /// The copy's triangles, ascending (not in the JSON: a building's
    /// would be its whole triangle list again).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub triangles: Vec<u32>,
}

/// A part that occurs more than once, and every copy of it.
#[derive(Clone, Debug, PartialEq)]
pub struct Family {
    /// The centre of the representative's minimal bounding sphere, in the
    /// scene: the point a copy's pose moves onto that copy's own.
    pub center: Vec3,
    /// That sphere's radius.
    pub radius: f64,
    /// How many pieces a copy was matched as: its connected components,
    /// welded, or one for a copy taken out of a component it shares with
    /// other copies.
    pub pieces: usize,
    /// The copies, the representative first (its pose the identity).
    pub copies: Vec<RepeatCopy>,
}

impl Family {
    /// The triangles each copy has.
    pub fn triangles(&self) -> usize {
        self.copies[0].triangles.len()
    }
}

/// As the CLI's JSON and JavaScript show a family: the RESULT format of
/// `bench/evaluate_families.py`, with each copy's triangle count.
#[cfg(feature = "serde")]
impl serde::Serialize for Family {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut family = serializer.serialize_struct("Family", 5)?;
        family.serialize_field("center", &self.center.to_array())?;
        family.serialize_field("radius", &self.radius)?;
        family.serialize_field("triangles", &self.triangles())?;
        family.serialize_field("pieces", &self.pieces)?;
        family.serialize_field("copies", &self.copies)?;
        family.end()
    }
}

/// The repeated parts of `mesh`: families of two copies or more, the one
/// with the most triangles in all first, each copy's triangles taken by no
/// other family. A mirror image is a copy too, marked as one (an instanced
/// model places left and right by one mesh and a reflecting node).
pub fn find_repeats(mesh: &TriMesh, backend: Threads) -> Vec<Family> {
    match find_repeats_observed(mesh, backend, &mut ()) {
        Ok(families) => families,
        Err(_) => unreachable!("no observer to cancel"),
    }
}

/// [`find_repeats`], telling `observer` as each of its
/// [`REPEAT_STEPS`] ends ([`Progress::REPEATS`]); a `Break` from it stops
/// the work with [`Error::Cancelled`](crate::Error::Cancelled).
pub fn find_repeats_observed(
    mesh: &TriMesh,
    backend: Threads,
    observer: &mut dyn Observer,
) -> Result<Vec<Family>> {
    let mut steps = Steps::new(observer, Progress::REPEATS, REPEAT_STEPS);
    let pieces = pieces_of(mesh, backend);
    steps.done()?;
    let lists: Vec<&[u32]> = pieces.iter().map(|p| p.as_slice()).collect();
    let mut copies = congruent_parts(mesh, &lists, backend, MirrorImages::Refused);
    steps.done()?;
    mirrors::mirror_lone_pieces(mesh, &pieces, &mut copies, backend);
    steps.done()?;
    let families: Vec<Family> = bodies::bodies(mesh, &pieces, &copies)
        .into_iter()
        .map(|group| family_of(mesh, &pieces, group))
        .collect();
    steps.done()?;
    let mut families = mirrors::with_mirror_images(mesh, families, backend);
    steps.done()?;
    for family in &mut families {
        // The representative first, the rest in the order the file has them.
        family.copies[1..].sort_by_key(|c| c.triangles[0]);
    }
    families.sort_by_key(|f| std::cmp::Reverse(f.triangles() * f.copies.len()));
    Ok(families)
}

/// The steps [`find_repeats_observed`] reports: the pieces, their copies,
/// the lone pieces' mirror images, the bodies, and the families' mirror
/// images.
pub const REPEAT_STEPS: usize = 5;

/// The pieces to match: the connected components (welded, so that a body
/// split along seams is one), except where a component that copies
/// nothing and that nothing copies is itself copies of one body
/// ([`overlaps`]): there, those copies.
fn pieces_of(mesh: &TriMesh, backend: Threads) -> Vec<Vec<u32>> {
    let components = connected_components(mesh, backend);
    let lists: Vec<&[u32]> = components.iter().map(|c| c.as_slice()).collect();
    let copies = congruent_parts(mesh, &lists, backend, MirrorImages::Refused);
    let mut repeats = vec![false; components.len()];
    for (c, copy) in copies.iter().enumerate() {
        if let Some(copy) = copy {
            repeats[c] = true;
            repeats[copy.original] = true;
        }
    }
    if repeats.iter().all(|&r| r) {
        return components;
    }
    let mut component_of = vec![0u32; mesh.triangles().len()];
    for (c, triangles) in components.iter().enumerate() {
        for &t in triangles {
            component_of[t as usize] = c as u32;
        }
    }
    // A stored piece lies in one component: the weld only joins.
    let mut stored: Vec<Vec<Vec<u32>>> = vec![Vec::new(); components.len()];
    for piece in stored_pieces(mesh, backend) {
        let c = component_of[piece[0] as usize] as usize;
        if !repeats[c] {
            stored[c].push(piece);
        }
    }
    let (welded, _) = weld_vertices_on(mesh.positions(), backend);
    let mut pieces = Vec::with_capacity(components.len());
    for ((component, repeats), stored) in components.into_iter().zip(repeats).zip(stored) {
        match (!repeats)
            .then(|| overlaps::copies_within(mesh, &stored, &welded))
            .flatten()
        {
            Some(copies) => pieces.extend(copies),
            None => pieces.push(component),
        }
    }
    pieces.sort_by_key(|piece| piece[0]);
    pieces
}

/// The family of a body's copies: each copy's pieces, its pose and
/// residual.
fn family_of(mesh: &TriMesh, pieces: &[Vec<u32>], group: bodies::Body) -> Family {
    let copies: Vec<RepeatCopy> = group
        .copies
        .into_iter()
        .map(|copy| {
            let triangles = copy.triangles(pieces);
            RepeatCopy {
                pose: copy.pose.to_rows(),
                residual: copy.residual,
                mirrored: copy.pose.rotation.determinant() < 0.0,
                triangles,
            }
        })
        .collect();
    let sphere = bounding_sphere(mesh, &copies[0].triangles);
    Family {
        center: sphere.0,
        radius: sphere.1,
        pieces: group.pieces,
        copies,
    }
}

/// The minimal bounding sphere of `triangles`' vertices: centre, radius.
fn bounding_sphere(mesh: &TriMesh, triangles: &[u32]) -> (Vec3, f64) {
    let vertices: Vec<Vec3> = mesh
        .vertices_of(triangles)
        .into_iter()
        .map(|v| mesh.vertex(v))
        .collect();
    minimal_bounding_sphere(&vertices).map_or((Vec3::ZERO, 0.0), |s| (s.center, s.radius))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::cuboid;
    use glam::DQuat;

    /// A box with one corner pulled out: no turn maps it onto itself.
    fn lopsided(min: Vec3) -> TriMesh {
        let far = min + Vec3::new(1.0, 2.0, 3.0);
        cuboid(min, far)
            .map_positions(|p| {
                if p == far {
                    p + Vec3::new(0.4, 0.2, 0.5)
                } else {
                    p
                }
            })
            .unwrap()
    }

    fn turn(i: usize) -> DQuat {
        let a = 0.7 + 1.1 * i as f64;
        DQuat::from_axis_angle(Vec3::new(a.sin(), a.cos(), 0.5).normalize(), a)
    }

    fn placed(mesh: &TriMesh, turn: DQuat, shift: Vec3) -> TriMesh {
        mesh.map_positions(|p| turn * p + shift).unwrap()
    }

    fn scene_of(parts: &[TriMesh]) -> TriMesh {
        let mut scene = parts[0].clone();
        for part in &parts[1..] {
            scene.append(part);
        }
        scene
    }

    /// Where `pose` moves `p`.
    fn moved(pose: &[[f64; 4]; 4], p: Vec3) -> Vec3 {
        let row = |r: &[f64; 4]| r[0] * p.x + r[1] * p.y + r[2] * p.z + r[3];
        Vec3::new(row(&pose[0]), row(&pose[1]), row(&pose[2]))
    }

    #[test]
    fn turned_copies_are_one_family_with_the_poses_they_were_placed_at() {
        let part = lopsided(Vec3::ZERO);
        let mut parts: Vec<TriMesh> = (0..4)
            .map(|i| placed(&part, turn(i), Vec3::new(10.0 * i as f64, 0.0, 0.0)))
            .collect();
        // A part found once is no family.
        parts.push(cuboid(Vec3::splat(-9.0), Vec3::new(-8.0, -7.0, -4.0)));
        let scene = scene_of(&parts);
        let families = find_repeats(&scene, Threads::Parallel);
        assert_eq!(families.len(), 1);
        let family = &families[0];
        assert_eq!(
            (family.copies.len(), family.pieces, family.triangles()),
            (4, 1, 12)
        );
        // Each pose takes the first copy onto the one placed there.
        let far = Vec3::new(1.4, 2.2, 3.5);
        let first = turn(0) * far;
        for (i, copy) in family.copies.iter().enumerate() {
            let want = turn(i) * far + Vec3::new(10.0 * i as f64, 0.0, 0.0);
            assert!(moved(&copy.pose, first).distance(want) < 1e-5, "copy {i}");
            assert!(copy.residual < 1e-5);
            assert_eq!(
                copy.triangles,
                (12 * i as u32..12 * i as u32 + 12).collect::<Vec<_>>()
            );
        }
    }

    /// `mesh` reflected in x, moved by `shift`, its triangles turned over
    /// (read backwards, to face outwards again) where `turned_over`.
    fn mirrored(mesh: &TriMesh, shift: Vec3, turned_over: bool) -> TriMesh {
        let positions = mesh
            .positions()
            .iter()
            .map(|p| {
                [
                    -p[0] + shift.x as f32,
                    p[1] + shift.y as f32,
                    p[2] + shift.z as f32,
                ]
            })
            .collect();
        let triangles = mesh
            .triangles()
            .iter()
            .map(|&[a, b, c]| if turned_over { [a, c, b] } else { [a, b, c] })
            .collect();
        TriMesh::new(positions, triangles).unwrap()
    }

    #[test]
    fn mirror_images_are_copies_marked_as_such_whichever_way_they_face() {
        let part = lopsided(Vec3::ZERO);
        let scene = scene_of(&[
            part.clone(),
            mirrored(&part, Vec3::new(10.0, 0.0, 0.0), false),
            mirrored(&part, Vec3::new(20.0, 0.0, 0.0), true),
            placed(&part, turn(2), Vec3::new(30.0, 0.0, 0.0)),
        ]);
        let families = find_repeats(&scene, Threads::Serial);
        assert_eq!(families.len(), 1);
        let copies = &families[0].copies;
        let mirrored: Vec<bool> = copies.iter().map(|c| c.mirrored).collect();
        assert_eq!(mirrored, [false, true, true, false]);
        // The far corner lands where each copy has it.
        let far = Vec3::new(1.4, 2.2, 3.5);
        let wants = [
            far,
            Vec3::new(10.0 - far.x, far.y, far.z),
            Vec3::new(20.0 - far.x, far.y, far.z),
            turn(2) * far + Vec3::new(30.0, 0.0, 0.0),
        ];
        for (copy, want) in copies.iter().zip(wants) {
            assert!(moved(&copy.pose, far).distance(want) < 1e-5);
            assert!(copy.residual < 1e-5);
        }
        // The search's copy test still refuses them.
        let lists: Vec<Vec<u32>> = (0..4).map(|k| (12 * k..12 * k + 12).collect()).collect();
        let lists: Vec<&[u32]> = lists.iter().map(|l| l.as_slice()).collect();
        let refused = congruent_parts(&scene, &lists, Threads::Serial, MirrorImages::Refused);
        assert_eq!(refused.iter().filter(|c| c.is_some()).count(), 1);
    }

    #[test]
    fn a_pair_of_mirror_images_that_repeats_stays_one_part() {
        // A wheel pair (a part and its mirror image side by side) placed
        // twice is one part of two copies, not one wheel of four; a left
        // and a right bracket found once each are one part, one mirrored.
        let wheel = lopsided(Vec3::new(1.0, 0.0, 0.0));
        let pair = scene_of(&[wheel.clone(), mirrored(&wheel, Vec3::ZERO, true)]);
        let bracket = cuboid(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.2))
            .map_positions(|p| {
                if p == Vec3::ONE.with_z(0.2) {
                    p + Vec3::X
                } else {
                    p
                }
            })
            .unwrap();
        let scene = scene_of(&[
            pair.clone(),
            placed(&pair, turn(3), Vec3::new(0.0, 30.0, 0.0)),
            placed(&bracket, DQuat::IDENTITY, Vec3::new(0.0, -30.0, 0.0)),
            mirrored(&bracket, Vec3::new(9.0, -30.0, 0.0), false),
        ]);
        let families = find_repeats(&scene, Threads::Serial);
        let shapes: Vec<(usize, usize, usize, usize)> = families
            .iter()
            .map(|f| {
                let mirrored = f.copies.iter().filter(|c| c.mirrored).count();
                (f.copies.len(), mirrored, f.pieces, f.triangles())
            })
            .collect();
        assert_eq!(shapes, [(2, 0, 2, 24), (2, 1, 1, 12)]);
    }

    #[test]
    fn near_twins_are_not_copies() {
        // A corner moved by a thousandth of the part's size, and a part
        // turned inside out (its triangles read backwards, not reflected).
        let part = lopsided(Vec3::ZERO);
        let twin = part
            .map_positions(|p| {
                let p = if p == Vec3::ZERO {
                    Vec3::splat(0.004)
                } else {
                    p
                };
                turn(1) * p + Vec3::new(20.0, 0.0, 0.0)
            })
            .unwrap();
        let inside_out = mirrored(
            &mirrored(&part, Vec3::ZERO, false),
            Vec3::new(40.0, 0.0, 0.0),
            true,
        );
        let scene = scene_of(&[part, twin, inside_out]);
        assert!(find_repeats(&scene, Threads::Serial).is_empty());
    }

    #[test]
    fn pieces_that_move_together_are_one_part() {
        // A body of two pieces apart, three times; a second kind of piece
        // stands at a different place beside each copy, so it moves with
        // none.
        let body = scene_of(&[
            lopsided(Vec3::ZERO),
            cuboid(Vec3::new(3.0, 0.0, 0.0), Vec3::new(3.5, 0.5, 4.0)),
        ]);
        let loner = cuboid(Vec3::ZERO, Vec3::new(0.3, 0.6, 0.9));
        let mut parts = Vec::new();
        for i in 0..3 {
            let shift = Vec3::new(0.0, 20.0 * i as f64, 0.0);
            parts.push(placed(&body, turn(i), shift));
            let beside = Vec3::new(-3.0 - i as f64, 0.0, 0.0);
            parts.push(placed(&loner, DQuat::IDENTITY, shift + beside));
        }
        let families = find_repeats(&scene_of(&parts), Threads::Parallel);
        let shapes: Vec<(usize, usize, usize)> = families
            .iter()
            .map(|f| (f.copies.len(), f.pieces, f.triangles()))
            .collect();
        assert_eq!(shapes, [(3, 2, 24), (3, 1, 12)]);
    }

    #[test]
    fn a_symmetric_piece_stored_turned_still_moves_with_its_body() {
        // A body of a lopsided piece and a plain box beside it. In the
        // second copy the box is stored turned half way about its own
        // axis first: the same place, but vertex for vertex its motion is
        // the body's composed with the box's symmetry.
        let box_piece = cuboid(Vec3::new(3.0, 0.0, 0.0), Vec3::new(3.5, 0.5, 4.0));
        let half_turn = DQuat::from_rotation_z(std::f64::consts::PI);
        let axis = Vec3::new(3.25, 0.25, 0.0);
        let turned_box = box_piece
            .map_positions(|p| half_turn * (p - axis) + axis)
            .unwrap();
        let shift = Vec3::new(0.0, 20.0, 0.0);
        let scene = scene_of(&[
            lopsided(Vec3::ZERO),
            box_piece,
            placed(&lopsided(Vec3::ZERO), turn(1), shift),
            placed(&turned_box, turn(1), shift),
        ]);
        let families = find_repeats(&scene, Threads::Serial);
        let shapes: Vec<(usize, usize, usize)> = families
            .iter()
            .map(|f| (f.copies.len(), f.pieces, f.triangles()))
            .collect();
        assert_eq!(shapes, [(2, 2, 24)]);
    }

    #[test]
    fn copies_that_touch_at_shared_vertices_are_taken_apart() {
        // Three bricks in a row, each face to face with the next: welded,
        // they are one component.
        let brick = lopsided(Vec3::ZERO)
            .map_positions(|p| p.min(Vec3::new(1.0, 2.0, 3.0)))
            .unwrap();
        let row: Vec<TriMesh> = (0..3)
            .map(|i| placed(&brick, DQuat::IDENTITY, Vec3::new(i as f64, 0.0, 0.0)))
            .collect();
        let scene = scene_of(&row);
        assert_eq!(connected_components(&scene, Threads::Serial).len(), 1);
        let families = find_repeats(&scene, Threads::Serial);
        assert_eq!(families.len(), 1);
        assert_eq!(families[0].copies.len(), 3);
    }

    #[test]
    fn a_part_stored_as_two_congruent_halves_is_one_part() {
        // A closed box stored as two open trays, each the other turned
        // over: they meet rim to rim, one surface cut in two.
        let closed = cuboid(Vec3::ZERO, Vec3::new(1.0, 2.0, 1.0));
        let tray = closed.subset(&[0, 1, 4, 5, 6, 7, 8, 9, 10, 11]);
        let over = tray
            .map_positions(|p| Vec3::new(p.x, 2.0 - p.y, 2.0 - p.z))
            .unwrap();
        let scene = scene_of(&[tray, over]);
        assert_eq!(stored_pieces(&scene, Threads::Serial).len(), 2);
        assert_eq!(connected_components(&scene, Threads::Serial).len(), 1);
        assert!(find_repeats(&scene, Threads::Serial).is_empty());
    }

    #[test]
    fn overlapping_copies_of_a_body_with_a_piece_twice_are_taken_apart() {
        // A body of three welded pieces, a bar and two equal cubes on it,
        // and a second copy a unit along, its bar face to face with the
        // first's: one component, four cubes, two bars.
        let body = scene_of(&[
            lopsided(Vec3::ZERO),
            cuboid(Vec3::new(0.0, 0.0, 3.0), Vec3::new(1.0, 1.0, 4.0)),
            cuboid(Vec3::new(0.0, 1.0, 3.0), Vec3::new(1.0, 2.0, 4.0)),
        ]);
        let next = placed(&body, DQuat::IDENTITY, Vec3::X);
        let scene = scene_of(&[body, next]);
        assert_eq!(connected_components(&scene, Threads::Serial).len(), 1);
        let families = find_repeats(&scene, Threads::Serial);
        assert_eq!(families.len(), 1);
        let family = &families[0];
        // Welded on its own, a copy's three stored pieces are one.
        assert_eq!(
            (family.copies.len(), family.pieces, family.triangles()),
            (2, 1, 36)
        );
        assert!(moved(&family.copies[1].pose, Vec3::ZERO).distance(Vec3::X) < 1e-6);
    }
}
