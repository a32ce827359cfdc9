//! A thin renderer on top of Embree: a world of flat or Phong objects, a camera, lights,
//! tiles rendered in parallel with rayon, deterministic whatever the thread count.

pub mod camera;
pub mod image_out;
pub mod scene_file;
pub mod smoothness;
pub mod text;
pub mod texture;
pub mod world;

use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use glam::Vec3;
use rayon::prelude::*;

pub use camera::{detect_up, Camera, CameraFrame, UpDetection, ViewSpec};
pub use image_out::{linear_to_srgb, Image};
pub use world::{
    AmbientOcclusion, Effects, Environment, EnvironmentSource, Ground, Light, ObjectMode, ObjectSettings,
    Rng, Surface, Terminator, World,
};

use crate::embree::{self, Ray};

/// What to render and how.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel (stratified on a square grid when a perfect square).
    pub spp: u32,
    /// Worker threads; `None` = all cores. The image does not depend on it.
    pub threads: Option<usize>,
    /// Show a progress bar on stderr (only when stderr is a terminal).
    pub progress: bool,
    /// Seed of the per-pixel sample pattern.
    pub seed: u64,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings { width: 640, height: 480, spp: 1, threads: None, progress: true, seed: 0 }
    }
}

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    pub primary: u64,
    pub shadow: u64,
    pub reflection: u64,
    pub refraction: u64,
    pub ambient_occlusion: u64,
    /// Short rays that check a shadow-ray origin lift is clear (see [`world::Terminator::Lift`]).
    pub terminator: u64,
    /// Highlight-lobe evaluations (not rays; glossy materials only).
    pub specular: u64,
    /// Texture lookups (not rays; textured materials only).
    pub texture: u64,
    /// Shadow rays towards the environment light (only with `[environment]`).
    pub environment: u64,
}

impl RayCounts {
    pub fn total(&self) -> u64 {
        self.primary
            + self.shadow
            + self.reflection
            + self.refraction
            + self.ambient_occlusion
            + self.terminator
            + self.environment
    }

    fn add(&mut self, o: &RayCounts) {
        self.primary += o.primary;
        self.shadow += o.shadow;
        self.reflection += o.reflection;
        self.refraction += o.refraction;
        self.ambient_occlusion += o.ambient_occlusion;
        self.terminator += o.terminator;
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
    pub image: Image,
    pub rays: RayCounts,
    pub elapsed: Duration,
}

const TILE: u32 = 16;

/// A hash of the pixel, sample and seed: the sample pattern depends on nothing else, so the
/// image is the same whatever the thread count or tile order.
fn sample_hash(x: u32, y: u32, s: u32, seed: u64) -> u64 {
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

/// Render `world` through `camera`.
pub fn render(world: &World, camera: &Camera, settings: &RenderSettings) -> anyhow::Result<RenderOutput> {
    let (w, h) = (settings.width, settings.height);
    if w == 0 || h == 0 || w > 1 << 15 || h > 1 << 15 {
        bail!("image size {w}x{h} is out of range (1..=32768 per side)");
    }
    if settings.spp == 0 || settings.spp > 1 << 16 {
        bail!("samples per pixel {} is out of range (1..=65536)", settings.spp);
    }
    let frame = camera.frame(w as f32 / h as f32).context(
        "degenerate camera: eye equals look-at, up is parallel to the view, or fov not in (0, 180)",
    )?;

    let tiles_x = w.div_ceil(TILE);
    let tiles_y = h.div_ceil(TILE);
    let n_tiles = (tiles_x * tiles_y) as u64;
    let bar = if settings.progress && std::io::stderr().is_terminal() {
        let b = indicatif::ProgressBar::new(n_tiles);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} rendering [{bar:40}] {percent}% {elapsed_precise} eta {eta}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    let done = AtomicU64::new(0);

    let mut pool = rayon::ThreadPoolBuilder::new().start_handler(|_| embree::set_flush_denormals());
    if let Some(t) = settings.threads {
        pool = pool.num_threads(t.max(1));
    }
    let pool = pool.build().context("cannot start render threads")?;

    let start = Instant::now();
    let tiles: Vec<(Vec<Vec3>, RayCounts)> = pool.install(|| {
        (0..tiles_x * tiles_y)
            .into_par_iter()
            .map(|t| {
                let (tx, ty) = (t % tiles_x, t / tiles_x);
                let mut counts = RayCounts::default();
                let x0 = tx * TILE;
                let y0 = ty * TILE;
                let mut out = Vec::with_capacity((TILE * TILE) as usize);
                for y in y0..(y0 + TILE).min(h) {
                    for x in x0..(x0 + TILE).min(w) {
                        let mut sum = Vec3::ZERO;
                        for s in 0..settings.spp {
                            let (ox, oy) = sample_offset(x, y, s, settings.spp, settings.seed);
                            let dir = frame.direction(x as f32 + ox, y as f32 + oy, w, h);
                            let mut rng = Rng::new(sample_hash(x, y, s, settings.seed ^ 0x5eed));
                            sum += world.shade(Ray::new(frame.eye, dir), &mut counts, &mut rng);
                        }
                        out.push(sum / settings.spp as f32);
                    }
                }
                let k = done.fetch_add(1, Ordering::Relaxed) + 1;
                if k % 8 == 0 || k == n_tiles {
                    bar.set_position(k);
                }
                (out, counts)
            })
            .collect()
    });
    let elapsed = start.elapsed();
    bar.finish_and_clear();

    // Assemble tiles in order.
    let mut image = Image::new(w, h);
    let mut rays = RayCounts::default();
    for (t, (px, counts)) in tiles.iter().enumerate() {
        let t = t as u32;
        let (x0, y0) = ((t % tiles_x) * TILE, (t / tiles_x) * TILE);
        let tw = (x0 + TILE).min(w) - x0;
        for (i, c) in px.iter().enumerate() {
            let i = i as u32;
            image.set(x0 + i % tw, y0 + i / tw, *c);
        }
        rays.add(counts);
    }
    Ok(RenderOutput { image, rays, elapsed })
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
    let scale = (h / 200).clamp(1, 4);
    let white = Vec3::splat(0.9);
    text::draw_text(&mut out, left_label, 6, 6, scale, white);
    text::draw_text(&mut out, right_label, w + 6, 6, scale, white);
    text::draw_text(&mut out, "difference x4", 2 * w + 6, 6, scale, white);
    out
}
