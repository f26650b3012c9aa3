import type {
  BuildInfo,
  InitOptions,
  LayerCallback,
  MatchOptions,
  MatchReport,
  MeshBytes,
  MeshFormat,
  OptionDefaults,
  Point3,
  ProgressCallback,
  RepeatsOptions,
  RepeatsReport,
  SceneOptions,
  SearchPlan,
} from './index.js';

export { CancelledError, ThreadPoolError } from './index.js';

/** Where the search runs: 'auto' (WebGPU on a hardware adapter, else the CPU), 'cpu', or 'gpu' (any adapter, a software one included; the CPU when there is none). */
export type Backend = 'auto' | 'cpu' | 'gpu';

export interface SearchWorkerOptions extends InitOptions {
  /** Default 'auto'. */
  backend?: Backend;
}

/** The worker's build, and every option's default. */
export interface WorkerInfo extends BuildInfo {
  defaults: OptionDefaults;
}

/** The scene the worker loaded. */
export interface SceneInfo {
  triangles: number;
  /** Connected parts: the voxel search describes each point by its own part. */
  parts: number;
  resolution: number;
  voxelSize: number;
  /** Time the worker took to parse and voxelize it. */
  ms: number;
}

/** A template for `SearchWorker.match`: a model file, or the part of the scene inside a sphere. */
export type TemplateSource =
  | { bytes: MeshBytes; format?: MeshFormat; center?: never }
  | { center: Point3; radius: number; bytes?: never };

export interface MatchControl {
  /** After every cascade layer; return `false` (or throw) to cancel. */
  onLayer?: LayerCallback;
  /** As the scene's parts are searched, `done` of `total`; return `false` (or throw) to cancel. */
  onProgress?: ProgressCallback;
  /** Cancels the search when aborted (its reason is the `CancelledError`'s cause). */
  signal?: AbortSignal;
}

/**
 * The search in a worker of its own (a Web Worker in the browser, worker_threads in Node): async, with progress per
 * part and per layer, and a cancel that stops the work at once. Requests run one at a time in order; the loaded scene is kept.
 */
export class SearchWorker {
  constructor(options?: SearchWorkerOptions);
  /** Resolves once the module is loaded in the worker. */
  ready(): Promise<WorkerInfo>;
  /** Parses a scene and keeps it for the next searches, telling `onProgress` its steps; on failure or cancel the previous scene stays. The bytes are copied. */
  loadScene(bytes: MeshBytes, options?: SceneOptions, control?: { signal?: AbortSignal; onProgress?: ProgressCallback }): Promise<SceneInfo>;
  /** Parses a template and forgets it: rejects with the reason a search with it would fail at once (a broken file). */
  checkTemplate(template: TemplateSource): Promise<void>;
  /** What searching the loaded scene for `template` will take, judged without running it (`Scene.plan`); null for the curvature descriptor. */
  plan(template: TemplateSource, options?: MatchOptions): Promise<SearchPlan | null>;
  /** Searches the loaded scene; rejects with a `CancelledError` when cancelled, an `Error` on bad input. */
  match(template: TemplateSource, options?: MatchOptions, control?: MatchControl): Promise<MatchReport>;
  /** Finds the parts a mesh file holds twice or more, without a template, in the worker; the loaded scene stays. */
  findRepeats(bytes: MeshBytes, options?: RepeatsOptions, control?: { signal?: AbortSignal; onProgress?: ProgressCallback }): Promise<RepeatsReport>;
  /** Stops the running request and every queued one (they reject with a `CancelledError`); the scene is loaded again. */
  cancel(): void;
  /** Stops the worker for good. */
  terminate(): void;
}
