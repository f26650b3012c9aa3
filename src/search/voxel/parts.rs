//! The scene's parts searched: which can hold a copy, in waves side by
//! side, each on its own grid or window by window when it is too large for
//! one.

use std::cell::RefCell;

use super::near_vertices::NearVertices;
use super::prepare::PartSearch;
use super::waves::{CPU_WAVE_PARTS, Found, plan_waves, share_cpu_wave_time, share_wave_time};
use super::windows::{Window, part_windows};
use super::work::{PROBE_FROM, probe, too_much_work, work as part_work};
use crate::budget::{Budget, Item};
use crate::cascade::{LayerStats, Observer, Progress, finished, go_on};
use crate::clock::now_ms;
use crate::descriptor::{LayerDevice, LocalFuture, WaveQueue, run_together};
use crate::error::{Error, Result};
use crate::exec::Teller;
use crate::instances::{Instance, merge_duplicates};
use crate::math::{Aabb, Vec3};
use crate::scene::{Lattice, PartVoxels, Scene, ScenePart};
use crate::template::VoxelTemplate;
use crate::voxel::WindowedMesh;
use crate::voxel::voxel_bytes;

/// What one part's search runs with: where it reports its layers, what
/// computes them besides the CPU, and what the search holds beside it.
pub(super) struct Runner<'r, 'o> {
    pub(super) observer: &'r RefCell<&'o mut dyn Observer>,
    pub(super) device: Option<&'r dyn LayerDevice>,
    /// Where its kernels wait for the others of its wave.
    pub(super) wave: Option<&'r dyn WaveQueue>,
    pub(super) held: Budget,
}

impl<'a> PartSearch<'a> {
    /// What each part of `originals` (indices into `parts`) found, by
    /// index: side by side, in waves that fit the memory budget together.
    /// On the CPU a wave's parts share the threads; on a device a layer is
    /// one submission for all parts of a wave. Many parts are judged by a
    /// sample searched first ([`super::work`]).
    pub(super) async fn search_parts(
        &self,
        parts: &[(usize, &ScenePart)],
        originals: &[usize],
        observer: &RefCell<&mut dyn Observer>,
        device: Option<&dyn LayerDevice>,
    ) -> Result<Vec<Option<Found>>> {
        let mut searched: Vec<Option<Found>> = parts.iter().map(|_| None).collect();
        let mut progress = Progress {
            step: Progress::PARTS,
            done: 0,
            total: originals.len(),
        };
        // The total before the first part: a bar of parts does not wait a
        // whole part (or the sample) to learn it.
        report_progress(observer, &progress)?;
        let limit = self.options.max_part_work;
        let mut work = 0.0;
        if originals.len() >= PROBE_FROM {
            work = self
                .search_sample(parts, originals, &mut searched, observer, device)
                .await?;
            progress.done = searched.iter().flatten().count();
            report_progress(observer, &progress)?;
        }
        let rest: Vec<usize> = originals
            .iter()
            .copied()
            .filter(|k| searched[*k].is_none())
            .collect();
        // The sample may misjudge the rest: the work done is checked
        // between waves.
        self.set_work_done(work);
        let mut add_work = |more: f64| {
            work += more;
            self.set_work_done(work);
            match work > limit {
                true => Err(too_much_work(originals.len(), work, limit)),
                false => Ok(()),
            }
        };
        if let Some(device) = device {
            for wave in self.waves(parts, &rest, device.wave_grids()) {
                let founds = self.device_wave(parts, &wave, observer, device).await?;
                add_work(founds.iter().map(part_work).sum())?;
                for ((k, _), found) in wave.iter().zip(founds) {
                    searched[*k] = Some(found);
                }
                progress.done += wave.len();
                report_progress(observer, &progress)?;
            }
            return Ok(searched);
        }
        for wave in self.waves(parts, &rest, CPU_WAVE_PARTS) {
            if let [(k, _)] = wave[..] {
                let (index, part) = parts[k];
                let mut runner = Runner {
                    observer,
                    device: None,
                    wave: None,
                    held: self.held.clone(),
                };
                let found = self.part(index, part, &mut runner).await?;
                add_work(part_work(&found))?;
                searched[k] = Some(found);
                progress.done += 1;
                report_progress(observer, &progress)?;
            } else {
                let founds = self.cpu_wave(parts, &wave, observer, &mut progress)?;
                add_work(founds.iter().map(part_work).sum())?;
                for ((k, _), found) in wave.iter().zip(founds) {
                    searched[*k] = Some(found);
                }
            }
        }
        Ok(searched)
    }

    /// A sample of `originals` searched first, one by one, into `searched`:
    /// its work, or the error for the work it projects over all of them
    /// when that passes the limit.
    async fn search_sample(
        &self,
        parts: &[(usize, &ScenePart)],
        originals: &[usize],
        searched: &mut [Option<Found>],
        observer: &RefCell<&mut dyn Observer>,
        device: Option<&dyn LayerDevice>,
    ) -> Result<f64> {
        let probed = probe(originals);
        let mut work = 0.0;
        for &k in &probed {
            let (index, part) = parts[k];
            let mut runner = Runner {
                observer,
                device,
                wave: None,
                held: self.held.clone(),
            };
            let found = self.part(index, part, &mut runner).await?;
            work += part_work(&found);
            searched[k] = Some(found);
        }
        let projected = work * originals.len() as f64 / probed.len() as f64;
        let limit = self.options.max_part_work;
        match projected > limit {
            true => Err(too_much_work(originals.len(), projected, limit)),
            false => Ok(work),
        }
    }

    /// The parts of `wave` searched side by side on `device`, each layer of
    /// all of them one submission; past the memory budget together, one by
    /// one, as they would have run without the device.
    async fn device_wave(
        &self,
        parts: &[(usize, &ScenePart)],
        wave: &[(usize, Budget)],
        observer: &RefCell<&mut dyn Observer>,
        device: &dyn LayerDevice,
    ) -> Result<Vec<Found>> {
        let started = now_ms();
        let queue = device.wave();
        let tasks: Vec<LocalFuture<'_, Result<Found>>> = wave
            .iter()
            .map(|(k, held)| {
                let (index, part) = parts[*k];
                let mut runner = Runner {
                    observer,
                    device: Some(device),
                    wave: Some(&*queue),
                    held: held.clone(),
                };
                Box::pin(async move { self.part(index, part, &mut runner).await })
                    as LocalFuture<'_, Result<Found>>
            })
            .collect();
        match run_together(&*queue, tasks).await {
            Ok(mut founds) => {
                share_wave_time(&mut founds, now_ms() - started);
                Ok(founds)
            }
            Err(Error::OverBudget { .. }) if wave.len() > 1 => {
                let mut founds = Vec::with_capacity(wave.len());
                for (k, _) in wave {
                    let (index, part) = parts[*k];
                    let mut runner = Runner {
                        observer,
                        device: Some(device),
                        wave: None,
                        held: self.held.clone(),
                    };
                    founds.push(self.part(index, part, &mut runner).await?);
                }
                Ok(founds)
            }
            Err(e) => Err(e),
        }
    }

    /// The parts of `wave` searched side by side on the CPU's threads, each
    /// with its own threads inside as well: a small part keeps few threads
    /// busy alone (a handful of blobs to verify, one instance to align).
    /// Their layers and windows reach `observer` as they run, and each part
    /// searched counts in `progress`; its times are shares of the wave's
    /// wall time.
    fn cpu_wave(
        &self,
        parts: &[(usize, &ScenePart)],
        wave: &[(usize, Budget)],
        observer: &RefCell<&mut dyn Observer>,
        progress: &mut Progress,
    ) -> Result<Vec<Found>> {
        let started = now_ms();
        let mut cancelled = false;
        let runs = self.options.backend.map_each_told(
            wave.len(),
            |i, teller| {
                let (k, held) = &wave[i];
                let (index, part) = parts[*k];
                let mut told = ToldObserver(teller);
                let own: RefCell<&mut dyn Observer> = RefCell::new(&mut told);
                let mut runner = Runner {
                    observer: &own,
                    device: None,
                    wave: None,
                    held: held.clone(),
                };
                let found = finished(self.part(index, part, &mut runner));
                if found.is_ok() {
                    let _ = teller.tell(WaveEvent::Searched);
                }
                found
            },
            |event| {
                let mut observer = observer.borrow_mut();
                let flow = match event {
                    WaveEvent::Layer(stats) => observer.on_layer(&stats),
                    WaveEvent::Progress(p) => observer.on_progress(&p),
                    WaveEvent::Searched => {
                        progress.done += 1;
                        observer.on_progress(progress)
                    }
                };
                cancelled |= flow.is_break();
                flow
            },
        );
        let wall = now_ms() - started;
        let mut founds = runs.into_iter().collect::<Result<Vec<Found>>>()?;
        if cancelled {
            return Err(Error::Cancelled);
        }
        share_cpu_wave_time(&mut founds, wall);
        Ok(founds)
    }

    /// `originals` in waves (see [`plan_waves`]), each part with what the
    /// search holds beside it: the template's side and the other parts of
    /// its wave.
    fn waves(
        &self,
        parts: &[(usize, &ScenePart)],
        originals: &[usize],
        max_parts: usize,
    ) -> Vec<Vec<(usize, Budget)>> {
        let reach = self.template.radius() / self.lattice.spec.voxel_size;
        let grids: Vec<Option<u64>> = originals
            .iter()
            .map(|&k| {
                let (index, part) = parts[k];
                match self.template.voxels_of_part(index) {
                    // A selection's own part is voxelized already.
                    Some(_) => Some(0),
                    None if self.scene.fits_one_grid(part, &self.lattice, reach) => self
                        .scene
                        .part_spec(part, &self.lattice, reach)
                        .ok()
                        .map(|spec| voxel_bytes(&spec)),
                    None => None,
                }
            })
            .collect();
        let free = self.held.free();
        plan_waves(&grids, free, max_parts)
            .into_iter()
            .map(|wave| {
                wave.into_iter()
                    .map(|(n, others)| {
                        let mut held = self.held.clone();
                        if others > 0 {
                            held.hold(Item::OtherParts, others);
                        }
                        (originals[n], held)
                    })
                    .collect()
            })
            .collect()
    }

    /// The instances on scene part `index`: on its own grid, or window by
    /// window when it is too large for one.
    async fn part(
        &self,
        index: usize,
        part: &ScenePart,
        runner: &mut Runner<'_, '_>,
    ) -> Result<Found> {
        let started = now_ms();
        let mut found = Found::default();
        found.instances = self.part_instances(index, part, &mut found, runner).await?;
        // Matching is all of a part's search but voxelizing and verifying:
        // its cells near vertices and its mesh too, as a wave of parts on
        // the GPU (which can only time the whole) counts it.
        found.timings.match_ =
            (now_ms() - started - found.timings.voxelize - found.timings.group).max(0.0);
        Ok(found)
    }

    /// [`PartSearch::part`]'s instances; the rest of what it found goes
    /// to `found`.
    async fn part_instances(
        &self,
        index: usize,
        part: &ScenePart,
        found: &mut Found,
        runner: &mut Runner<'_, '_>,
    ) -> Result<Vec<Instance>> {
        let reach = self.template.radius() / self.lattice.spec.voxel_size;
        let near = NearVertices::new(
            self.scene.mesh(),
            part.triangles(),
            part.bounds(),
            self.vertex_reach,
            self.options.backend,
        );
        let windows = part_windows(self.scene, part, &self.lattice, reach, near.as_ref())?;
        let Some(windows) = windows else {
            let fresh;
            let voxels = match self.template.voxels_of_part(index) {
                Some(voxels) => voxels,
                None => {
                    fresh = self.scene.voxelize_part_beside(
                        part,
                        &self.lattice,
                        reach,
                        &runner.held,
                    )?;
                    found.timings.voxelize += fresh.voxelize_ms();
                    &fresh
                }
            };
            return self
                .grid(part, voxels, None, near.as_ref(), found, runner)
                .await;
        };
        self.windowed_part(part, &windows, near.as_ref(), found, runner)
            .await
    }

    /// The instances on a part too large for one grid, searched in
    /// `windows`.
    async fn windowed_part(
        &self,
        part: &ScenePart,
        windows: &[Window],
        near: Option<&NearVertices>,
        found: &mut Found,
        runner: &mut Runner<'_, '_>,
    ) -> Result<Vec<Instance>> {
        let backend = self.options.backend;
        let windowed = WindowedMesh::new(self.scene.mesh().subset(part.triangles()), backend);
        let mut held = runner.held.clone();
        held.reserve(Item::WindowMesh { selection: false }, windowed.bytes())?;
        let mut instances: Vec<Instance> = Vec::new();
        for (number, window) in windows.iter().enumerate() {
            let progress = Progress {
                step: Progress::WINDOWS,
                done: number,
                total: windows.len(),
            };
            report_progress(runner.observer, &progress)?;
            // No copy can be anchored here.
            if near.is_some_and(|n| !n.any_in(&window.core_bounds())) {
                continue;
            }
            let fitted;
            let window = match near {
                Some(near) => {
                    let Some(fit) = fitted_to_content(window, near, &windowed) else {
                        continue;
                    };
                    fitted = fit;
                    &fitted
                }
                None => window,
            };
            held.clone().reserve(
                Item::WindowGrids { selection: false },
                voxel_bytes(&window.spec),
            )?;
            let voxels = PartVoxels::build_window(&windowed, &window.spec, backend);
            found.windows += 1;
            found.timings.voxelize += voxels.voxelize_ms();
            instances.extend(
                self.grid(part, &voxels, Some(window), near, found, runner)
                    .await?,
            );
        }
        // A copy whose points fall in two cores is found from both.
        Ok(merge_duplicates(
            instances,
            self.options.group_radius * self.template.radius(),
            Some(&self.extent),
        ))
    }
}

/// The parts of `all` large enough to hold a copy of `template`, with
/// their indices; fails when voxelizing them one by one on `lattice` would
/// take far more than the scene's own grid.
pub(super) fn parts_to_search<'p>(
    scene: &Scene,
    template: &VoxelTemplate,
    lattice: &Lattice,
    all: &'p [ScenePart],
) -> Result<Vec<(usize, &'p ScenePart)>> {
    let parts: Vec<(usize, &ScenePart)> = all
        .iter()
        .enumerate()
        .filter(|(_, part)| part.radius() >= template.min_part_radius())
        .collect();
    let reach = template.radius() / lattice.spec.voxel_size;
    check_part_volume(scene, lattice, &parts, reach)?;
    Ok(parts)
}

/// `window` cut down to where a candidate can lie, or `None` where none
/// can. A candidate the vertex test passes lies within its farthest
/// distance of a vertex, so of a triangle that meets the core grown by it:
/// the core is cut down to those triangles' box, grown by it (a window over
/// a terrain or a scan is mostly empty space above and below the sheet).
fn fitted_to_content(
    window: &Window,
    near: &NearVertices,
    windowed: &WindowedMesh,
) -> Option<Window> {
    let core = window.core_bounds();
    let far = Vec3::splat(near.farthest());
    let grown = Aabb {
        min: core.min - far,
        max: core.max + far,
    };
    let content = windowed.content_in(&grown)?;
    window.fitted(&Aabb {
        min: content.min - far,
        max: content.max + far,
    })
}

/// The parts' grids may hold this many times the voxels of the whole
/// scene's: apart, parts fill less than their common box, and padding and
/// nesting add some; a soup of large crossing triangles, each a part,
/// would take thousands of times as long as the scene.
const MAX_PART_VOLUME_FACTOR: u32 = 8;

/// Fails when voxelizing `parts` one by one would fill far more voxels than
/// the whole scene holds.
fn check_part_volume(
    scene: &Scene,
    lattice: &Lattice,
    parts: &[(usize, &ScenePart)],
    reach: f64,
) -> Result<()> {
    // Counted in f64 from the boxes: a part past a grid's side is searched
    // in windows, and still counts whole here.
    let voxel = lattice.spec.voxel_size;
    let voxels: f64 = parts
        .iter()
        .map(|(_, part)| match scene.part_spec(part, lattice, reach) {
            Ok(spec) => spec.voxel_count() as f64,
            Err(_) => {
                let e = part.bounds().extent();
                [e.x, e.y, e.z].iter().map(|e| e / voxel + 3.0).product()
            }
        })
        .sum();
    // Against the scene's box padded as a part's is: a flat scene (tiles
    // on a floor) has a flat grid, and every part's padding alone passed
    // it many times over.
    let scene_extent = scene.mesh().bounds().extent();
    let padded_scene: f64 = [scene_extent.x, scene_extent.y, scene_extent.z]
        .iter()
        .map(|e| e / voxel + 2.0 * reach + 3.0)
        .product();
    let limit =
        f64::from(MAX_PART_VOLUME_FACTOR) * padded_scene.max(lattice.spec.voxel_count() as f64);
    if voxels <= limit {
        return Ok(());
    }
    Err(Error::PartsOverlap {
        voxels,
        limit,
        factor: MAX_PART_VOLUME_FACTOR,
        resolution: lattice.resolution,
        advice: "weld the mesh so that a part's triangles share vertices, or search a region of the scene".into(),
    })
}

/// Tells `observer` how far the search has come; a `Break` cancels it.
fn report_progress(observer: &RefCell<&mut dyn Observer>, progress: &Progress) -> Result<()> {
    go_on(observer.borrow_mut().on_progress(progress))
}

/// What a part searched in a CPU wave tells the calling thread.
enum WaveEvent {
    Layer(LayerStats),
    Progress(Progress),
    /// The part is searched.
    Searched,
}

/// A part's observer in a CPU wave: its reports go to the calling thread.
struct ToldObserver<'t, 'a>(&'t Teller<'a, WaveEvent>);

impl Observer for ToldObserver<'_, '_> {
    fn on_layer(&mut self, stats: &LayerStats) -> std::ops::ControlFlow<()> {
        self.0.tell(WaveEvent::Layer(stats.clone()))
    }

    fn on_progress(&mut self, progress: &Progress) -> std::ops::ControlFlow<()> {
        self.0.tell(WaveEvent::Progress(*progress))
    }
}
