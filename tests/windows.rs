//! A part too large for one grid is searched window by window (a scan, a
//! game level welded into one mesh, a long machined rack): its copies are
//! found there as on its whole grid, once each, whatever window they fall
//! in.

use std::ops::ControlFlow;

use fast_reject::{
    LayerStats, MatchOptions, MatchReport, Observer, Progress, Scene, SceneOptions, TemplateSource,
    TriMesh, search,
};

/// A toothed rack, one closed mesh: `teeth` trapezoid teeth of pitch 1 on
/// a bar 0.6 high and 0.8 deep, extruded along y. Its top boundary is a
/// function of x, so each cap is a strip of quads down to the bar's base.
fn rack(teeth: usize) -> TriMesh {
    let mut top: Vec<[f64; 2]> = vec![[0.0, 0.6]];
    for i in 0..teeth {
        let x = i as f64 + 0.5;
        top.extend([[x, 0.6], [x + 0.15, 1.1], [x + 0.35, 1.1], [x + 0.5, 0.6]]);
    }
    top.push([teeth as f64 + 1.0, 0.6]);
    let depth = 0.8;
    let n = top.len() as u32;
    // Vertices: per y side (0, depth), the top points, then their feet.
    let mut positions: Vec<[f32; 3]> = Vec::new();
    for y in [0.0, depth] {
        for &[x, z] in &top {
            positions.push([x as f32, y as f32, z as f32]);
        }
        for &[x, _] in &top {
            positions.push([x as f32, y as f32, 0.0]);
        }
    }
    let (top_at, foot_at) = (
        |s: u32, j: u32| s * 2 * n + j,
        |s: u32, j: u32| s * 2 * n + n + j,
    );
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut quad = |a: u32, b: u32, c: u32, d: u32| {
        triangles.push([a, b, c]);
        triangles.push([a, c, d]);
    };
    for j in 0..n - 1 {
        // Caps (outward -y, then +y), the toothed top, the flat base.
        quad(
            foot_at(0, j),
            foot_at(0, j + 1),
            top_at(0, j + 1),
            top_at(0, j),
        );
        quad(
            foot_at(1, j),
            top_at(1, j),
            top_at(1, j + 1),
            foot_at(1, j + 1),
        );
        quad(
            top_at(0, j),
            top_at(0, j + 1),
            top_at(1, j + 1),
            top_at(1, j),
        );
        quad(
            foot_at(0, j),
            foot_at(1, j),
            foot_at(1, j + 1),
            foot_at(0, j + 1),
        );
    }
    // The two ends.
    quad(foot_at(0, 0), top_at(0, 0), top_at(1, 0), foot_at(1, 0));
    let last = n - 1;
    quad(
        foot_at(0, last),
        foot_at(1, last),
        top_at(1, last),
        top_at(0, last),
    );
    TriMesh::new(positions, triangles).unwrap()
}

/// Long enough that, under the smaller budget below, the rack's grid
/// takes more than half of it.
const TEETH: usize = 50;

fn find_teeth(budget_mib: u64) -> MatchReport {
    let scene = Scene::new(
        rack(TEETH),
        &SceneOptions::DEFAULT.with_memory_budget(budget_mib << 20),
    )
    .unwrap();
    // A sphere around the tip of tooth 20.
    let template = TemplateSource::Selection {
        center: [20.75, 0.4, 1.1],
        radius: 0.6,
    };
    search(&scene, &template, &MatchOptions::DEFAULT, &mut ()).unwrap()
}

#[test]
fn the_teeth_of_a_rack_too_large_for_one_grid_are_found_window_by_window() {
    let whole = find_teeth(2048);
    let windowed = find_teeth(40);
    let grid = |r: &MatchReport| r.grid.clone().expect("a voxel search");
    assert_eq!(grid(&whole).windows, 0);
    assert!(grid(&windowed).windows > 1, "{:?}", grid(&windowed));
    let tips = |r: &MatchReport| {
        let mut x: Vec<f64> = r.instances.iter().map(|i| i.position[0]).collect();
        x.sort_by(f64::total_cmp);
        x
    };
    // Every tooth away from the rack's ends, once, at its tip.
    for report in [&whole, &windowed] {
        let found = tips(report);
        for tooth in 2..TEETH - 2 {
            let tip = tooth as f64 + 0.75;
            assert_eq!(
                found.iter().filter(|&&x| (x - tip).abs() < 0.05).count(),
                1,
                "tooth {tooth}: {found:?}"
            );
        }
        for i in &report.instances {
            let [x, y, z] = i.position;
            let off_tip = (x - 0.75 - (x - 0.75).round()).abs();
            assert!(
                off_tip < 0.05 && (y - 0.4).abs() < 0.05 && (z - 1.1).abs() < 0.05,
                "{:?}",
                i.position
            );
        }
    }
    // The same instances either way.
    let (a, b) = (tips(&whole), tips(&windowed));
    assert_eq!(a.len(), b.len(), "{a:?} / {b:?}");
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 0.02, "{a:?} / {b:?}");
    }
}

#[test]
fn a_search_in_windows_reports_each_window_before_it_is_searched() {
    let scene = Scene::new(
        rack(TEETH),
        &SceneOptions::DEFAULT.with_memory_budget(40 << 20),
    )
    .unwrap();
    let template = TemplateSource::Selection {
        center: [20.75, 0.4, 1.1],
        radius: 0.6,
    };
    let mut seen = Recorder::default();
    let report = search(&scene, &template, &MatchOptions::DEFAULT, &mut seen).unwrap();
    let windows: Vec<Progress> = seen
        .0
        .iter()
        .copied()
        .filter(|p| p.step == Progress::WINDOWS)
        .collect();
    let total = windows[0].total;
    assert!(total > 1, "{windows:?}");
    assert_eq!(windows[0].done, 0);
    assert!(
        windows
            .windows(2)
            .all(|w| w[0].done < w[1].done && w[1].total == total)
    );
    // Windows with nothing to anchor a copy are skipped, never searched.
    assert!(report.grid.unwrap().windows <= total);
}

/// Every progress report, in order.
#[derive(Default)]
struct Recorder(Vec<Progress>);

impl Observer for Recorder {
    fn on_layer(&mut self, _: &LayerStats) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }

    fn on_progress(&mut self, progress: &Progress) -> ControlFlow<()> {
        self.0.push(*progress);
        ControlFlow::Continue(())
    }
}
