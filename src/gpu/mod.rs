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

pub use harmonics::GpuSpheres;

use std::sync::{Arc, Mutex};

use crate::error::{Error, Result};

/// Every kernel's WGSL, by file name (validated by a test with no
/// adapter).
#[cfg(test)]
const SHADERS: &[(&str, &str)] = &[("harmonics.wgsl", harmonics::SHADER)];

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
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("harmonics"),
            source: wgpu::ShaderSource::Wgsl(harmonics::SHADER.into()),
        });
        let spheres = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("harmonics"),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let (fourier, legendre) = crate::descriptor::harmonics::unfolded_tables();
        let gpu = Gpu {
            fourier: storage(&device, "fourier", bytemuck::cast_slice(&fourier)),
            legendre: storage(&device, "legendre", bytemuck::cast_slice(&legendre)),
            device,
            queue,
            info,
            spheres,
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
