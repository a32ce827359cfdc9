//! The stages of a render: check the request, trace each 16x16 tile (packets or single rays),
//! assemble the tiles in order; and the progress meter the tiles report to.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use glam::Vec3;

use crate::camera::CameraFrame;
use crate::{
    sample_hash, sample_offset, Camera, Image, RayCounts, RenderError, RenderExtent, RenderSettings, Rng,
    Window, World, MAX_SAMPLE_RADIANCE,
};
use phongrt::embree::{Ray, PACKET8};

/// The side of a square tile, in pixels.
pub(crate) const TILE: u32 = 16;

/// How far a render has got: pixel samples traced of the total, and the time since it started.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Pixel samples traced so far.
    pub done: u64,
    /// Pixel samples of the whole render (window pixels x samples per pixel).
    pub total: u64,
    /// Time since tracing started.
    pub elapsed: Duration,
}

impl Progress {
    /// The fraction done, in [0, 1].
    pub fn fraction(&self) -> f64 {
        if self.total == 0 {
            1.0
        } else {
            self.done as f64 / self.total as f64
        }
    }

    /// The time left at the rate so far (samples done per second), or `None` before any sample
    /// is done.
    pub fn eta(&self) -> Option<Duration> {
        if self.done == 0 {
            return None;
        }
        let left = self.total.saturating_sub(self.done) as f64;
        Some(self.elapsed.mul_f64(left / self.done as f64))
    }
}

/// The least time between two progress reports.
const REPORT_EVERY: Duration = Duration::from_millis(100);

/// Counts the samples the tiles trace and calls the caller's progress callback at most every
/// [`REPORT_EVERY`] (from whichever worker thread notices), so that even one slow tile reports.
pub(crate) struct Meter<'a> {
    total: u64,
    done: AtomicU64,
    start: Instant,
    /// Milliseconds since `start` of the last report.
    last_ms: AtomicU64,
    report: &'a (dyn Fn(Progress) + Sync),
}

impl<'a> Meter<'a> {
    pub(crate) fn new(total: u64, report: &'a (dyn Fn(Progress) + Sync)) -> Self {
        Meter { total, done: AtomicU64::new(0), start: Instant::now(), last_ms: AtomicU64::new(0), report }
    }

    /// `n` more samples traced.
    fn add(&self, n: u64) {
        let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
        let elapsed = self.start.elapsed();
        let ms = elapsed.as_millis() as u64;
        let last = self.last_ms.load(Ordering::Relaxed);
        if ms >= last + REPORT_EVERY.as_millis() as u64
            && self.last_ms.compare_exchange(last, ms, Ordering::Relaxed, Ordering::Relaxed).is_ok()
        {
            (self.report)(Progress { done, total: self.total, elapsed });
        }
    }

    /// The last report: everything done.
    pub(crate) fn finish(&self) -> Duration {
        let elapsed = self.start.elapsed();
        (self.report)(Progress { done: self.done.load(Ordering::Relaxed), total: self.total, elapsed });
        elapsed
    }
}

/// Check the request: the frame size, the window inside it, the samples, the camera. Returns
/// the window and the camera's frame.
pub(crate) fn check(
    camera: &Camera,
    settings: &RenderSettings,
    extent: &RenderExtent,
) -> Result<(Window, CameraFrame), RenderError> {
    let (fw, fh) = (settings.width, settings.height);
    if fw == 0 || fh == 0 || fw > 1 << 15 || fh > 1 << 15 {
        return Err(RenderError::ImageSize { width: fw, height: fh });
    }
    let win = extent.crop.unwrap_or(Window::full(fw, fh));
    if win.full_width != fw
        || win.full_height != fh
        || win.x0 >= win.x1
        || win.y0 >= win.y1
        || win.x1 > fw
        || win.y1 > fh
    {
        return Err(RenderError::Crop { window: win.to_text(), width: fw, height: fh });
    }
    if settings.spp == 0 || settings.spp > 1 << 16 {
        return Err(RenderError::Samples(settings.spp));
    }
    let frame = camera.frame(fw as f32 / fh as f32).ok_or(RenderError::Camera)?;
    Ok((win, frame))
}

/// One 16x16 tile's pixels, alpha and counts.
pub(crate) struct TileResult {
    pixels: Vec<Vec3>,
    alpha: Vec<f32>,
    counts: RayCounts,
    clamped: u64,
}

/// What every tile of one render shares.
pub(crate) struct Tracer<'a> {
    pub(crate) world: &'a World,
    pub(crate) frame: CameraFrame,
    pub(crate) settings: &'a RenderSettings,
    pub(crate) alpha: bool,
    pub(crate) win: Window,
    pub(crate) tiles_x: u32,
    pub(crate) meter: &'a Meter<'a>,
    /// Single-ray samples between two reports to the meter (fewer when a sample costs many
    /// rays, so that the progress moves at least about once a second).
    pub(crate) batch: u64,
}

/// A tile being traced: its corner and size in frame coordinates, and what it gathers.
struct TileWork {
    fx0: u32,
    fy0: u32,
    tw: u32,
    th: u32,
    out: Vec<Vec3>,
    alpha: Vec<f32>,
    counts: RayCounts,
    clamped: u64,
}

impl TileWork {
    /// A sample's radiance, made finite and at most [`MAX_SAMPLE_RADIANCE`] (and counted if it
    /// was not).
    fn clamp(&mut self, c: Vec3) -> Vec3 {
        if c.is_finite() && c.max_element() <= MAX_SAMPLE_RADIANCE {
            c
        } else {
            self.clamped += 1;
            let c = Vec3::select(c.cmpeq(c), c, Vec3::ZERO); // NaN -> 0
            c.min(Vec3::splat(MAX_SAMPLE_RADIANCE))
        }
    }

    /// Whether frame pixel (x, y) is in the tile.
    fn contains(&self, x: u32, y: u32) -> bool {
        (self.fx0..self.fx0 + self.tw).contains(&x) && (self.fy0..self.fy0 + self.th).contains(&y)
    }

    /// The index in the tile of frame pixel (x, y).
    fn index(&self, x: u32, y: u32) -> usize {
        ((y - self.fy0) * self.tw + (x - self.fx0)) as usize
    }
}

impl Tracer<'_> {
    /// Trace tile `t` (row-major over the window's tiles).
    pub(crate) fn trace_tile(&self, t: u32) -> TileResult {
        let (w, h) = (self.win.width(), self.win.height());
        // Tile corners in window coordinates; pixels are addressed in the full frame.
        let (x0, y0) = ((t % self.tiles_x) * TILE, (t / self.tiles_x) * TILE);
        let (tw, th) = ((x0 + TILE).min(w) - x0, (y0 + TILE).min(h) - y0);
        let n = (tw * th) as usize;
        let mut work = TileWork {
            fx0: self.win.x0 + x0,
            fy0: self.win.y0 + y0,
            tw,
            th,
            out: vec![Vec3::ZERO; n],
            alpha: if self.alpha { vec![0.0; n] } else { Vec::new() },
            counts: RayCounts::default(),
            clamped: 0,
        };
        if self.settings.packets {
            self.trace_packets(&mut work);
        } else {
            self.trace_single(&mut work);
        }
        TileResult { pixels: work.out, alpha: work.alpha, counts: work.counts, clamped: work.clamped }
    }

    fn camera_ray(&self, x: u32, y: u32, s: u32) -> Ray {
        let (fw, fh) = (self.settings.width, self.settings.height);
        let (ox, oy) = sample_offset(x, y, s, self.settings.spp, self.settings.seed);
        Ray::new(self.frame.eye, self.frame.direction(x as f32 + ox, y as f32 + oy, fw, fh))
    }

    fn sample_rng(&self, x: u32, y: u32, s: u32) -> Rng {
        Rng::new(sample_hash(x, y, s, self.settings.seed ^ 0x5eed))
    }

    /// Packets of 4x2 pixels on a grid fixed to the frame: a block traces every lane inside the
    /// frame whatever the tile or crop, and keeps the lanes in the tile, so its packets are the
    /// same in every tiling.
    fn trace_packets(&self, work: &mut TileWork) {
        let (fw, fh) = (self.settings.width, self.settings.height);
        let (fx0, fy0) = (work.fx0, work.fy0);
        let (fx1, fy1) = (fx0 + work.tw, fy0 + work.th);
        for by in (fy0 - fy0 % 2..fy1).step_by(2) {
            for bx in (fx0 - fx0 % 4..fx1).step_by(4) {
                let lane = |k: usize| (bx + k as u32 % 4, by + k as u32 / 4);
                let (mut trace, mut inside) = (0u8, 0u8);
                for k in 0..PACKET8 {
                    let (x, y) = lane(k);
                    if x < fw && y < fh {
                        trace |= 1 << k;
                        if work.contains(x, y) {
                            inside |= 1 << k;
                        }
                    }
                }
                let mut sums = [Vec3::ZERO; PACKET8];
                let mut hits = [0u32; PACKET8];
                for s in 0..self.settings.spp {
                    let rays = std::array::from_fn(|k| {
                        let (x, y) = lane(k);
                        self.camera_ray(x, y, s)
                    });
                    let mut shade = inside;
                    if self.alpha {
                        let cover = self.world.scene().intersect8_rays(&rays, trace, true);
                        for (k, c) in cover.iter().enumerate().filter(|(k, _)| inside & (1 << k) != 0) {
                            work.counts.coverage += 1;
                            match c {
                                Some(_) => hits[k] += 1,
                                None => shade &= !(1 << k),
                            }
                        }
                    }
                    let mut rngs = std::array::from_fn(|k| {
                        let (x, y) = lane(k);
                        self.sample_rng(x, y, s)
                    });
                    let c = self.world.shade8(&rays, trace, shade, &mut work.counts, &mut rngs);
                    for k in (0..PACKET8).filter(|k| shade & (1 << k) != 0) {
                        sums[k] += work.clamp(c[k]);
                    }
                    self.meter.add(inside.count_ones() as u64);
                }
                let spp = self.settings.spp as f32;
                for k in (0..PACKET8).filter(|k| inside & (1 << k) != 0) {
                    let (x, y) = lane(k);
                    let i = work.index(x, y);
                    work.out[i] = sums[k] / spp;
                    if self.alpha {
                        work.alpha[i] = hits[k] as f32 / spp;
                    }
                }
            }
        }
    }

    /// Every ray alone.
    fn trace_single(&self, work: &mut TileWork) {
        // Samples counted but not yet reported to the meter (reported every `batch`, and per pixel).
        let mut pending = 0u64;
        for y in work.fy0..work.fy0 + work.th {
            for x in work.fx0..work.fx0 + work.tw {
                let mut sum = Vec3::ZERO;
                let mut hits = 0u32;
                for s in 0..self.settings.spp {
                    pending += 1;
                    if pending >= self.batch {
                        self.meter.add(std::mem::take(&mut pending));
                    }
                    if let Some(c) = self.trace_sample(x, y, s, &mut work.counts) {
                        hits += 1;
                        sum += work.clamp(c);
                    }
                }
                let i = work.index(x, y);
                let spp = self.settings.spp as f32;
                work.out[i] = sum / spp;
                if self.alpha {
                    work.alpha[i] = hits as f32 / spp;
                }
            }
            self.meter.add(std::mem::take(&mut pending));
        }
    }

    /// Sample `s` of frame pixel (x, y) as a single ray: its radiance, or `None` when an alpha
    /// channel is asked for and the ray meets nothing.
    pub(crate) fn trace_sample(&self, x: u32, y: u32, s: u32, counts: &mut RayCounts) -> Option<Vec3> {
        let ray = self.camera_ray(x, y, s);
        if self.alpha {
            counts.coverage += 1;
            self.world.scene().intersect1(ray)?;
        }
        let mut rng = self.sample_rng(x, y, s);
        Some(self.world.shade(ray, counts, &mut rng))
    }
}

/// The window's image from its tiles (row-major, as traced), the alpha if asked for, the ray
/// counts and the clamped samples summed.
pub(crate) fn assemble(
    tiles: &[TileResult],
    win: Window,
    tiles_x: u32,
    alpha: bool,
) -> (Image, Option<Vec<f32>>, RayCounts, u64) {
    let (w, h) = (win.width(), win.height());
    let mut image = Image::new(w, h);
    let mut alpha = alpha.then(|| vec![0f32; w as usize * h as usize]);
    let mut rays = RayCounts::default();
    let mut clamped_samples = 0;
    for (t, tile) in tiles.iter().enumerate() {
        let t = t as u32;
        let (x0, y0) = ((t % tiles_x) * TILE, (t / tiles_x) * TILE);
        let tw = (x0 + TILE).min(w) - x0;
        for (i, c) in tile.pixels.iter().enumerate() {
            let i = i as u32;
            let (x, y) = (x0 + i % tw, y0 + i / tw);
            image.set(x, y, *c);
            if let Some(a) = alpha.as_mut() {
                a[y as usize * w as usize + x as usize] = tile.alpha[i as usize];
            }
        }
        rays.add(&tile.counts);
        clamped_samples += tile.clamped;
    }
    (image, alpha, rays, clamped_samples)
}
