//! What a render will cost, before it runs: the samples it traces, the rays each sample costs by
//! the effects plan (an upper bound), and the time it should take at the ray rate measured on
//! this machine by a short pilot over pixels spread across the window.

use std::time::{Duration, Instant};

use crate::tracer::{self, Tracer};
use crate::{Camera, RayCounts, RenderError, RenderExtent, RenderSettings, World};

/// The most pilot samples: enough to spread over the window, few enough to cost nothing on an
/// ordinary scene (a millisecond or two).
pub const PILOT_SAMPLES: u32 = 256;

/// What [`estimate`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CostEstimate {
    /// Pixel samples the render traces (window pixels x samples per pixel).
    pub samples: u64,
    /// Rays a sample costs at most by the effects plan ([`World::rays_per_sample_bound`]).
    pub planned_rays_per_sample: f64,
    /// Pilot samples traced.
    pub pilot_samples: u32,
    /// Rays the pilot traced, all kinds.
    pub pilot_rays: u64,
    /// The pilot's time, on one thread.
    pub pilot_time: Duration,
}

impl CostEstimate {
    /// Rays a sample cost in the pilot.
    pub fn rays_per_sample(&self) -> f64 {
        self.pilot_rays as f64 / self.pilot_samples.max(1) as f64
    }

    /// The rays of the whole render at the pilot's rays per sample.
    pub fn rays(&self) -> f64 {
        self.samples as f64 * self.rays_per_sample()
    }

    /// The pilot's rate on one thread, rays per second.
    pub fn rays_per_second(&self) -> f64 {
        self.pilot_rays as f64 / self.pilot_time.as_secs_f64().max(1e-9)
    }

    /// The render's time on `threads` threads at the pilot's time per sample (single rays,
    /// perfect scaling: packets and hyper-threads make it somewhat shorter, idle cores no longer).
    pub fn time(&self, threads: usize) -> Duration {
        let per_sample = self.pilot_time.as_secs_f64() / self.pilot_samples.max(1) as f64;
        let secs = self.samples as f64 * per_sample / threads.max(1) as f64;
        Duration::try_from_secs_f64(secs).unwrap_or(Duration::MAX)
    }
}

/// Estimate the cost of `render_extent(world, camera, settings, extent, ..)`: trace up to
/// [`PILOT_SAMPLES`] samples (or as many as `budget` allows, at least one) at pixels spread over
/// the window by the R2 sequence, on the calling thread (run it inside the render's pool, so
/// the pilot traces in the pool's float mode). The render itself is not changed: the pilot's
/// samples are thrown away.
pub fn estimate(
    world: &World,
    camera: &Camera,
    settings: &RenderSettings,
    extent: &RenderExtent,
    budget: Duration,
) -> Result<CostEstimate, RenderError> {
    // Check the request as the render will.
    let (win, frame) = tracer::check(camera, settings, extent)?;
    let samples = win.width() as u64 * win.height() as u64 * settings.spp as u64;

    // Trace the pilot: pixel i of the R2 sequence, sample i mod spp.
    let meter = tracer::Meter::new(0, &|_| {});
    let t = Tracer { world, frame, settings, alpha: extent.alpha, win, tiles_x: 1, meter: &meter, batch: 1 };
    let (a1, a2) = (0.754_877_7_f64, 0.569_840_3_f64);
    let mut counts = RayCounts::default();
    let start = Instant::now();
    let mut n = 0;
    while n < PILOT_SAMPLES && (n == 0 || start.elapsed() < budget) {
        let fx = (0.5 + a1 * n as f64).fract();
        let fy = (0.5 + a2 * n as f64).fract();
        let x = win.x0 + ((fx * win.width() as f64) as u32).min(win.width() - 1);
        let y = win.y0 + ((fy * win.height() as f64) as u32).min(win.height() - 1);
        t.trace_sample(x, y, n % settings.spp, &mut counts);
        n += 1;
    }
    Ok(CostEstimate {
        samples,
        planned_rays_per_sample: world.rays_per_sample_bound(),
        pilot_samples: n,
        pilot_rays: counts.total(),
        pilot_time: start.elapsed(),
    })
}

impl std::fmt::Display for CostEstimate {
    /// "2.1e11 rays (4.1e6 samples, 51200 rays a sample), about 7.3 h at 4.1 Mrays/s a thread"
    /// — the time is for one thread; see [`CostEstimate::time`] for more.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:.2e} rays ({} samples x {:.0} rays a sample; the effects plan allows up to {:.0}), \
             at {:.2} Mrays/s a thread measured over {} pilot samples",
            self.rays(),
            self.samples,
            self.rays_per_sample(),
            self.planned_rays_per_sample,
            self.rays_per_second() / 1e6,
            self.pilot_samples
        )
    }
}

/// A duration for people: "42 s", "12.5 min", "7.3 h", "3.1 days".
pub fn human_duration(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s < 90.0 {
        format!("{s:.0} s")
    } else if s < 5400.0 {
        format!("{:.1} min", s / 60.0)
    } else if s < 172_800.0 {
        format!("{:.1} h", s / 3600.0)
    } else {
        format!("{:.1} days", s / 86_400.0)
    }
}
