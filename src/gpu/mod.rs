//! The GPU backend (feature `gpu`): the harmonics layers of the cascade
//! computed on a GPU through wgpu.
//!
//! The device is made apart from the work and handed in ([`Gpu::new`]), so
//! that tests can give it a software adapter (lavapipe) and an embedder its
//! own device; [`Gpu::request`] finds one the usual way. A GPU's f32
//! signatures differ from the CPU's by rounding only; the harmonics stage
//! takes them as a filter with a guard band and recomputes on the CPU every
//! decision the difference could flip (see
//! [`crate::descriptor::harmonics::SphereBatch`]), so that both backends
//! keep the same candidates. Every failure (no adapter, a buffer past the
//! device's limits, a lost device) is reported and the search goes on on
//! the CPU.

mod harmonics;
mod solid;
mod volume;

pub use solid::GpuSolid;

use std::sync::{Arc, Mutex};

use crate::error::{Error, Result};

/// Every kernel's WGSL, by file name (validated by a test with no
/// adapter).
#[cfg(test)]
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
}

impl Gpu {
    /// Asks the system for an adapter of `choice` and a device on it;
    /// `Ok(None)` when there is none. Blocks until the device is ready.
    pub fn request(choice: AdapterChoice) -> Result<Option<Gpu>> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let options = wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        };
        let Ok(adapter) = pollster::block_on(instance.request_adapter(&options)) else {
            return Ok(None);
        };
        let info = adapter.get_info();
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
        let (device, queue) = pollster::block_on(adapter.request_device(&descriptor))
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
        };
        gpu.check("building the GPU pipelines")?;
        Ok(gpu)
    }

    /// The adapter's name and API, as reports show it.
    pub fn description(&self) -> String {
        let kind = if self.is_software() { ", software" } else { "" };
        format!("{} ({:?}{kind})", self.info.name, self.info.backend)
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

/// One kernel run: the uniform `params` at binding 0, `inputs` at the
/// next bindings in order, and an output buffer of `output_bytes` after
/// them, which is read back.
struct Dispatch<'a> {
    pipeline: &'a wgpu::ComputePipeline,
    params: &'a [u8],
    inputs: &'a [&'a wgpu::Buffer],
    output_bytes: u64,
    workgroups: [u32; 2],
}

impl Gpu {
    /// Runs `d` and returns its output's bytes. Blocks until the device is
    /// done; every error the device reports on the way fails it.
    fn run_kernel(&self, d: Dispatch) -> std::result::Result<Vec<u8>, String> {
        use wgpu::util::DeviceExt;
        let device = &self.device;
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: d.params,
            usage: wgpu::BufferUsages::UNIFORM,
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
        let resources = std::iter::once(&uniform)
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
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(d.pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(d.workgroups[0], d.workgroups[1], 1);
        }
        encoder.copy_buffer_to_buffer(&output, 0, &readback, 0, d.output_bytes);
        self.queue.submit([encoder.finish()]);
        let mapped: Arc<Mutex<Option<std::result::Result<(), wgpu::BufferAsyncError>>>> =
            Arc::default();
        let slot = mapped.clone();
        readback.map_async(wgpu::MapMode::Read, .., move |r| {
            *slot.lock().unwrap_or_else(|p| p.into_inner()) = Some(r);
        });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| e.to_string())?;
        self.check("running a kernel").map_err(|e| e.to_string())?;
        match mapped.lock().unwrap_or_else(|p| p.into_inner()).take() {
            Some(Ok(())) => {}
            Some(Err(e)) => return Err(format!("reading a kernel's output back: {e}")),
            None => return Err("the GPU never finished a kernel".into()),
        }
        let view = readback.get_mapped_range(..).map_err(|e| e.to_string())?;
        Ok(view.to_vec())
    }
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
    Error::Gpu { reason }
}

#[cfg(test)]
pub(crate) mod tests;
