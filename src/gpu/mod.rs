//! The GPU backend (feature `gpu`): the cascade's volume and harmonics
//! layers computed on a GPU through wgpu, Vulkan natively and WebGPU in a
//! browser, from one WGSL source per kernel.
//!
//! The device is made apart from the work and handed in ([`Gpu::new`]), so
//! that tests can give it a software adapter (lavapipe, SwiftShader) and an
//! embedder its own device; [`Gpu::request_async`] finds one the usual way.
//! A [`GpuSolid`] is a `crate::descriptor::LayerBatch`: the stages ask it
//! for a layer's values for all live points and wait without blocking (a
//! browser answers on its event loop). Ball counts are integers, the same
//! as the CPU's; harmonics signatures differ by f32 rounding only and are
//! taken with a guard band (see `descriptor::harmonics`), so both backends
//! keep the same candidates. Every failure (no adapter, a buffer past the
//! device's limits, a lost device) is reported and the search goes on on
//! the CPU.

mod harmonics;
mod queue;
mod solid;
mod volume;

pub use queue::KernelQueue;
pub use solid::GpuSolid;
/// The wgpu this crate is built with: a device handed to [`Gpu::new`] must
/// come from it.
pub use wgpu;

use std::sync::{Arc, Mutex};

use crate::descriptor::{LayerBatch, LayerDevice, WaveQueue};
use crate::error::{Error, Result};
use crate::voxel::Solid;

/// The per-degree error bound the harmonics stage's guard band assumes for
/// a GPU's signatures: about 40 times the largest difference measured
/// against the CPU (2.6e-7), and checked by the tests.
const MAX_ERROR: f32 = 1e-5;

/// Every kernel's WGSL, by file name (validated by a test with no
/// adapter).
#[cfg(all(test, not(target_arch = "wasm32")))]
const SHADERS: &[(&str, &str)] = &[
    ("harmonics.wgsl", harmonics::SHADER),
    ("volume.wgsl", volume::SHADER),
];

/// Which adapters [`Gpu::request`] accepts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdapterChoice {
    /// A hardware GPU only: a software adapter (lavapipe, a browser's
    /// fallback) is many times slower than the CPU code.
    Hardware,
    /// Any adapter, software ones included (tests, and `--backend gpu`).
    Any,
}

/// A GPU device with the pipelines the search runs on it.
pub struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    spheres: wgpu::ComputePipeline,
    balls: wgpu::ComputePipeline,
    fourier: wgpu::Buffer,
    legendre: wgpu::Buffer,
    /// Errors the device reported outside any call's own checks, and
    /// whether it was lost: read after every submission.
    failures: Arc<Mutex<Vec<String>>>,
    /// Balls' run tables on the device, the latest used first (see
    /// `volume::BallTables`).
    ball_tables: Mutex<Vec<volume::BallTables>>,
    /// Spheres' sample tables on the device, the latest used first (see
    /// `harmonics::SampleTables`).
    sample_tables: Mutex<Vec<harmonics::SampleTables>>,
    /// Submissions and kernels so far (see [`Gpu::submissions`]).
    submissions: std::sync::atomic::AtomicUsize,
    kernels: std::sync::atomic::AtomicUsize,
    /// Nanoseconds spent waiting for submissions' outputs (see
    /// [`Gpu::waited_ms`]).
    waited_ns: std::sync::atomic::AtomicU64,
}

impl Gpu {
    /// Asks the system for an adapter of `choice` and a device on it;
    /// `Ok(None)` when there is none. Blocks until the device is ready.
    #[cfg(not(target_arch = "wasm32"))]
    pub fn request(choice: AdapterChoice) -> Result<Option<Gpu>> {
        pollster::block_on(Gpu::request_async(choice))
    }

    /// [`Gpu::request`] without blocking: what a browser needs, where the
    /// adapter and device arrive on the event loop.
    pub async fn request_async(choice: AdapterChoice) -> Result<Option<Gpu>> {
        // wgpu's instance panics where there is no `navigator.gpu` (Node,
        // a shared worker): ask first.
        #[cfg(target_arch = "wasm32")]
        if !wgpu::util::is_browser_webgpu_supported().await {
            return Ok(None);
        }
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let options = wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        };
        let Ok(adapter) = instance.request_adapter(&options).await else {
            return Ok(None);
        };
        let info = adapter.get_info();
        // Lavapipe natively, and a browser's fallback adapter, say Cpu.
        if choice == AdapterChoice::Hardware && info.device_type == wgpu::DeviceType::Cpu {
            return Ok(None);
        }
        // Grids larger than WebGPU's default 128 MiB binding where the
        // adapter allows it.
        let offered = adapter.limits();
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: offered.max_storage_buffer_binding_size,
            max_buffer_size: offered.max_buffer_size,
            ..wgpu::Limits::defaults()
        };
        let descriptor = wgpu::DeviceDescriptor {
            label: Some("fast-reject"),
            required_limits: limits,
            ..Default::default()
        };
        let (device, queue) = adapter
            .request_device(&descriptor)
            .await
            .map_err(|e| unavailable(format!("the adapter {} gave no device: {e}", info.name)))?;
        Gpu::new(device, queue, info).map(Some)
    }

    /// Wraps a device made elsewhere, with the adapter's description, and
    /// builds the pipelines.
    pub fn new(device: wgpu::Device, queue: wgpu::Queue, info: wgpu::AdapterInfo) -> Result<Gpu> {
        let failures: Arc<Mutex<Vec<String>>> = Arc::default();
        // wgpu's default handler panics: an error is reported instead.
        let seen = failures.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            seen.lock()
                .unwrap_or_else(|p| p.into_inner())
                .push(e.to_string());
        }));
        let seen = failures.clone();
        device.set_device_lost_callback(move |_, message| {
            seen.lock()
                .unwrap_or_else(|p| p.into_inner())
                .push(format!("the GPU device was lost: {message}"));
        });
        let pipeline = |label: &str, source: &str| {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let spheres = pipeline("harmonics", harmonics::SHADER);
        let balls = pipeline("volume", volume::SHADER);
        let (fourier, legendre) = crate::descriptor::harmonics::unfolded_tables();
        let gpu = Gpu {
            fourier: storage(&device, "fourier", bytemuck::cast_slice(&fourier)),
            legendre: storage(&device, "legendre", bytemuck::cast_slice(&legendre)),
            device,
            queue,
            info,
            spheres,
            balls,
            failures,
            ball_tables: Mutex::default(),
            sample_tables: Mutex::default(),
            submissions: Default::default(),
            kernels: Default::default(),
            waited_ns: Default::default(),
        };
        gpu.check("building the GPU pipelines")?;
        Ok(gpu)
    }

    /// The adapter's name and API, as reports show it.
    pub fn description(&self) -> String {
        let kind = if self.is_software() { ", software" } else { "" };
        // Browsers often withhold the adapter's description.
        let name = match self.info.name.as_str() {
            "" => "an unnamed adapter",
            name => name,
        };
        format!("{name} ({:?}{kind})", self.info.backend)
    }

    /// Whether the adapter runs on the CPU (lavapipe, SwiftShader).
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// The device's limits.
    pub fn limits(&self) -> wgpu::Limits {
        self.device.limits()
    }

    /// Fails with what the device reported since the last check, if
    /// anything.
    fn check(&self, doing: &str) -> Result<()> {
        let mut failures = self.failures.lock().unwrap_or_else(|p| p.into_inner());
        if failures.is_empty() {
            return Ok(());
        }
        let all = failures.join("; ");
        failures.clear();
        Err(unavailable(format!("{doing}: {all}")))
    }
}

/// One kernel run: `params` at binding 0, `inputs` at the next bindings
/// in order, and an output buffer of `output_bytes` after them, which is
/// read back. The params are a storage buffer, not a uniform one:
/// lavapipe compiles a variant of the kernel for every uniform buffer a
/// dispatch reads, and keeps it (180 KB and a compile per kernel).
struct Dispatch<'a> {
    pipeline: &'a wgpu::ComputePipeline,
    params: &'a [u8],
    inputs: &'a [&'a wgpu::Buffer],
    output_bytes: u64,
    workgroups: [u32; 2],
}

/// Grids in a wave at most. A submission's fixed cost (0.1-0.25 ms
/// measured on an H100, whatever its kernels) is shared by a wave's grids,
/// while each kernel costs its own 30-130 us to build and submit: at 16
/// grids the shared part is already below a tenth of a layer's cost, and
/// more would mostly add memory (each holds its voxels).
const WAVE_GRIDS: usize = 16;

/// The search's view of a GPU: a batch per grid, and queues that submit a
/// wave's kernels together.
impl LayerDevice for Gpu {
    fn description(&self) -> String {
        Gpu::description(self)
    }

    fn wave_grids(&self) -> usize {
        WAVE_GRIDS
    }

    fn batch<'a>(&'a self, solid: &'a Solid) -> Box<dyn LayerBatch + 'a> {
        Box::new(GpuSolid::new(self, solid))
    }

    fn wave(&self) -> Box<dyn WaveQueue + '_> {
        Box::new(KernelQueue::new(self))
    }
}

impl Gpu {
    /// Starts `d`: its buffers are made now, and the future returns its
    /// output's bytes, submitted on its own when awaited, or in `queue`'s
    /// next submission beside other parts' kernels.
    fn start_kernel<'s>(
        &'s self,
        d: Dispatch<'_>,
        queue: Option<&'s KernelQueue<'_>>,
    ) -> crate::descriptor::LocalFuture<'s, std::result::Result<Vec<u8>, String>> {
        let kernel = self.prepare(d);
        match queue {
            Some(queue) => Box::pin(queue.enqueue(kernel)),
            None => Box::pin(async move {
                let mut outputs = self.submit(std::slice::from_ref(&kernel)).await?;
                Ok(outputs.pop().unwrap_or_default())
            }),
        }
    }

    /// `d`'s buffers and bindings, ready to be encoded.
    fn prepare(&self, d: Dispatch<'_>) -> queue::Prepared {
        use wgpu::util::DeviceExt;
        let device = &self.device;
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: d.params,
            usage: wgpu::BufferUsages::STORAGE,
        });
        let output = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("output"),
            size: d.output_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read back"),
            size: d.output_bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let resources = std::iter::once(&params)
            .chain(d.inputs.iter().copied())
            .chain(std::iter::once(&output));
        let entries: Vec<wgpu::BindGroupEntry> = resources
            .enumerate()
            .map(|(i, buffer)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &d.pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        queue::Prepared {
            pipeline: d.pipeline.clone(),
            group,
            workgroups: d.workgroups,
            output,
            readback,
        }
    }

    /// Runs `kernels` in one submission and returns each one's output
    /// bytes. Every error the device reports on the way fails them all.
    async fn submit(
        &self,
        kernels: &[queue::Prepared],
    ) -> std::result::Result<Vec<Vec<u8>>, String> {
        let device = &self.device;
        // The device's complaints about these kernels come back here, in a
        // browser too, where uncaptured errors arrive on the event loop.
        let out_of_memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let invalid = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            // One pass: each kernel writes its own output, so the device
            // may run them side by side.
            let mut pass = encoder.begin_compute_pass(&Default::default());
            for k in kernels {
                pass.set_pipeline(&k.pipeline);
                pass.set_bind_group(0, &k.group, &[]);
                pass.dispatch_workgroups(k.workgroups[0], k.workgroups[1], 1);
            }
        }
        for k in kernels {
            encoder.copy_buffer_to_buffer(&k.output, 0, &k.readback, 0, k.output.size());
        }
        self.queue.submit([encoder.finish()]);
        self.submissions
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.kernels
            .fetch_add(kernels.len(), std::sync::atomic::Ordering::Relaxed);
        let waiting = crate::clock::now_ms();
        let mapped: Vec<Slot<_>> = kernels
            .iter()
            .map(|k| {
                let slot = Slot::new();
                k.readback.map_async(wgpu::MapMode::Read, .., slot.setter());
                slot
            })
            .collect();
        // Natively the device is polled here; a browser's answers on its
        // event loop, which the awaits below return to.
        #[cfg(not(target_arch = "wasm32"))]
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| e.to_string())?;
        let mut done = Vec::with_capacity(kernels.len());
        for slot in mapped {
            done.push(slot.await);
        }
        self.waited_ns.fetch_add(
            ((crate::clock::now_ms() - waiting) * 1e6) as u64,
            std::sync::atomic::Ordering::Relaxed,
        );
        for scope in [invalid, out_of_memory] {
            if let Some(error) = scope.pop().await {
                return Err(format!("the GPU refused a kernel: {error}"));
            }
        }
        self.check("running a kernel").map_err(|e| e.to_string())?;
        kernels
            .iter()
            .zip(done)
            .map(|(k, done)| {
                done.map_err(|e| format!("reading a kernel's output back: {e}"))?;
                let view = k.readback.get_mapped_range(..).map_err(|e| e.to_string())?;
                Ok(view.to_vec())
            })
            .collect()
    }

    /// Submissions made to the device so far, and the kernels they ran:
    /// fewer submissions than kernels where parts share them
    /// ([`KernelQueue`]).
    pub fn submissions(&self) -> (usize, usize) {
        use std::sync::atomic::Ordering::Relaxed;
        (self.submissions.load(Relaxed), self.kernels.load(Relaxed))
    }

    /// Milliseconds the searches have spent waiting for the device so far,
    /// from each submission to its outputs read back (the kernels'
    /// running time and the transfers included): a search's match time
    /// less this is what the host did.
    pub fn waited_ms(&self) -> f64 {
        self.waited_ns.load(std::sync::atomic::Ordering::Relaxed) as f64 / 1e6
    }
}

/// A value a callback delivers, awaited: resolves once the callback ran.
struct Slot<T>(Arc<Mutex<SlotState<T>>>);

struct SlotState<T> {
    value: Option<T>,
    waker: Option<std::task::Waker>,
}

impl<T: Send + 'static> Slot<T> {
    fn new() -> Self {
        Slot(Arc::new(Mutex::new(SlotState {
            value: None,
            waker: None,
        })))
    }

    /// The callback that fills the slot.
    fn setter(&self) -> impl FnOnce(T) + Send + 'static {
        let state = self.0.clone();
        move |value| {
            let mut s = state.lock().unwrap_or_else(|p| p.into_inner());
            s.value = Some(value);
            if let Some(waker) = s.waker.take() {
                waker.wake();
            }
        }
    }
}

impl<T> std::future::Future for Slot<T> {
    type Output = T;

    fn poll(self: std::pin::Pin<&mut Self>, cx: &mut std::task::Context<'_>) -> std::task::Poll<T> {
        let mut s = self.0.lock().unwrap_or_else(|p| p.into_inner());
        match s.value.take() {
            Some(value) => std::task::Poll::Ready(value),
            None => {
                s.waker = Some(cx.waker().clone());
                std::task::Poll::Pending
            }
        }
    }
}

/// Tables that depend on a ball or sphere alone, not on the solid, kept on
/// the device for every part and search, the latest used first: the one
/// `found` picks if kept, else `upload`ed; the list keeps as many as fit
/// in `limit` bytes by `bytes`.
fn kept_tables<T: Clone>(
    kept: &Mutex<Vec<T>>,
    found: impl Fn(&T) -> bool,
    upload: impl FnOnce() -> T,
    bytes: impl Fn(&T) -> u64,
    limit: u64,
) -> T {
    let mut kept = kept.lock().unwrap_or_else(|p| p.into_inner());
    let tables = match kept.iter().position(found) {
        Some(i) => kept.remove(i),
        None => upload(),
    };
    kept.insert(0, tables.clone());
    let mut total = 0;
    kept.retain(|t| {
        total += bytes(t);
        total <= limit
    });
    tables
}

/// A read-only storage buffer holding `bytes`.
fn storage(device: &wgpu::Device, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytes,
        usage: wgpu::BufferUsages::STORAGE,
    })
}

fn unavailable(reason: String) -> Error {
    Error::Gpu {
        reason: reason.into(),
    }
}

// Native: they block on the device (the browser's path has its own test,
// tests/wasm_gpu.rs).
#[cfg(all(test, not(target_arch = "wasm32")))]
pub(crate) mod tests;
