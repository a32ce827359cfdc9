//! `phongrt render`: run a resolved job (its frames, or --compare), write each image and the stats.

use std::io::{IsTerminal, Write};
use std::time::Instant;

use anyhow::{bail, Context};

use crate::cli::RenderArgs;
use crate::job::{RenderJob, Stages};
use crate::plan::{Output, RenderPlan, StatsTarget};
use phongrt::embree::Device;
use phongrt_render::image_out::{self, EncodeOptions};
use phongrt_render::{self as render, Camera, ObjectMode, RenderExtent, RenderOutput, RenderSettings, World};

pub(crate) fn render_cmd(args: RenderArgs) -> anyhow::Result<()> {
    let t_start = Instant::now();
    let job = RenderJob::resolve(&args, t_start)?;
    let device = Device::new().context("cannot start Embree")?;
    let pool = render::thread_pool(job.plan.threads)?;
    if args.compare {
        run_compare(job, &device, &pool, t_start)
    } else {
        run_frames(job, &device, &pool, t_start)
    }
}

/// Render on `pool`, drawing the renderer's progress reports as a bar on stderr when `show`
/// and stderr is a terminal.
fn render_with_bar(
    pool: &rayon::ThreadPool,
    show: bool,
    world: &World,
    camera: &Camera,
    settings: &RenderSettings,
    extent: &RenderExtent,
) -> Result<RenderOutput, render::RenderError> {
    let bar = if show && std::io::stderr().is_terminal() {
        let b = indicatif::ProgressBar::new(1);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} rendering [{bar:40}] {percent}% {elapsed_precise} {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b.enable_steady_tick(std::time::Duration::from_millis(200));
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    let report = |p: render::Progress| {
        bar.set_length(p.total);
        bar.set_position(p.done);
        if let Some(eta) = p.eta() {
            bar.set_message(format!("eta {:#}", indicatif::HumanDuration(eta)));
        }
    };
    let out = pool.install(|| render::render_extent(world, camera, settings, extent, &report));
    bar.finish_and_clear();
    out
}

/// How long the pilot before a render may take.
const PILOT_BUDGET: std::time::Duration = std::time::Duration::from_millis(250);

/// Estimate the render of `worlds` (one after the other, `frames` times) on `pool`'s threads
/// by a short pilot each ([`render::estimate`]), and warn before it starts when it should take
/// longer than [`crate::progress::LONG_RENDER`]. The frames of an orbit cost alike, so the first
/// frame's camera stands for all.
fn warn_if_long(
    pool: &rayon::ThreadPool,
    what: &str,
    worlds: &[&World],
    frames: u32,
    camera: &Camera,
    settings: &RenderSettings,
    extent: &RenderExtent,
) -> anyhow::Result<()> {
    let threads = pool.current_num_threads();
    let mut estimates = Vec::new();
    for w in worlds {
        estimates.push(pool.install(|| render::estimate(w, camera, settings, extent, PILOT_BUDGET))?);
    }
    let time: std::time::Duration =
        estimates.iter().map(|e| e.time(threads)).sum::<std::time::Duration>() * frames;
    if let Some(w) = crate::progress::long_render_warning(what, time, &estimates, threads) {
        eprintln!("phongrt: warning: {w}");
    }
    Ok(())
}

/// `--compare`: flat everywhere on the left; on the right each object as a plain render makes
/// it (the scene file's and --object's per-object mode and alpha); their difference.
pub(crate) fn run_compare(
    mut job: RenderJob,
    device: &Device,
    pool: &rayon::ThreadPool,
    t_start: Instant,
) -> anyhow::Result<()> {
    let t = Instant::now();
    let flat = job.world(device, Some(ObjectMode::Flat))?;
    let phong = job.world(device, None)?;
    job.stages.build = t.elapsed().as_secs_f64();
    let quiet = job.quiet;
    if !quiet {
        eprintln!("phongrt: {}", phong.effects());
    }
    let whole = RenderExtent::default();
    let what = format!("{} (flat, then Phong)", job.plan.output.name());
    warn_if_long(pool, &what, &[&flat, &phong], 1, &job.camera, &job.settings, &whole)?;
    let a = render_with_bar(pool, job.progress, &flat, &job.camera, &job.settings, &whole)?;
    report(quiet, "flat", &a);
    let b = render_with_bar(pool, job.progress, &phong, &job.camera, &job.settings, &whole)?;
    report(quiet, "phong", &b);
    let ms = |o: &RenderOutput| o.elapsed.as_secs_f64() * 1e3;
    let img = render::compare_panel(
        &a.image,
        &b.image,
        &format!("flat {:.1} ms", ms(&a)),
        &format!("phong {:.1} ms ({:.2}x)", ms(&b), ms(&b) / ms(&a).max(1e-9)),
    );
    let plan = &job.plan;
    let t = Instant::now();
    let bytes = image_out::encode(&img, plan.format, &EncodeOptions::default())?;
    write_output(&plan.output, &bytes)?;
    let write = t.elapsed().as_secs_f64();
    if !quiet {
        eprintln!("phongrt: wrote {} (flat | phong | difference)", plan.output.name());
    }
    let frames =
        [frame_stats(plan, None, &plan.output, &a, write), frame_stats(plan, None, &plan.output, &b, 0.0)];
    write_stats(plan, &job.stages, &phong, &frames, t_start)
}

/// Every frame of the plan (one without --frames), each written as soon as it is rendered.
pub(crate) fn run_frames(
    mut job: RenderJob,
    device: &Device,
    pool: &rayon::ThreadPool,
    t_start: Instant,
) -> anyhow::Result<()> {
    let t = Instant::now();
    let world = job.world(device, None)?;
    job.stages.build = t.elapsed().as_secs_f64();
    // --quiet: warnings and errors only.
    let quiet = job.quiet;
    if !quiet {
        eprintln!("phongrt: {}", world.effects());
    }
    let plan = &job.plan;
    let extent = RenderExtent { crop: plan.crop, alpha: plan.alpha };
    let mut frames = Vec::new();
    let count = plan.outputs().len() as u32;
    let what =
        if count > 1 { format!("{} ({count} frames)", plan.output.name()) } else { plan.output.name() };
    warn_if_long(pool, &what, &[&world], count, &job.camera, &job.settings, &extent)?;
    for (k, output) in plan.outputs() {
        // Compute the frame's camera: an orbit of the eye about the look-at point.
        let camera = match (k, plan.frames) {
            (Some(k), Some(f)) => job.camera.orbit(f.orbit_deg * k as f32 / f.count as f32),
            _ => job.camera,
        };
        if let Some(p) = camera.problem() {
            bail!("camera of frame {}: {p} (the orbit of --frames)", k.unwrap_or(0));
        }
        // Record what the tile is of (its files read before the render), then render, encode and
        // write it.
        let record = plan.crop.map(|_| job.record(k).to_text());
        let out = render_with_bar(pool, job.progress, &world, &camera, &job.settings, &extent)?;
        let t = Instant::now();
        let window = out.window;
        let opts = EncodeOptions {
            alpha: out.alpha.as_deref(),
            window: (!window.is_full()).then_some(window),
            // Every tile or crop records its render, even one that is the whole frame (--tile 0/1).
            render: record.as_deref(),
        };
        let bytes = image_out::encode(&out.image, plan.format, &opts)?;
        write_output(&output, &bytes)?;
        let write = t.elapsed().as_secs_f64();
        if out.clamped_samples > 0 {
            eprintln!(
                "phongrt: warning: {}: {} samples had radiance that is not a finite f32 number (a light too \
                 bright?): NaN made 0, the rest clamped to {:e}",
                output.name(),
                out.clamped_samples,
                render::MAX_SAMPLE_RADIANCE
            );
        }
        report(quiet, &output.name(), &out);
        frames.push(frame_stats(plan, k, &output, &out, write));
    }
    write_stats(plan, &job.stages, &world, &frames, t_start)
}

/// Write the encoded image: a file replaced only by a complete one, or stdout, every write checked.
pub(crate) fn write_output(output: &Output, bytes: &[u8]) -> anyhow::Result<()> {
    match output {
        Output::File(p) => Ok(image_out::write_atomically(p, bytes)?),
        Output::Stdout => Ok(image_out::write_stdout(bytes)?),
    }
}

pub(crate) fn frame_stats(
    plan: &RenderPlan,
    k: Option<u32>,
    output: &Output,
    out: &RenderOutput,
    write_s: f64,
) -> serde_json::Value {
    let r = &out.rays;
    let secs = out.elapsed.as_secs_f64();
    let w = out.window;
    serde_json::json!({
        "frame": k,
        "output": output.name(),
        "window": [w.x0, w.y0, w.x1, w.y1],
        "width": out.image.width,
        "height": out.image.height,
        "threads": out.threads,
        "rays": {
            "primary": r.primary, "shadow": r.shadow, "reflection": r.reflection,
            "refraction": r.refraction, "ambient_occlusion": r.ambient_occlusion,
            "coverage": r.coverage, "total": r.total(),
        },
        "mrays_per_s": r.total() as f64 / secs.max(1e-9) / 1e6,
        "seconds": { "render": secs, "write": write_s },
        "clamped_samples": out.clamped_samples,
        "format": format!("{:?}", plan.format).to_lowercase(),
    })
}

pub(crate) fn write_stats(
    plan: &RenderPlan,
    stages: &Stages,
    world: &World,
    frames: &[serde_json::Value],
    t_start: Instant,
) -> anyhow::Result<()> {
    let Some(target) = &plan.stats else {
        return Ok(());
    };
    let e = world.effects();
    let doc = serde_json::json!({
        "full_width": plan.width,
        "full_height": plan.height,
        "spp": plan.spp,
        "seed": plan.seed,
        "effects": {
            "summary": e.to_string(),
            "shadow_lights": e.shadow_lights,
            "soft_shadow_lights": e.soft_shadow_lights,
            "reflective": e.reflective,
            "refractive": e.refractive,
            "ambient_occlusion": e.ambient_occlusion.map(|a| serde_json::json!({"samples": a.samples, "distance": a.distance})),
            "max_depth": e.max_depth,
        },
        "seconds": { "load": stages.load, "build": stages.build, "total": t_start.elapsed().as_secs_f64() },
        "frames": frames,
    });
    let text = serde_json::to_string_pretty(&doc)? + "\n";
    match target {
        StatsTarget::Print if plan.output == Output::Stdout => eprint!("{text}"),
        StatsTarget::Print => {
            let mut out = std::io::stdout().lock();
            out.write_all(text.as_bytes())
                .and_then(|_| out.flush())
                .context("--stats json: cannot write to stdout")?;
        }
        StatsTarget::File(p) => image_out::write_atomically(p, text.as_bytes())?,
    }
    Ok(())
}

pub(crate) fn report(quiet: bool, what: &str, out: &RenderOutput) {
    if quiet {
        return;
    }
    let secs = out.elapsed.as_secs_f64();
    eprintln!(
        "phongrt: {what}: {}x{} in {:.3} s: {}, {:.2} Mrays/s",
        out.image.width,
        out.image.height,
        secs,
        out.rays,
        out.rays.total() as f64 / secs.max(1e-9) / 1e6
    );
}
