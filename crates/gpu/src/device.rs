//! The compute device: one adapter, one device and queue, and the helpers every evaluator
//! uses (buffers, pipelines, bind groups, readback).

use crate::GpuError;
use wgpu::util::DeviceExt;

/// A compute device (no surface).
#[derive(Debug)]
pub struct Gpu {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
}

/// How to get a device on a machine without a GPU (the message of [`GpuError::NoAdapter`]).
pub const INSTALL_HINT: &str = "install a Vulkan driver; without a GPU, Mesa's lavapipe (Debian/Ubuntu: \
     `apt-get install mesa-vulkan-drivers libvulkan1`), then, if several drivers are installed, \
     `export VK_ICD_FILENAMES=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json`";

impl Gpu {
    /// The first adapter of the native backends (Vulkan, Metal, DX12; `WGPU_BACKEND` and
    /// `WGPU_ADAPTER_NAME` override, as wgpu documents), with its own limits.
    pub fn new() -> Result<Self, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
        let desc = desc.with_env();
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("penumbra"),
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        Ok(Self { device, queue, info })
    }

    /// The adapter's name (`llvmpipe (LLVM 15.0.6, 256 bits)` for lavapipe).
    pub fn adapter(&self) -> &str {
        &self.info.name
    }

    /// The backend (`vulkan`, `metal`, `dx12`).
    pub fn backend(&self) -> String {
        self.info.backend.to_string()
    }

    /// The device type (`Cpu` for a software device such as lavapipe).
    pub fn device_type(&self) -> String {
        format!("{:?}", self.info.device_type)
    }

    /// A storage buffer holding `data` (at least 4 bytes: WGSL arrays cannot be empty).
    pub(crate) fn storage<T: bytemuck::Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let padded;
        let contents = if bytes.len() < 4 {
            padded = [0u8; 4];
            &padded[..]
        } else {
            bytes
        };
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
        })
    }

    /// A zeroed storage buffer of `n` f32 (at least one).
    pub(crate) fn zeros(&self, label: &str, n: usize) -> wgpu::Buffer {
        self.storage(label, &vec![0.0f32; n.max(1)])
    }

    /// A uniform buffer holding `data`.
    pub(crate) fn uniform<T: bytemuck::Pod>(&self, label: &str, data: &T) -> wgpu::Buffer {
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::bytes_of(data),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        })
    }

    /// Compiles `source` and makes one pipeline per entry point (layouts derived from what
    /// each entry point uses).
    pub(crate) fn pipelines(&self, name: &str, source: &str, entries: &[&str]) -> Vec<wgpu::ComputePipeline> {
        let module = self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(name),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        entries
            .iter()
            .map(|e| {
                self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(e),
                    layout: None,
                    module: &module,
                    entry_point: Some(e),
                    compilation_options: Default::default(),
                    cache: None,
                })
            })
            .collect()
    }

    /// The bind group of `pipeline`'s group 0 from `(binding, buffer)` pairs.
    pub(crate) fn bind(&self, pipeline: &wgpu::ComputePipeline, entries: &[(u32, &wgpu::Buffer)]) -> wgpu::BindGroup {
        let layout = pipeline.get_bind_group_layout(0);
        let entries: Vec<wgpu::BindGroupEntry<'_>> = entries
            .iter()
            .map(|(binding, buf)| wgpu::BindGroupEntry { binding: *binding, resource: buf.as_entire_binding() })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &layout, entries: &entries })
    }

    /// Submits `encoder`, waits, and copies `n` f32 of `buf` back.
    pub(crate) fn read(
        &self,
        mut encoder: wgpu::CommandEncoder,
        buf: &wgpu::Buffer,
        n: usize,
    ) -> Result<Vec<f32>, GpuError> {
        let size = (n.max(1) * 4) as u64;
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        encoder.copy_buffer_to_buffer(buf, 0, &staging, 0, size);
        self.queue.submit([encoder.finish()]);
        let slice = staging.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Device(e.to_string()))?;
        rx.recv().map_err(|e| GpuError::Device(e.to_string()))?.map_err(|e| GpuError::Device(e.to_string()))?;
        let view = slice.get_mapped_range().map_err(|e| GpuError::Device(e.to_string()))?;
        let mut out: Vec<f32> = bytemuck::cast_slice(&view).to_vec();
        drop(view);
        staging.unmap();
        out.truncate(n);
        Ok(out)
    }

    /// Submits `encoder` and waits for it (timing without a readback).
    pub(crate) fn run(&self, encoder: wgpu::CommandEncoder) -> Result<(), GpuError> {
        self.queue.submit([encoder.finish()]);
        self.device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ()).map_err(|e| GpuError::Device(e.to_string()))
    }

    /// A new command encoder.
    pub(crate) fn encoder(&self) -> wgpu::CommandEncoder {
        self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None })
    }
}

/// Work groups of 64 invocations covering `n`.
pub(crate) fn groups64(n: usize) -> u32 {
    n.div_ceil(64).max(1) as u32
}
