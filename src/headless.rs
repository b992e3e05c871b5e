//! Headless rendering: an app with Bevy's default plugins but no window, a camera drawing into an
//! image, and the frame's pixels read back into memory.
//!
//! Used by the crate's render tests and by the clip recorder. It works on any Vulkan adapter,
//! including Mesa's CPU rasteriser lavapipe (Debian: `mesa-vulkan-drivers libvulkan1`), so it
//! needs no GPU.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_cartoon_hair::headless::{HeadlessRenderer, CaptureSettings};
//!
//! let mut renderer = HeadlessRenderer::new(CaptureSettings::default()).unwrap();
//! let camera_target = renderer.target();
//! renderer.app.world_mut().spawn((
//!     Camera3d::default(),
//!     bevy::camera::RenderTarget::Image(camera_target.into()),
//!     Transform::from_xyz(0.0, 0.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y),
//! ));
//! let frame = renderer.capture().unwrap();
//! println!("centre pixel: {:?}", frame.pixel(frame.width / 2, frame.height / 2));
//! ```

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use bevy::app::PluginsState;
use bevy::prelude::*;
use bevy::render::pipelined_rendering::PipelinedRenderingPlugin;
use bevy::render::render_resource::{
    CachedPipelineState, PipelineCache, TextureFormat, TextureUsages,
};
use bevy::render::renderer::{
    RenderAdapter, RenderAdapterInfo, RenderDevice, RenderInstance, RenderQueue,
};
use bevy::render::settings::{RenderCreation, RenderResources};
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::render::{RenderApp, RenderPlugin};
use bevy::window::ExitCondition;

/// What to install when no adapter is found (Debian and Ubuntu package names).
pub const ADAPTER_HELP: &str = "no Vulkan adapter found: install a GPU driver, or Mesa's CPU \
    rasteriser with `sudo apt-get install mesa-vulkan-drivers libvulkan1` (Debian/Ubuntu)";

/// Why a headless frame could not be produced.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum HeadlessError {
    /// wgpu found no Vulkan adapter on this machine.
    #[error("{ADAPTER_HELP}")]
    NoAdapter,
    /// The adapter refused to open a device.
    #[error("the GPU adapter would not open a device: {0}")]
    DeviceFailed(String),
    /// Some render pipeline failed to compile (usually a shader error).
    #[error("a render pipeline failed: {0}")]
    PipelineFailed(String),
    /// Pipelines were still compiling, or the capture never arrived, after this many frames
    /// (and at least [`CaptureSettings::min_wait`]).
    #[error("no frame captured after {0} frames")]
    Timeout(u32),
    /// A captured frame could not be written as a PNG file.
    #[error("{path}: cannot write the PNG: {message}")]
    SavePng {
        /// The file.
        path: std::path::PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// A frame count and a moment that must both have passed before a wait gives up.
struct Deadline {
    frame: u32,
    not_before: std::time::Instant,
}

impl Deadline {
    fn passed(&self, frames: u32) -> bool {
        frames >= self.frame && std::time::Instant::now() >= self.not_before
    }
}

/// The process's one GPU context: a `wgpu` instance, its adapter, device and queue, created on
/// first use and shared by [`find_adapter`] and every [`HeadlessRenderer`] (Bevy's
/// `RenderCreation::Manual`). Drivers run out of instances when a process makes many (an NVIDIA
/// driver refuses adapters after about 30), and each device keeps memory of its own, so a process
/// that starts and drops renderers without limit (tests, the clip recorder, a batch exporter)
/// makes them once.
struct GpuContext {
    resources: RenderResources,
    adapter_name: String,
}

static GPU: OnceLock<Result<GpuContext, HeadlessError>> = OnceLock::new();
static INSTANCES_CREATED: AtomicUsize = AtomicUsize::new(0);

/// How many `wgpu` instances this module has created in this process: `1` once any renderer
/// or [`find_adapter`] ran, however many renderers came and went (`0` before).
pub fn gpu_instances_created() -> usize {
    INSTANCES_CREATED.load(Ordering::Relaxed)
}

/// The shared context, created on the first call.
fn gpu() -> Result<&'static GpuContext, HeadlessError> {
    GPU.get_or_init(create_gpu).as_ref().map_err(Clone::clone)
}

/// A Vulkan instance, adapter and device as Bevy's automatic set-up makes them
/// (`WgpuSettingsPriority::Functionality`: the adapter's features and limits, timestamp and
/// pipeline-statistics queries among them where it has them).
fn create_gpu() -> Result<GpuContext, HeadlessError> {
    INSTANCES_CREATED.fetch_add(1, Ordering::Relaxed);
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapter = bevy::tasks::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..default()
    }))
    .map_err(|_| HeadlessError::NoAdapter)?;
    let info = adapter.get_info();
    let mut features = adapter.features();
    if info.device_type == wgpu::DeviceType::DiscreteGpu {
        // As Bevy does: slow on a discrete GPU.
        features.remove(wgpu::Features::MAPPABLE_PRIMARY_BUFFERS);
    }
    // Experimental features (mesh shaders, ray queries) need an unsafe opt-in and nothing here
    // uses them.
    features.remove(wgpu::Features::all_experimental_mask());
    features |= wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES;
    let (device, queue) = bevy::tasks::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("bevy_cartoon_hair headless"),
        required_features: features,
        required_limits: adapter.limits(),
        ..default()
    }))
    .map_err(|e| HeadlessError::DeviceFailed(format!("{}: {e}", info.name)))?;
    let adapter_name = info.name.clone();
    Ok(GpuContext {
        resources: RenderResources(
            RenderDevice::from(device),
            RenderQueue::new(queue),
            RenderAdapterInfo::new(info),
            RenderAdapter::new(adapter),
            RenderInstance::new(instance),
        ),
        adapter_name,
    })
}

/// Looks for a Vulkan adapter the way Bevy will and opens it, without starting Bevy. Returns its
/// name. The instance and device are the ones every [`HeadlessRenderer`] of this process uses.
pub fn find_adapter() -> Result<String, HeadlessError> {
    gpu().map(|gpu| gpu.adapter_name.clone())
}

/// Size and patience of a headless capture.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureSettings {
    /// Width of the image target in pixels. Default: `256`.
    pub width: u32,
    /// Height of the image target in pixels. Default: `256`.
    pub height: u32,
    /// Frames to run before looking at pipelines at all (lets assets and meshes reach the GPU).
    /// Default: `3`.
    pub min_frames: u32,
    /// Consecutive frames with no pipeline still compiling before the capture is taken.
    /// Default: `4`.
    pub settle_frames: u32,
    /// Give up after this many frames. Default: `600`.
    pub max_frames: u32,
    /// ... but not before this much wall-clock time has passed: files load and shaders compile at
    /// the disk's and the driver's pace, and a fast GPU runs hundreds of small frames a second.
    /// Default: 30 s.
    pub min_wait: std::time::Duration,
    /// Render on a thread of its own, one frame behind the app, as a game does
    /// (`PipelinedRenderingPlugin`). Default: `false` (each frame drawn in its own update).
    pub pipelined_rendering: bool,
    /// The asset folder, when it is not the default `assets` (a path relative to
    /// `BEVY_ASSET_ROOT`, or absolute). Default: `None`.
    pub asset_folder: Option<String>,
}

impl Default for CaptureSettings {
    fn default() -> Self {
        Self {
            width: 256,
            height: 256,
            min_frames: 3,
            settle_frames: 4,
            max_frames: 600,
            min_wait: std::time::Duration::from_secs(30),
            pipelined_rendering: false,
            asset_folder: None,
        }
    }
}

/// A captured frame: tightly packed sRGB RGBA8 pixels, row by row from the top.
#[derive(Debug, Clone, PartialEq)]
pub struct CapturedFrame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 4` bytes.
    pub rgba: Vec<u8>,
}

impl CapturedFrame {
    /// The pixel at `(x, y)`, `y` counted from the top.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 4] {
        let i = ((y * self.width + x) * 4) as usize;
        [
            self.rgba[i],
            self.rgba[i + 1],
            self.rgba[i + 2],
            self.rgba[i + 3],
        ]
    }

    /// Number of pixels for which `predicate` holds.
    pub fn count(&self, predicate: impl Fn([u8; 4]) -> bool) -> usize {
        self.rgba
            .chunks_exact(4)
            .filter(|p| predicate([p[0], p[1], p[2], p[3]]))
            .count()
    }

    /// Encodes the frame as a PNG file.
    ///
    /// # Errors
    ///
    /// [`HeadlessError::SavePng`] naming the file when it cannot be encoded or written.
    pub fn save_png(&self, path: impl AsRef<std::path::Path>) -> Result<(), HeadlessError> {
        let path = path.as_ref();
        let fail = |message: String| HeadlessError::SavePng {
            path: path.to_path_buf(),
            message,
        };
        let image = Image::new(
            bevy::render::render_resource::Extent3d {
                width: self.width,
                height: self.height,
                depth_or_array_layers: 1,
            },
            bevy::render::render_resource::TextureDimension::D2,
            self.rgba.clone(),
            TextureFormat::Rgba8UnormSrgb,
            bevy::asset::RenderAssetUsages::default(),
        );
        let dynamic = image.try_into_dynamic().map_err(|e| fail(e.to_string()))?;
        dynamic
            .to_rgba8()
            .save(path)
            .map_err(|e| fail(e.to_string()))
    }
}

/// A windowless Bevy app that renders into an image and reads frames back.
///
/// Add plugins, resources and entities to [`HeadlessRenderer::app`] like to any app; point a
/// camera at [`HeadlessRenderer::target`]; then call [`HeadlessRenderer::capture`].
pub struct HeadlessRenderer {
    /// The app. Plugins may be added until the first [`HeadlessRenderer::capture`].
    pub app: App,
    settings: CaptureSettings,
    target: Handle<Image>,
    frames: u32,
    pipelines: PipelineReport,
}

impl HeadlessRenderer {
    /// Builds the app with `DefaultPlugins` minus the window backend and logging (and
    /// pipelined rendering unless [`CaptureSettings::pipelined_rendering`]), on the process's
    /// shared GPU device. Fails with [`HeadlessError::NoAdapter`] before starting Bevy if no
    /// adapter exists.
    pub fn new(settings: CaptureSettings) -> Result<Self, HeadlessError> {
        let gpu = gpu()?;
        let mut app = App::new();
        let mut assets = bevy::asset::AssetPlugin::default();
        if let Some(folder) = &settings.asset_folder {
            assets.file_path.clone_from(folder);
        }
        let plugins = DefaultPlugins
            .set(assets)
            .set(RenderPlugin {
                render_creation: RenderCreation::Manual(Box::new(gpu.resources.clone())),
                ..default()
            })
            .set(WindowPlugin {
                primary_window: None,
                exit_condition: ExitCondition::DontExit,
                close_when_requested: false,
                ..default()
            })
            .disable::<bevy::winit::WinitPlugin>()
            .disable::<bevy::log::LogPlugin>();
        if settings.pipelined_rendering {
            app.add_plugins(plugins);
        } else {
            // Stepped by hand, each frame drawn in its own update.
            app.add_plugins(plugins.disable::<PipelinedRenderingPlugin>());
        }
        let mut image = Image::new_target_texture(
            settings.width,
            settings.height,
            TextureFormat::Rgba8UnormSrgb,
            None,
        );
        image.texture_descriptor.usage |= TextureUsages::COPY_SRC;
        let target = app.world_mut().resource_mut::<Assets<Image>>().add(image);
        let pipelines: PipelineReport = Arc::new(Mutex::new(Ok(false)));
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .insert_resource(PipelineReporter(pipelines.clone()))
                .add_systems(
                    bevy::render::Render,
                    report_pipelines.in_set(bevy::render::RenderSystems::Cleanup),
                );
        }
        Ok(Self {
            app,
            settings,
            target,
            frames: 0,
            pipelines,
        })
    }

    /// The image the camera should render into.
    pub fn target(&self) -> Handle<Image> {
        self.target.clone()
    }

    /// Frames run so far.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Runs one frame, finishing plugin setup first if needed.
    pub fn update(&mut self) {
        if self.app.plugins_state() != PluginsState::Cleaned {
            while self.app.plugins_state() == PluginsState::Adding {
                bevy::tasks::tick_global_task_pools_on_main_thread();
            }
            self.app.finish();
            self.app.cleanup();
        }
        self.app.update();
        self.frames += 1;
    }

    /// Runs one frame that advances time by `seconds`, the app's clock otherwise standing still
    /// (`TimeUpdateStrategy::ManualDuration` of zero between calls): frames that only wait for
    /// pipelines or captures move nothing.
    pub fn update_by(&mut self, seconds: f32) {
        use bevy::time::TimeUpdateStrategy;
        self.app.insert_resource(TimeUpdateStrategy::ManualDuration(
            std::time::Duration::from_secs_f32(seconds.max(0.0)),
        ));
        self.update();
        self.app.insert_resource(TimeUpdateStrategy::ManualDuration(
            std::time::Duration::ZERO,
        ));
    }

    /// Runs frames until every render pipeline has compiled and stayed settled, then captures the
    /// target image and returns its pixels.
    pub fn capture(&mut self) -> Result<CapturedFrame, HeadlessError> {
        let deadline = self.deadline();
        let mut settled = 0;
        for _ in 0..self.settings.min_frames {
            self.update();
        }
        while settled < self.settings.settle_frames {
            if deadline.passed(self.frames) {
                return Err(HeadlessError::Timeout(self.settings.max_frames));
            }
            self.update();
            match self.pipelines_state()? {
                true => settled += 1,
                false => settled = 0,
            }
        }
        let slot: Arc<Mutex<Option<Image>>> = Arc::default();
        let sink = slot.clone();
        self.app
            .world_mut()
            .spawn(Screenshot::image(self.target.clone()))
            .observe(move |captured: On<ScreenshotCaptured>| {
                *sink.lock().unwrap() = Some(captured.image.clone());
            });
        while !deadline.passed(self.frames) {
            self.update();
            if let Some(image) = slot.lock().unwrap().take() {
                let width = image.width();
                let height = image.height();
                let rgba = image.data.unwrap_or_default();
                return Ok(CapturedFrame {
                    width,
                    height,
                    rgba,
                });
            }
        }
        Err(HeadlessError::Timeout(self.settings.max_frames))
    }

    /// Runs frames until `ready` holds and then every render pipeline has compiled and stayed
    /// settled for [`CaptureSettings::settle_frames`] frames: the scene is loaded and the next
    /// frame draws it completely.
    ///
    /// # Errors
    ///
    /// [`HeadlessError::PipelineFailed`] if a pipeline fails, [`HeadlessError::Timeout`] after
    /// [`CaptureSettings::max_frames`] frames.
    pub fn warm_up(
        &mut self,
        mut ready: impl FnMut(&mut World) -> bool,
    ) -> Result<(), HeadlessError> {
        let deadline = self.deadline();
        let mut settled = 0;
        while settled < self.settings.settle_frames.max(1) {
            if deadline.passed(self.frames) {
                return Err(HeadlessError::Timeout(self.settings.max_frames));
            }
            self.update();
            let idle = self.pipelines_state()?;
            settled = if idle && ready(self.app.world_mut()) {
                settled + 1
            } else {
                0
            };
        }
        Ok(())
    }

    /// Captures `count` consecutive frames: one [`App::update`] per frame, each frame's image
    /// read back and handed to `each(index, frame)` in order. Call [`HeadlessRenderer::warm_up`]
    /// first so the first frame is complete. The app runs a few more frames after the last one
    /// while the readbacks arrive.
    ///
    /// # Errors
    ///
    /// [`HeadlessError::Timeout`] if the frames have not all arrived
    /// [`CaptureSettings::max_frames`] frames after the last one.
    pub fn capture_sequence(
        &mut self,
        count: u32,
        mut each: impl FnMut(u32, CapturedFrame),
    ) -> Result<(), HeadlessError> {
        type Arrived = Arc<Mutex<Vec<(u32, Image)>>>;
        let arrived: Arrived = Arc::default();
        let mut pending: std::collections::BTreeMap<u32, CapturedFrame> = default();
        let mut next = 0;
        let mut deliver = |arrived: &Arrived, next: &mut u32| {
            for (index, image) in arrived.lock().unwrap().drain(..) {
                let frame = CapturedFrame {
                    width: image.width(),
                    height: image.height(),
                    rgba: image.data.unwrap_or_default(),
                };
                pending.insert(index, frame);
            }
            // In order, even if readbacks complete out of order.
            while let Some(frame) = pending.remove(next) {
                each(*next, frame);
                *next += 1;
            }
        };
        for index in 0..count {
            let sink = arrived.clone();
            self.app
                .world_mut()
                .spawn(Screenshot::image(self.target.clone()))
                .observe(move |captured: On<ScreenshotCaptured>| {
                    sink.lock().unwrap().push((index, captured.image.clone()));
                });
            self.update();
            deliver(&arrived, &mut next);
        }
        let deadline = self.deadline();
        while next < count {
            if deadline.passed(self.frames) {
                return Err(HeadlessError::Timeout(self.settings.max_frames));
            }
            self.update();
            deliver(&arrived, &mut next);
        }
        Ok(())
    }

    /// When the calls that wait give up: [`CaptureSettings::max_frames`] frames from now, and
    /// no sooner than [`CaptureSettings::min_wait`].
    fn deadline(&self) -> Deadline {
        Deadline {
            frame: self.frames.saturating_add(self.settings.max_frames),
            not_before: std::time::Instant::now() + self.settings.min_wait,
        }
    }

    /// `Ok(true)` when no pipeline was queued or compiling in the last frame the render world
    /// finished; an error if one failed.
    fn pipelines_state(&self) -> Result<bool, HeadlessError> {
        self.pipelines
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clone()
    }
}

/// The render world's pipelines as of its last frame: `Ok(true)` when all have compiled. Shared
/// with the render world, which may run on a thread of its own (pipelined rendering).
type PipelineReport = Arc<Mutex<Result<bool, HeadlessError>>>;

/// Render world: writes the pipelines' state into the renderer's report, every frame.
#[derive(Resource, Clone)]
struct PipelineReporter(PipelineReport);

fn report_pipelines(reporter: Res<PipelineReporter>, cache: Res<PipelineCache>) {
    let mut state = Ok(true);
    for pipeline in cache.pipelines() {
        match &pipeline.state {
            CachedPipelineState::Queued | CachedPipelineState::Creating(_) => state = Ok(false),
            // Bevy retries these once the shader (or an import) has loaded.
            CachedPipelineState::Err(
                bevy::shader::ShaderCacheError::ShaderNotLoaded(_)
                | bevy::shader::ShaderCacheError::ShaderImportNotYetAvailable,
            ) => state = Ok(false),
            CachedPipelineState::Err(err) => {
                let label = match &pipeline.descriptor {
                    bevy::render::render_resource::PipelineDescriptor::RenderPipelineDescriptor(d) => d.label.clone(),
                    bevy::render::render_resource::PipelineDescriptor::ComputePipelineDescriptor(d) => d.label.clone(),
                    bevy::render::render_resource::PipelineDescriptor::MeshPipelineDescriptor(d) => d.label.clone(),
                };
                state = Err(HeadlessError::PipelineFailed(format!("{label:?}: {err}")));
                break;
            }
            CachedPipelineState::Ok(_) => {}
        }
    }
    *reporter
        .0
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner) = state;
}
