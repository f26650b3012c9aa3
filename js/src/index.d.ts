/** Which build runs and how. */
export interface BuildInfo {
  /** 'threads' in a cross-origin isolated Web Worker with several cores, 'plain' otherwise. */
  build: 'plain' | 'threads';
  /** Threads the matcher runs on. */
  threads: number;
  /** Bytes the module's memory may grow to (voxel grids are capped from it). */
  memoryLimitBytes: number;
  /** Why the plain build runs where `build: 'auto'` chose threads (the pool did not start), else null. */
  fallback: string | null;
}

export interface InitOptions {
  /** 'auto' (default) picks 'threads' where threadsSupported() is true. */
  build?: 'auto' | 'plain' | 'threads';
  /** Pool size for the threaded build (default: navigator.hardwareConcurrency). */
  threads?: number;
}

/** Loads the WebAssembly module once; call it (and await it) before anything else. */
export function init(options?: InitOptions): Promise<BuildInfo>;

/** Whether this context can run the threaded build. */
export function threadsSupported(): boolean;

/** Linear memory the module holds now; after a search, its peak. */
export function memoryBytes(): number;

/** A mesh format, by its file extension. */
export type MeshFormat = 'glb' | 'gltf' | 'obj' | 'ply' | 'stl';

/** Bytes of a mesh file. */
export type MeshBytes = Uint8Array | ArrayBuffer | ArrayBufferView;

/** A descriptor chain (the core's `DescriptorKind`). */
export type DescriptorName = 'volume+harmonics' | 'volume' | 'harmonics' | 'curvature';

/**
 * Scene options. Like MatchOptions, the core's own schema (a test holds this
 * file to it): an unknown key is an error, not ignored.
 */
export interface SceneOptions {
  /** The format; recognized from the content when absent. */
  format?: MeshFormat;
  /** Voxels along the scene's longest side, 8..=16384; a search refines it for a small template and coarsens it for a large one (`templateVoxels`; 0 keeps it) (default 512). */
  resolution?: number;
}

/** Match options: the core's `MatchOptions`, camelCased; an unknown key is an error. */
export interface MatchOptions {
  /** 'curvature' works on the mesh, with no voxels (default 'volume+harmonics'). */
  descriptor?: DescriptorName;
  /** Voxelize the scene again at this resolution (kept for later calls). */
  resolution?: number;
  /** Number of radii k (default 6). */
  layers?: number;
  /** Volume stage threshold: the sum of the balls' solid-fraction differences (default 0.12). */
  volumeThreshold?: number;
  /** Harmonics stage threshold, in voxels of equivalent deviation (default 0.8). */
  harmonicsThreshold?: number;
  /** Curvature threshold on the r_k^2-scaled squared differences (default 2.5). */
  curvatureThreshold?: number;
  /** Curvature: 0 makes every vertex a candidate; a positive value is a grid cell's side (a share of r_1) for a faster first pass over one vertex per cell, which can miss an occurrence (default 0). */
  curvatureSpacing?: number;
  /** Survivors within this share of r_k of a better one join its instance (default 1). */
  groupRadius?: number;
  /** Least share of the template's surface that must lie on the scene's surface, 0..1 (default 0.85). */
  verifyThreshold?: number;
  /** Largest share of a model template's surface other material may hide, 0..1 (default 0.3). */
  hiddenSurface?: number;
  /** How far from the scene's surface a point of the template's may lie at an instance's pose, as a share of the template's radius; lower it (0.01) where copies are exact, as CAD instances are (default 0.03). */
  surfaceTolerance?: number;
  /** Least number of voxels a voxel template's bounding radius spans: a smaller template refines the grid, one spanning over three times this coarsens it; 0 keeps the scene's resolution (default 32). */
  templateVoxels?: number;
  /** One candidate point per cube of this many voxels a side; 1 makes every skin voxel a candidate (default 2). */
  candidateSpacing?: number;
  /** Keep whole copies only: instances whose own part the template explains entirely, not a larger part that holds it, as part-in-whole (the paper's case) reports; not with the curvature descriptor (default false). */
  wholeCopies?: boolean;
  /** Keep near twins: where some instance fits the template within float rounding (exact CAD or BIM copies), those that neither fit within 1e-3 of its radius nor land 95% of its surface are refused unless this is set (default false). */
  keepNearTwins?: boolean;
  /** Refuse a volume or harmonics search whose distinct parts, each searched on its own, would take more work than this (about nanoseconds of one core), judged from a sample searched first; raise it to search a building of tens of thousands of distinct parts anyway (default 3e10): about 30 s of one core; the same limit stops a part whose layers let most candidates through. */
  maxPartWork?: number;
}

/** Every option's default, as the core defines them. */
export interface OptionDefaults {
  scene: Required<Omit<SceneOptions, 'format'>>;
  match: Required<Omit<MatchOptions, 'resolution'>>;
}

/** The defaults of every scene and match option (after init()). */
export function optionDefaults(): OptionDefaults;

/** One cascade layer, as reported to the progress callback and in `stages`. */
export interface LayerStats {
  /** The stage: one descriptor of the chain ('curvature-sample' is the sampled first pass of curvatureSpacing). */
  descriptor: 'volume' | 'harmonics' | 'curvature' | 'curvature-sample';
  layer: number;
  radius: number;
  candidates: number;
  survivors: number;
  ms: number;
}

export interface Instance {
  /** Where the template's centre c_T lies in the scene. */
  position: [number, number, number];
  /** Final descriptor distance. */
  distance: number;
  /** Share of the placed template's surface that lies on the scene's (0..1); null for curvature, which has no verification. */
  score: number | null;
  /** Surviving points the instance gathered. */
  support: number;
  /** The template's pose: a row-major 4x4 matrix from template to scene coordinates (it maps c_T to `position`); null for curvature, which finds no rotation. */
  pose: Matrix4 | null;
  /** Root mean square distance of the template's surface within the tolerance to the scene's, in scene units: float rounding for an exact copy, more for a near twin; null for curvature. */
  residual: number | null;
  /** Whether the copy's own part is entirely explained by the template (a whole copy) rather than part of a larger whole; null for curvature. */
  whole: boolean | null;
}

/** A point: three coordinates, as a tuple or a typed array (whose length is checked when called). */
export type Point3 = readonly [number, number, number] | Float32Array | Float64Array;

/** A row-major 4x4 matrix; the last row is 0, 0, 0, 1. */
export type Matrix4 = [
  [number, number, number, number],
  [number, number, number, number],
  [number, number, number, number],
  [number, number, number, number],
];

/** The native CLI's JSON (`fast-reject match --json`) with camelCase keys (`timingsMs`, `grid.voxelSize`), plus typed arrays for drawing. */
export interface MatchReport {
  template: { center: [number, number, number]; radius: number };
  instances: Instance[];
  stages: LayerStats[];
  /** The voxel grid (null for curvature); `windows`: how many windows parts too large for one grid were searched in (0: none was). */
  grid: { resolution: number; voxelSize: number; skinVoxels: number; windows: number } | null;
  /** The welded surface (curvature only, else null). */
  surface: { vertices: number; triangles: number } | null;
  /** The GPU the layers ran on (`matchGpu`), and why some went back to the CPU if any did; null when the search ran on the CPU only. */
  gpu: { adapter: string; fallback: string | null } | null;
  timingsMs: { load: number; voxelize: number; surface: number; template: number; match: number; group: number; total: number };
  /** x, y, z of every instance, best first. */
  instancePositions: Float64Array;
  /** The radius of the ball each instance occupies (r_k). */
  highlightRadius: number;
  /** Threads the search ran on. */
  threads: number;
}

/**
 * What a search will take, judged before it runs (`Scene.plan`): the search's first steps (the template, which
 * parts can hold a copy, which copy one another) and the rest from the parts' areas.
 */
export interface SearchPlan {
  /** The scene's parts large enough to hold a copy. */
  parts: number;
  /** Of those, the ones searched; the others are rigid copies of one and take its instances, moved. */
  distinctParts: number;
  /** The distinct parts' skin voxels (the candidates), estimated from their areas. */
  skinVoxels: number;
  /** The least work the search takes, in about nanoseconds of one core (the unit of `maxPartWork`). */
  leastWork: number;
  /** The threads the search runs on: the module's. */
  threads: number;
  /** `leastWork` shared by those threads, in seconds: about the least the search takes; parts like the template take several times more. */
  leastSeconds: number;
  /** Whether the search will be refused for its work (`maxPartWork`) even at the least. */
  overLimit: boolean;
}

export interface TemplateOptions {
  /** The format; recognized from the content when absent. */
  format?: MeshFormat;
}

/** Which WebGPU adapters `Scene.matchGpu` may use. */
export interface GpuChoice {
  /** Use a fallback (software) adapter too, such as headless Chromium's SwiftShader: many times slower than the CPU code, for tests. Default false. */
  allowSoftware?: boolean;
}

/** The threaded build's workers did not start (`build: 'threads'`; 'auto' falls back to the plain build). */
export class ThreadPoolError extends Error {
  readonly name: 'ThreadPoolError';
  readonly code: 'thread-pool';
}

/**
 * A search stopped before its end: the progress callback returned `false` or
 * threw (what it threw is the `cause`), or the caller cancelled it.
 */

export class CancelledError extends Error {
  readonly name: 'CancelledError';
  readonly code: 'cancelled';
}

/** Called after every cascade layer of every scene part searched (the report sums them per stage and layer); return `false` (or throw) to cancel: the search then throws (rejects with) a `CancelledError`. */
export type LayerCallback = (stats: LayerStats) => boolean | void;

/** How far a search has come: `done` of `total` scene parts searched (a part too large for one grid: its windows; the curvature search: the mesh's vertices, after the steps of welding the mesh into a surface; `findRepeats`: its steps, reading to writing; `Scene.fromBytes`: its steps, reading to splitting the scene into parts). */
export interface SearchProgress {
  step: 'parts' | 'windows' | 'candidates' | 'surface steps' | 'repeat steps' | 'scene steps';
  done: number;
  total: number;
}

/** Called as a search works through its parts; return `false` (or throw) to cancel, as with `LayerCallback`. */
export type ProgressCallback = (progress: SearchProgress) => boolean | void;

/** The callbacks of a search: per layer, and per part done. */
export interface SearchCallbacks {
  onLayer?: LayerCallback;
  onProgress?: ProgressCallback;
}

declare abstract class Handle {
  /** Releases the wasm memory now (or when a search using the handle, a pending `matchGpu`, ends); the handle cannot be used afterwards. */
  free(): void;
}

/** One place a repeated part stands. */
export interface RepeatCopy {
  /** Row-major 4x4 from the family's first copy, where it stands in the scene, to this one. */
  pose: Matrix4;
  /** The farthest a vertex of the first copy, moved by `pose`, lands from this copy's: float rounding for an exact copy. */
  residual: number;
  /** Whether this copy is the first one's mirror image (`pose` is a reflection). */
  mirrored: boolean;
}

/** A part the scene holds twice or more, and every copy of it. */
export interface RepeatFamily {
  /** The centre of the first copy's minimal bounding sphere, in the scene: the point each pose moves onto its copy's. */
  center: [number, number, number];
  radius: number;
  /** Triangles of one copy. */
  triangles: number;
  /** Connected pieces one copy was matched as (a CAD body of several pieces that move together is one part). */
  pieces: number;
  /** The copies, the first one first (its pose the identity). */
  copies: RepeatCopy[];
}

export interface RepeatsReport {
  /** The families, the one covering the most triangles first. */
  families: RepeatFamily[];
  /** With `instanced`: the scene as an instanced binary glTF (each family stored once, every copy placed; the rest as it was). */
  glb?: Uint8Array;
  /** With `instanced`: what the file holds; `keptCopies`, copies written as they were because their family's mesh would not draw them the same. */
  written?: { bytes: number; meshes: number; nodes: number; keptCopies: number };
  timingsMs: { load: number; repeats: number; write?: number };
}

export interface RepeatsOptions {
  /** The file's format; recognized from the content when absent. */
  format?: MeshFormat;
  /** Also write the scene as an instanced GLB (`glb` in the report): a node per copy, or one EXT_mesh_gpu_instancing node per family. */
  instanced?: 'nodes' | 'gpu-instancing';
}

/** Finds the parts a mesh file holds twice or more, without a template; throws an Error with a readable message on bad input. */
export function findRepeats(bytes: MeshBytes, options?: RepeatsOptions, observe?: { onProgress?: ProgressCallback }): RepeatsReport;

export class Scene extends Handle {
  private constructor();
  /** Parses a scene and splits it into its parts, telling `onProgress` its steps; throws an Error with a readable message on bad input. */
  static fromBytes(bytes: MeshBytes, options?: SceneOptions, observe?: { onProgress?: ProgressCallback }): Scene;
  readonly resolution: number;
  readonly voxelSize: number;
  /** Connected parts: the voxel search describes each point by its own part. */
  readonly parts: number;
  readonly triangles: number;
  /** Finds every occurrence of `template`; throws a `CancelledError` when cancelled, an `Error` on bad options. */
  match(template: Template, options?: MatchOptions, observe?: LayerCallback | SearchCallbacks): MatchReport;
  /**
   * What a search for `template` with `options` will take, judged in a fraction of the search's time without
   * running it; null for the curvature descriptor (its work is the welded surface's vertices).
   */
  plan(template: Template, options?: MatchOptions): SearchPlan | null;
  /**
   * Like `match`, with the volume and harmonics layers on WebGPU where `navigator.gpu` gives a hardware adapter
   * (a fallback, software one only with `allowSoftware`): the same instances. The report's `gpu` names the adapter,
   * or is null when the CPU ran (no adapter, as in Node); a device that fails midway hands its layers back to the
   * CPU and says why in `gpu.fallback`. Rejects with a `CancelledError` when cancelled, an `Error` on bad options.
   */
  matchGpu(
    template: Template,
    options?: MatchOptions,
    observe?: LayerCallback | SearchCallbacks,
    gpu?: GpuChoice,
  ): Promise<MatchReport>;
}

export class Template extends Handle {
  private constructor();
  /** A separate model. */
  static fromBytes(bytes: MeshBytes, options?: TemplateOptions): Template;
  /** The part of the scene inside a sphere (scene coordinates). */
  static fromSelection(center: Point3, radius: number): Template;
  readonly isSelection: boolean;
}
