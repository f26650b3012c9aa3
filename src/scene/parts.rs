//! A scene's parts: its connected components, or those that may be shells
//! of one copy joined (a template of several shells), each with its
//! bounding sphere and box.

use crate::exec::Threads;
use crate::math::{Aabb, Vec3};
use crate::mesh::{TriMesh, VertexNumbering, minimal_bounding_sphere};

/// One connected component of the scene's mesh: the voxel descriptors see
/// a candidate's own part only, so that neighbours touching it or sitting
/// in it do not hide it.
#[derive(Clone, Debug)]
pub struct ScenePart {
    triangles: Vec<u32>,
    radius: f64,
    bounds: Aabb,
    /// How many connected components it joins.
    components: usize,
}

impl ScenePart {
    /// The parts of `mesh` made of each of `lists`, their spheres and boxes
    /// found on `backend`'s threads.
    pub(super) fn all(mesh: &TriMesh, lists: Vec<Vec<u32>>, backend: Threads) -> Vec<ScenePart> {
        let shapes = backend.map_each(lists.len(), |k| ScenePart::shape(mesh, &lists[k]));
        lists
            .into_iter()
            .zip(shapes)
            .map(|(triangles, (radius, bounds))| ScenePart {
                triangles,
                radius,
                bounds,
                components: 1,
            })
            .collect()
    }

    /// The minimal bounding sphere's radius and the box of `triangles`'
    /// vertices, each read once.
    fn shape(mesh: &TriMesh, triangles: &[u32]) -> (f64, Aabb) {
        let mut numbering = VertexNumbering::for_part(mesh, triangles);
        let mut vertices = Vec::new();
        for &t in triangles {
            for v in mesh.triangles()[t as usize] {
                if numbering.number(v).1 {
                    vertices.push(mesh.vertex(v));
                }
            }
        }
        (
            minimal_bounding_sphere(&vertices).map_or(0.0, |s| s.radius),
            Aabb::around(vertices).expect("a part has vertices"),
        )
    }

    /// The radius of the part's minimal bounding sphere.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Its triangles in the scene's mesh.
    pub fn triangles(&self) -> &[u32] {
        &self.triangles
    }

    /// Its bounding box.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// How many connected components it joins: one, but for a template of
    /// several shells.
    pub fn components(&self) -> usize {
        self.components
    }
}

/// How the shells of a template of several are gathered into one part:
/// the scene's components no larger than the template's largest shell,
/// joined where their boxes come as near each other as the template's
/// shells do.
///
/// A copy's shell, or a piece of one, is no larger than the template's
/// largest; so a larger component is not one and stays out of the copy's
/// part: the body around a wheel pair, the axle between its wheels, the
/// thigh a knee touches. (A copy whose shells are fused is one component
/// as large as the template, searched alone.) And since a box holds its
/// shell, two boxes are never further apart than any two of their shells'
/// points: the template's points measure the gap, whatever the copy's
/// rotation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShellRule {
    /// The largest bounding radius a copy's shell, or a piece of one, can
    /// have.
    pub largest: f64,
    /// Boxes at most this far apart are joined.
    pub gap: f64,
    /// A part smaller than this cannot hold a copy alone.
    pub holds: f64,
}

/// A copy's shell may be this much larger than the template's: meshing and
/// rounding move a bounding sphere a little.
const SHELL_RADIUS_SLACK: f64 = 1.05;

/// At most this many point pairs are measured between a template's shells.
const GAP_PAIRS: usize = 1 << 22;

/// The gap between the shells of a template of more is not measured: its
/// diameter bounds it (every pair of shells is measured, so the work grows
/// as the square of their number).
const MEASURED_SHELLS: usize = 64;

impl ShellRule {
    /// The rule for a template `mesh` of bounding radius `radius` made of
    /// `shells` (triangle lists): its largest shell, and the widest step
    /// that links them all (single linkage over their nearest points);
    /// `holds` is the smallest part that can hold a copy.
    pub fn of_template(
        mesh: &TriMesh,
        shells: &[Vec<u32>],
        radius: f64,
        holds: f64,
        backend: Threads,
    ) -> ShellRule {
        let largest = ScenePart::all(mesh, shells.to_vec(), backend)
            .iter()
            .map(ScenePart::radius)
            .fold(0.0, f64::max);
        let rule = |gap: f64| ShellRule {
            largest: SHELL_RADIUS_SLACK * largest,
            // Rounding of the copy's own positions.
            gap: gap + 1e-6 * radius,
            holds,
        };
        if shells.len() > MEASURED_SHELLS {
            return rule(2.0 * radius);
        }
        let pair_count = shells.len() * shells.len().saturating_sub(1) / 2;
        // Points spread over each shell: the nearest pair among them is a
        // real pair, so the gap measured is never too small.
        let per_shell = ((GAP_PAIRS / pair_count.max(1)) as f64).sqrt().max(8.0) as usize;
        let points: Vec<Vec<Vec3>> = shells
            .iter()
            .map(|triangles| {
                let corners = mesh.vertices_of(triangles);
                let step = corners.len().div_ceil(per_shell).max(1);
                corners
                    .iter()
                    .step_by(step)
                    .map(|&v| mesh.vertex(v))
                    .collect()
            })
            .collect();
        let mut links: Vec<(f64, usize, usize)> = Vec::with_capacity(pair_count);
        for a in 0..points.len() {
            for b in a + 1..points.len() {
                let nearest = points[a]
                    .iter()
                    .flat_map(|p| points[b].iter().map(move |q| p.distance(*q)))
                    .fold(f64::INFINITY, f64::min);
                links.push((nearest, a, b));
            }
        }
        links.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut group: Vec<usize> = (0..shells.len()).collect();
        let mut joined = 1;
        let mut gap: f64 = 0.0;
        for (distance, a, b) in links {
            if joined == shells.len() {
                break;
            }
            let (ra, rb) = (root(&mut group, a), root(&mut group, b));
            if ra != rb {
                group[ra.max(rb)] = ra.min(rb);
                joined += 1;
                gap = gap.max(distance);
            }
        }
        rule(gap)
    }
}

fn root(group: &mut [usize], mut i: usize) -> usize {
    while group[i] != i {
        group[i] = group[group[i]];
        i = group[i];
    }
    i
}

/// The parts `rule` lets be shells of one copy, and each larger part with
/// the groups its box meets; the groups are also searched alone, so a copy
/// may be found twice.
pub(super) fn join_shells(
    mesh: &TriMesh,
    parts: &[ScenePart],
    rule: ShellRule,
    backend: Threads,
) -> Vec<ScenePart> {
    let shells = shell_groups(parts, rule);
    let mut joined = joined_parts(mesh, parts, &shells, backend);
    // A larger part may still hold a copy's shell inside it (a block that
    // runs on below, the paper's part-in-whole): it is searched with the
    // groups its box meets that cannot hold a copy alone. Those that can
    // are searched alone: a knee is not searched again with its thigh.
    let mut lists = Vec::new();
    for (l, part) in parts
        .iter()
        .enumerate()
        .filter(|(_, p)| p.radius > rule.largest)
    {
        let mut with = vec![l];
        for (m, group) in shells.iter().zip(&joined) {
            if group.radius < rule.holds && group.bounds.overlaps(&part.bounds) {
                with.extend_from_slice(m);
            }
        }
        lists.push(with);
    }
    joined.extend(joined_parts(mesh, parts, &lists, backend));
    joined.sort_by_key(|p| (p.triangles[0], p.triangles.len()));
    joined
}

/// The parts no larger than `rule.largest`, joined transitively where
/// their boxes come within its gap (a sweep along x, then union-find).
fn shell_groups(parts: &[ScenePart], rule: ShellRule) -> Vec<Vec<usize>> {
    let mut group: Vec<usize> = (0..parts.len()).collect();
    let mut by_x: Vec<usize> = (0..parts.len())
        .filter(|&p| parts[p].radius <= rule.largest)
        .collect();
    by_x.sort_by(|&a, &b| parts[a].bounds.min.x.total_cmp(&parts[b].bounds.min.x));
    for (k, &a) in by_x.iter().enumerate() {
        let boxed = parts[a].bounds;
        for &b in &by_x[k + 1..] {
            let other = parts[b].bounds;
            if other.min.x > boxed.max.x + rule.gap {
                break;
            }
            if boxed.gap(&other) <= rule.gap {
                let (ra, rb) = (root(&mut group, a), root(&mut group, b));
                group[ra.max(rb)] = ra.min(rb);
            }
        }
    }
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); parts.len()];
    for &i in &by_x {
        let r = root(&mut group, i);
        members[r].push(i);
    }
    members.into_iter().filter(|m| !m.is_empty()).collect()
}

/// The part made of each of `lists` (indices into `parts`): one alone keeps
/// its sphere and box, only joined ones are measured.
fn joined_parts(
    mesh: &TriMesh,
    parts: &[ScenePart],
    lists: &[Vec<usize>],
    backend: Threads,
) -> Vec<ScenePart> {
    let mut joined_lists = Vec::new();
    for m in lists.iter().filter(|m| m.len() > 1) {
        let mut triangles: Vec<u32> = m
            .iter()
            .flat_map(|&p| parts[p].triangles.iter().copied())
            .collect();
        triangles.sort_unstable();
        joined_lists.push(triangles);
    }
    let mut joined = ScenePart::all(mesh, joined_lists, backend).into_iter();
    lists
        .iter()
        .map(|m| match m[..] {
            [only] => parts[only].clone(),
            _ => ScenePart {
                components: m.iter().map(|&p| parts[p].components).sum(),
                ..joined.next().expect("a joined part for each group")
            },
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::connected_components;
    use crate::mesh::shapes::cuboid;

    fn rule_of(mesh: &TriMesh) -> ShellRule {
        let shells = connected_components(mesh, Threads::Serial);
        let radius = minimal_bounding_sphere(
            &mesh
                .positions()
                .iter()
                .map(|&p| crate::math::from_f32(p))
                .collect::<Vec<_>>(),
        )
        .unwrap()
        .radius;
        ShellRule::of_template(mesh, &shells, radius, 0.8 * radius, Threads::Serial)
    }

    #[test]
    fn the_gap_is_the_widest_step_between_shells_and_the_largest_is_a_shell() {
        // Three unit cubes in a row, 0.5 and then 2 apart: the widest step
        // that links them is 2, and no shell is larger than a cube.
        let mut mesh = cuboid(Vec3::ZERO, Vec3::ONE);
        mesh.append(&cuboid(Vec3::new(1.5, 0.0, 0.0), Vec3::new(2.5, 1.0, 1.0)));
        mesh.append(&cuboid(Vec3::new(4.5, 0.0, 0.0), Vec3::new(5.5, 1.0, 1.0)));
        let rule = rule_of(&mesh);
        assert!((rule.gap - 2.0).abs() < 1e-4, "{rule:?}");
        assert!(
            (rule.largest - 1.05 * 3f64.sqrt() / 2.0).abs() < 1e-6,
            "{rule:?}"
        );
    }

    #[test]
    fn a_template_of_many_shells_is_bounded_by_its_diameter() {
        let mut mesh = cuboid(Vec3::ZERO, Vec3::splat(0.1));
        for i in 1..200 {
            let x = f64::from(i) * 0.2;
            mesh.append(&cuboid(
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 0.1, 0.1, 0.1),
            ));
        }
        let rule = rule_of(&mesh);
        let span = 199.0 * 0.2 + 0.1;
        assert!(rule.gap >= 0.1 && rule.gap <= span * 1.01, "{rule:?}");
    }
}
