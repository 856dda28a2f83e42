//! Finding a GPU adapter and opening a device for compute work.
//!
//! Honours `WGPU_BACKEND` (e.g. `vulkan`), `WGPU_ADAPTER_NAME` (a substring of the adapter
//! name, e.g. `llvmpipe`) and `WGPU_POWER_PREF`, as wgpu's own tools do, but reports a
//! missing adapter as an error that says how to install one instead of panicking.

use std::sync::{Arc, Mutex};

use crate::error::{Error, Result};
use wgpu::{Adapter, Backends, Device, Features, Instance, InstanceDescriptor, Limits, Queue};

/// An open device with the optional features cuberay uses when the adapter has them.
pub struct GpuContext {
    pub adapter: Adapter,
    pub device: Device,
    pub queue: Queue,
    pub info: wgpu::AdapterInfo,
    /// Timestamp queries are available: kernel times can be measured on the GPU.
    pub timestamps: bool,
    /// Whether kernels may compute in f64 (`SHADER_F64`: `--precision f64`).
    pub f64: bool,
    /// Whether kernels may use the platform's ray queries (`EXPERIMENTAL_RAY_QUERY`:
    /// `--accel rayquery`, and the rays leaving surfaces under `cube`).
    pub ray_queries: bool,
    /// Seconds it took to open: the instance, the adapter and the device.
    pub opened_s: f64,
    /// The first fault the device reported on its own (a lost device, or an error no
    /// operation of ours captured): every later wait returns it as an error.
    fault: Arc<Mutex<Option<String>>>,
}

impl GpuContext {
    /// Opens the first suitable adapter (see the module documentation for the variables).
    pub fn new() -> Result<GpuContext> {
        pollster::block_on(Self::new_async())
    }

    async fn new_async() -> Result<GpuContext> {
        let start = std::time::Instant::now();
        let instance = Self::instance(InstanceDescriptor::new_without_display_handle_from_env());
        let instance_s = start.elapsed().as_secs_f64();
        let mut ctx = Self::open(&instance, None).await?;
        ctx.opened_s = start.elapsed().as_secs_f64();
        log::info!("GPU opened in {:.3} s (instance {:.3} s)", ctx.opened_s, instance_s);
        Ok(ctx)
    }

    /// An instance on the primary backends (Vulkan, Metal, DX12; compute needs no GL)
    /// unless `WGPU_BACKEND` says otherwise.
    pub fn instance(mut desc: InstanceDescriptor) -> Instance {
        desc.backends = desc_backends();
        Instance::new(desc)
    }

    /// Opens an adapter of `instance` (one that can present to `surface` when given) as
    /// [`GpuContext::new`] does.
    pub async fn open(instance: &Instance, surface: Option<&wgpu::Surface<'_>>) -> Result<GpuContext> {
        let start = std::time::Instant::now();
        let adapter = pick_adapter(instance, desc_backends(), surface).await?;
        log::info!("adapter found in {:.3} s", start.elapsed().as_secs_f64());
        let info = adapter.get_info();
        let wanted = Features::TIMESTAMP_QUERY | Features::SHADER_F64 | Features::EXPERIMENTAL_RAY_QUERY;
        let features = adapter.features() & wanted;
        let ray_queries = features.contains(Features::EXPERIMENTAL_RAY_QUERY);
        // Ask for the adapter's own storage limits: the tables are large.
        let adapter_limits = adapter.limits();
        let mut limits = Limits {
            max_storage_buffer_binding_size: adapter_limits.max_storage_buffer_binding_size,
            max_buffer_size: adapter_limits.max_buffer_size,
            max_storage_buffers_per_shader_stage: adapter_limits.max_storage_buffers_per_shader_stage,
            ..Limits::downlevel_defaults().using_resolution(adapter_limits.clone())
        };
        if ray_queries {
            // The acceleration-structure limits are 0 by default; the adapter's own, not
            // wgpu's "minimum supported" ones, which lavapipe's primitive count is below.
            limits = limits.using_acceleration_structure_values(adapter_limits.clone());
        }
        // wgpu marks ray queries experimental and wants them asked for knowingly. The
        // kernels keep the rules its checks would (src/gpu/kernels.rs, rayquery.wgsl).
        let experimental = if ray_queries {
            // SAFETY: only the ray-query kernels use the experimental feature, and they keep
            // to what wgpu 30's ray queries support (procedural boxes, one instance, queries
            // declared outside loops, generated hits within the query's limits).
            unsafe { wgpu::ExperimentalFeatures::enabled() }
        } else {
            wgpu::ExperimentalFeatures::disabled()
        };
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("cuberay"),
                required_features: features,
                required_limits: limits,
                experimental_features: experimental,
                ..Default::default()
            })
            .await
            .map_err(|source| Error::Device { adapter: info.name.clone(), source })?;
        log::info!("GPU: {} ({:?}, {})", info.name, info.backend, info.driver_info);
        // wgpu's default reaction to an error nobody captured is a panic: record it instead,
        // and a lost device too, so that the render ends with an error that says so.
        let fault: Arc<Mutex<Option<String>>> = Arc::default();
        let record = |fault: &Arc<Mutex<Option<String>>>, message: String| {
            log::error!("{message}");
            fault.lock().expect("fault lock").get_or_insert(message);
        };
        let f = fault.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            record(&f, format!("the GPU reported: {e}"))
        }));
        let f = fault.clone();
        device.set_device_lost_callback(move |reason, message| {
            record(&f, format!("the GPU device was lost ({reason:?}): {message}"))
        });
        Ok(GpuContext {
            adapter,
            device,
            queue,
            timestamps: features.contains(Features::TIMESTAMP_QUERY),
            f64: features.contains(Features::SHADER_F64),
            ray_queries,
            opened_s: start.elapsed().as_secs_f64(),
            info,
            fault,
        })
    }
}

/// A failed wgpu call, wgpu's error kept as the source.
fn gpu_call(what: &'static str, e: impl std::error::Error + Send + Sync + 'static) -> Error {
    Error::GpuCall { what, source: Box::new(e) }
}

impl GpuContext {
    /// What this adapter offers that a render's choices depend on.
    pub fn capabilities(&self) -> super::Capabilities {
        let limits = self.device.limits();
        super::Capabilities {
            adapter: format!("{} ({})", self.info.name, self.info.driver_info),
            lavapipe: self.is_lavapipe(),
            ray_queries: self.ray_queries,
            f64: self.f64,
            max_binding: limits.max_storage_buffer_binding_size.min(limits.max_buffer_size),
        }
    }

    /// Whether the adapter is Mesa's lavapipe (llvmpipe), whose loop limit the kernels keep to.
    pub fn is_lavapipe(&self) -> bool {
        self.info.name.to_lowercase().contains("llvmpipe")
    }

    /// `Err(Error::Gpu)` once the device has reported a fault.
    pub fn fault(&self) -> Result<()> {
        match self.fault.lock().expect("fault lock").as_ref() {
            Some(message) => Err(Error::Gpu(message.clone())),
            None => Ok(()),
        }
    }

    /// Waits until the queue has done everything submitted so far.
    pub fn wait(&self) -> Result<()> {
        self.device
            .poll(wgpu::PollType::Wait { submission_index: None, timeout: None })
            .map_err(|e| gpu_call("waiting for the queue", e))?;
        self.fault()
    }

    /// Waits for the queue and copies the first `bytes` of mappable `buffer`.
    pub fn read(&self, buffer: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>> {
        self.fault()?;
        let (tx, rx) = std::sync::mpsc::channel();
        buffer.map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::Wait { submission_index: None, timeout: None })
            .map_err(|e| gpu_call("waiting for a readback", e))?;
        self.fault()?;
        const MAPPING: &str = "mapping a buffer for a readback";
        rx.recv().map_err(|e| gpu_call(MAPPING, e))?.map_err(|e| gpu_call(MAPPING, e))?;
        let data = buffer.get_mapped_range(0..bytes).map_err(|e| gpu_call(MAPPING, e))?.to_vec();
        buffer.unmap();
        Ok(data)
    }

    /// A buffer the host can map to read `size` bytes copied into it.
    pub fn readback_buffer(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }
}

fn desc_backends() -> Backends {
    Backends::from_env().unwrap_or(Backends::PRIMARY)
}

async fn pick_adapter(
    instance: &Instance,
    backends: Backends,
    surface: Option<&wgpu::Surface<'_>>,
) -> Result<Adapter> {
    let adapters = instance.enumerate_adapters(backends).await;
    if let Ok(name) = std::env::var("WGPU_ADAPTER_NAME") {
        let name = name.to_lowercase();
        return adapters
            .into_iter()
            .filter(|a| surface.is_none_or(|s| a.is_surface_supported(s)))
            .find(|a| a.get_info().name.to_lowercase().contains(&name))
            .ok_or(Error::NoAdapter { filter: format!(" matching WGPU_ADAPTER_NAME='{name}'") });
    }
    let options = wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::from_env().unwrap_or(wgpu::PowerPreference::HighPerformance),
        compatible_surface: surface,
        ..Default::default()
    };
    match instance.request_adapter(&options).await {
        Ok(a) => Ok(a),
        // A software adapter is fine for us: lavapipe is how CI runs.
        Err(_) => instance
            .request_adapter(&wgpu::RequestAdapterOptions { force_fallback_adapter: true, ..options })
            .await
            .map_err(|_| Error::NoAdapter { filter: String::new() }),
    }
}
