//! The device: one Vulkan adapter (a GPU, or Mesa's lavapipe on a machine
//! without one), with GPU timestamps where the adapter has them.

use crate::ViewError;

/// A wgpu device and its queue on the first Vulkan adapter.
pub struct Gpu {
    pub(crate) adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Whether render passes can be timed by GPU timestamps.
    pub timestamps: bool,
}

impl Gpu {
    /// A device for drawing offscreen (no window, no display needed).
    pub fn headless() -> Result<Gpu, ViewError> {
        Gpu::new(instance(), |_| None)
    }

    /// A device that can present to the surface `make_surface` builds from
    /// the instance (the window's); the surface comes back with it.
    pub(crate) fn with_surface(
        make_surface: impl FnOnce(&wgpu::Instance) -> Result<wgpu::Surface<'static>, ViewError>,
    ) -> Result<(Gpu, wgpu::Surface<'static>), ViewError> {
        let instance = instance();
        let surface = make_surface(&instance)?;
        let gpu = Gpu::new(instance, |_| Some(&surface))?;
        Ok((gpu, surface))
    }

    fn new<'s>(
        instance: wgpu::Instance,
        surface: impl FnOnce(&wgpu::Instance) -> Option<&'s wgpu::Surface<'static>>,
    ) -> Result<Gpu, ViewError> {
        let compatible_surface = surface(&instance);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface,
        }))
        .map_err(|e| ViewError::NoAdapter(e.to_string()))?;
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let required_features = if timestamps {
            wgpu::Features::TIMESTAMP_QUERY
        } else {
            wgpu::Features::empty()
        };
        // The adapter's own limits: big scenes need big vertex buffers.
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("hom-view"),
            required_features,
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| ViewError::Device(e.to_string()))?;
        Ok(Gpu {
            adapter,
            device,
            queue,
            timestamps,
        })
    }

    /// The adapter, its driver and backend, in one line: "llvmpipe (LLVM
    /// 15.0.6, 256 bits), Mesa 22.3.6, Vulkan, cpu".
    pub fn describe(&self) -> String {
        let info = self.adapter.get_info();
        let driver = [info.driver.as_str(), info.driver_info.as_str()]
            .into_iter()
            .filter(|s| !s.is_empty())
            .collect::<Vec<_>>()
            .join(" ");
        let kind = match info.device_type {
            wgpu::DeviceType::Cpu => "cpu",
            wgpu::DeviceType::DiscreteGpu => "discrete gpu",
            wgpu::DeviceType::IntegratedGpu => "integrated gpu",
            wgpu::DeviceType::VirtualGpu => "virtual gpu",
            wgpu::DeviceType::Other => "other",
        };
        format!("{}, {driver}, {:?}, {kind}", info.name, info.backend)
    }

    /// Waits until the queue has done everything submitted.
    pub(crate) fn wait(&self) -> Result<(), ViewError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| ViewError::Device(e.to_string()))
    }

    /// The bytes of `buffer` (mapped for reading), after the queue is done.
    pub(crate) fn read(&self, buffer: &wgpu::Buffer) -> Result<Vec<u8>, ViewError> {
        let slice = buffer.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv()
            .map_err(|e| ViewError::Device(e.to_string()))?
            .map_err(|e| ViewError::Device(e.to_string()))?;
        let bytes = slice.get_mapped_range().to_vec();
        buffer.unmap();
        Ok(bytes)
    }
}

/// Vulkan only: the one backend this crate builds (lavapipe where there is no GPU).
fn instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    wgpu::Instance::new(desc)
}
