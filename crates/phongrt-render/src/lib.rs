//! A thin renderer on top of Embree: a world of flat or Phong objects, a camera, lights,
//! tiles rendered in parallel with rayon, deterministic whatever the thread count.

#![warn(missing_docs)]
// Comparisons written `!(x > 0.0)` are deliberate throughout: they are true for NaN, which is
// how bad input is turned away without a separate NaN test.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool)]

pub mod camera;
pub mod cost;
pub mod image_out;
pub mod render_record;
pub mod scene_file;
pub mod smoothness;
pub mod stitch;
pub mod temp_file;
pub mod text;
pub mod texture;
mod tracer;
pub mod world;

use std::time::Duration;

use glam::Vec3;
use rayon::prelude::*;

pub use camera::{detect_up, Camera, CameraFrame, CameraProblem, UpDetection, ViewSpec};
pub use image_out::{linear_to_srgb, Image, Window};
pub use world::{
    default_lights, AmbientOcclusion, Effects, Environment, EnvironmentSource, Geometry, Ground, Light,
    ObjectMode, ObjectSettings, Rng, Surface, SurfaceMode, SurfaceOverride, Terminator, World, WorldBuilder,
};

pub use cost::{estimate, CostEstimate};
use phongrt::embree::{self, EmbreeError, PhongMeshError};
pub use tracer::Progress;
use tracer::TILE;

/// Why a world could not be built, a render run, or an image written. The cause of a wrapped
/// error is its `source()`, so a caller printing the chain gets one line.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Width or height is 0 or above 32768.
    #[error("image size {width}x{height} is out of range (1..=32768 per side)")]
    ImageSize {
        /// The requested width.
        width: u32,
        /// The requested height.
        height: u32,
    },
    /// Samples per pixel is 0 or above 65536.
    #[error("samples per pixel {0} is out of range (1..=65536)")]
    Samples(u32),
    /// The camera has no frame.
    #[error("degenerate camera: eye equals look-at, up is parallel to the view, or fov not in (0, 180)")]
    Camera,
    /// The render thread pool could not start.
    #[error("cannot start render threads")]
    Threads(#[source] rayon::ThreadPoolBuildError),
    /// An object of the world was refused by Embree.
    #[error("object {name:?}")]
    Object {
        /// The object's name.
        name: String,
        /// Why.
        #[source]
        source: EmbreeError,
    },
    /// An object's Phong mesh was refused.
    #[error("object {name:?}")]
    PhongMesh {
        /// The object's name.
        name: String,
        /// Why.
        #[source]
        source: PhongMeshError,
    },
    /// A crop window that is not inside the frame.
    #[error("crop window {window} is not inside the {width}x{height} frame")]
    Crop {
        /// The window, as `X0,Y0,X1,Y1`.
        window: String,
        /// The frame's width.
        width: u32,
        /// The frame's height.
        height: u32,
    },
    /// Zero render threads.
    #[error("threads: 0 is not a thread count (at least 1)")]
    ZeroThreads,
    /// The environment map cannot be used: the message names the file and what is wrong.
    #[error("{0}")]
    Environment(String),
    /// A scene file's value out of range (the file, the key and what is wrong).
    #[error(transparent)]
    SceneFile(#[from] scene_file::SceneFileError),
    /// The ground plane's up direction or height is zero or not finite.
    #[error("ground: the up direction or height is zero or not finite")]
    Ground,
    /// Embree handed out a geomID out of attach order (shading looks objects up by geomID).
    #[error("unexpected geomID {0}")]
    UnexpectedGeomId(u32),
    /// Embree refused the world's scene.
    #[error(transparent)]
    Embree(#[from] EmbreeError),
    /// The output path has neither a `.png` nor an `.exr` extension.
    #[error("{}: unknown image extension (use .png or .exr)", path.display())]
    ImageExtension {
        /// The output path.
        path: std::path::PathBuf,
    },
    /// The image could not be encoded or written.
    #[error("{}: cannot write {format}", path.display())]
    ImageWrite {
        /// The output path.
        path: std::path::PathBuf,
        /// "PNG" or "EXR".
        format: &'static str,
        /// Why.
        #[source]
        source: image::ImageError,
    },
}

/// What to render and how.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Width of the full frame in pixels (default 800, as `phongrt render`'s).
    pub width: u32,
    /// Height of the full frame in pixels (default 600, as `phongrt render`'s).
    pub height: u32,
    /// Samples per pixel (stratified on a square grid when a perfect square).
    pub spp: u32,
    /// Seed of the per-pixel sample pattern.
    pub seed: u64,
    /// Trace camera rays and their hard shadows in coherent 8-ray packets from 4x2 pixel
    /// blocks (see [`World::shade8`]); `false` traces every ray alone. The image is the same.
    pub packets: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings { width: 800, height: 600, spp: 1, seed: 0, packets: true }
    }
}

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Camera rays, one per sample of the window's pixels.
    pub primary: u64,
    /// Shadow rays towards the lights (only lights with shadows; area lights always).
    pub shadow: u64,
    /// Reflection rays: off mirror materials, and the Fresnel reflection off transparent ones.
    pub reflection: u64,
    /// Refraction rays (only for transparent materials).
    pub refraction: u64,
    /// Ambient-occlusion rays (only with an [`AmbientOcclusion`] setting).
    pub ambient_occlusion: u64,
    /// Short rays that check a shadow-ray origin lift is clear (see [`world::Terminator::Lift`]).
    pub terminator: u64,
    /// Primary rays traced only to find the alpha channel (coverage), when asked for.
    pub coverage: u64,
    /// Highlight-lobe evaluations (not rays; glossy materials only).
    pub specular: u64,
    /// Texture lookups (not rays; textured materials only).
    pub texture: u64,
    /// Shadow rays towards the environment light (only with `[environment]`).
    pub environment: u64,
}

impl RayCounts {
    /// Every ray traced: all the counts but `specular` and `texture`, which are not rays.
    pub fn total(&self) -> u64 {
        self.primary
            + self.shadow
            + self.reflection
            + self.refraction
            + self.ambient_occlusion
            + self.terminator
            + self.coverage
            + self.environment
    }

    pub(crate) fn add(&mut self, o: &RayCounts) {
        self.primary += o.primary;
        self.shadow += o.shadow;
        self.reflection += o.reflection;
        self.refraction += o.refraction;
        self.ambient_occlusion += o.ambient_occlusion;
        self.terminator += o.terminator;
        self.coverage += o.coverage;
        self.specular += o.specular;
        self.texture += o.texture;
        self.environment += o.environment;
    }
}

impl std::fmt::Display for RayCounts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} rays ({} primary", self.total(), self.primary)?;
        for (n, k) in [
            (self.shadow, "shadow"),
            (self.reflection, "reflection"),
            (self.refraction, "refraction"),
            (self.ambient_occlusion, "ambient occlusion"),
            (self.terminator, "terminator lift"),
            (self.coverage, "coverage"),
            (self.environment, "environment"),
        ] {
            if n > 0 {
                write!(f, ", {n} {k}")?;
            }
        }
        write!(f, ")")?;
        if self.specular > 0 {
            write!(f, ", {} specular evaluations", self.specular)?;
        }
        if self.texture > 0 {
            write!(f, ", {} texture lookups", self.texture)?;
        }
        Ok(())
    }
}

/// An image and what it cost.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// The window's pixels (the whole frame unless a crop was asked for).
    pub image: Image,
    /// Coverage per pixel (the fraction of samples that hit a surface), when asked for; the
    /// image is then premultiplied: samples that miss add nothing, not the background.
    pub alpha: Option<Vec<f32>>,
    /// Where `image` sits in the full frame.
    pub window: Window,
    /// The rays traced for this image, by kind.
    pub rays: RayCounts,
    /// Wall-clock time spent tracing the tiles.
    pub elapsed: Duration,
    /// The worker threads used.
    pub threads: usize,
    /// Samples whose radiance was not a finite number (a light too bright for f32, say): NaN
    /// became 0 and anything above [`MAX_SAMPLE_RADIANCE`] was clamped to it.
    pub clamped_samples: u64,
}

/// The largest radiance one sample may carry: far above any real scene, and small enough that
/// 65536 samples still sum to a finite f32.
pub const MAX_SAMPLE_RADIANCE: f32 = 1e30;

/// Which part of the frame to render, and whether to compute an alpha channel.
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderExtent {
    /// A window of the full `width x height` frame; `None` = all of it.
    pub crop: Option<Window>,
    /// Compute coverage (alpha) per pixel.
    pub alpha: bool,
}

/// The bytes per pixel `render` and the PNG/EXR encoders hold at their peak: the tiles and the
/// assembled image (12 bytes each), alpha (4 in the tiles + 4 assembled), and the encoded output
/// (about 4). Measured peak resident set at 2048x2048 (`/usr/bin/time -v phongrt render ...`):
/// 26 bytes per pixel for PNG, 34 for EXR with alpha, both including the process's own ~10 MB.
pub const PEAK_BYTES_PER_PIXEL: u64 = 12 + 12 + 8 + 4;

/// The memory `render` needs for a window of `pixels`, in bytes (see [`PEAK_BYTES_PER_PIXEL`]).
pub fn memory_estimate(pixels: u64) -> u64 {
    pixels * PEAK_BYTES_PER_PIXEL
}

/// A hash of the pixel, sample and seed: the sample pattern depends on nothing else, so the
/// image is the same whatever the thread count or tile order.
pub(crate) fn sample_hash(x: u32, y: u32, s: u32, seed: u64) -> u64 {
    let mut z = seed ^ ((x as u64) << 40 | (y as u64) << 16 | s as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Sub-pixel offset of sample `s` of `spp`: the pixel centre for one sample, else a jittered
/// stratified grid (or plain jitter when `spp` is not a square).
pub fn sample_offset(x: u32, y: u32, s: u32, spp: u32, seed: u64) -> (f32, f32) {
    if spp <= 1 {
        return (0.5, 0.5);
    }
    let h = sample_hash(x, y, s, seed);
    let j1 = (h >> 40) as f32 / (1u64 << 24) as f32;
    let j2 = ((h >> 16) & 0xFF_FFFF) as f32 / (1u64 << 24) as f32;
    let n = (spp as f32).sqrt() as u32;
    if n * n == spp {
        let (sx, sy) = (s % n, s / n);
        ((sx as f32 + j1) / n as f32, (sy as f32 + j2) / n as f32)
    } else {
        (j1, j2)
    }
}

/// Render `world` through `camera`: the whole frame, no alpha, no progress reports, on the
/// current rayon thread pool (see [`thread_pool`]).
pub fn render(
    world: &World,
    camera: &Camera,
    settings: &RenderSettings,
) -> Result<RenderOutput, RenderError> {
    render_extent(world, camera, settings, &RenderExtent::default(), &|_| {})
}

/// Render a window of the frame (and its alpha, if asked) on the current rayon thread pool
/// (the caller's: run it inside [`rayon::ThreadPool::install`] to choose the threads; see
/// [`thread_pool`]), calling `progress` from the worker threads at most every 100 ms and once
/// at the end. Each pixel is exactly the pixel of the full-frame render, whatever the window,
/// tiling and thread count, since the samples of a pixel depend only on its position in the
/// full frame and the seed.
pub fn render_extent(
    world: &World,
    camera: &Camera,
    settings: &RenderSettings,
    extent: &RenderExtent,
    progress: &(dyn Fn(Progress) + Sync),
) -> Result<RenderOutput, RenderError> {
    // Check the request.
    let (win, frame) = tracer::check(camera, settings, extent)?;

    // Trace the tiles in parallel.
    let tiles_x = win.width().div_ceil(TILE);
    let n_tiles = tiles_x * win.height().div_ceil(TILE);
    let meter = tracer::Meter::new(win.width() as u64 * win.height() as u64 * settings.spp as u64, progress);
    let batch = (256.0 / world.rays_per_sample_bound()).clamp(1.0, 64.0) as u64;
    let tracer =
        tracer::Tracer { world, frame, settings, alpha: extent.alpha, win, tiles_x, meter: &meter, batch };
    let tiles: Vec<_> = (0..n_tiles).into_par_iter().map(|t| tracer.trace_tile(t)).collect();
    let elapsed = meter.finish();

    // Assemble the tiles in order.
    let (image, alpha, rays, clamped_samples) = tracer::assemble(&tiles, win, tiles_x, extent.alpha);
    let threads = rayon::current_num_threads();
    Ok(RenderOutput { image, alpha, window: win, rays, elapsed, threads, clamped_samples })
}

/// A thread pool to render on: `threads` workers (`None` = one per core), each running in the
/// float mode Embree asks for (flush-to-zero and denormals-are-zero) before it traces.
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool, RenderError> {
    let mut pool = embree::thread_pool_builder();
    match threads {
        Some(0) => return Err(RenderError::ZeroThreads),
        Some(t) => pool = pool.num_threads(t),
        None => {}
    }
    pool.build().map_err(RenderError::Threads)
}

/// Side by side: `left | right | difference`, each labelled (e.g. with its mode and time).
/// The difference panel shows `|left - right|` per channel, amplified 4x.
pub fn compare_panel(left: &Image, right: &Image, left_label: &str, right_label: &str) -> Image {
    let (w, h) = (left.width, left.height);
    let mut out = Image::new(3 * w, h);
    out.blit(left, 0, 0);
    out.blit(right, w, 0);
    let mut diff = Image::new(w, h);
    for y in 0..h.min(right.height) {
        for x in 0..w.min(right.width) {
            let d = (left.get(x, y) - right.get(x, y)).abs() * 4.0;
            diff.set(x, y, d.min(Vec3::ONE));
        }
    }
    out.blit(&diff, 2 * w, 0);
    let size = (h as f32 / 22.0).clamp(11.0, 40.0);
    text::draw_label(&mut out, left_label, 6, 6, size);
    text::draw_label(&mut out, right_label, w + 6, 6, size);
    text::draw_label(&mut out, "difference x4", 2 * w + 6, 6, size);
    out
}
