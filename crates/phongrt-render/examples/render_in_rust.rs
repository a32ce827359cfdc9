//! Render the demo sphere from code, with no command line and no files read: a 96-triangle UV
//! sphere traced directly as a Phong surface, on a thread pool the caller owns, with progress
//! reported through a callback, written as a PNG.
//!
//! `cargo run --release -p phongrt-render --example render_in_rust -- sphere.png`

use std::path::Path;

use phongrt::embree::Device;
use phongrt::scene::{uv_sphere, Model};
use phongrt_render::{
    render_extent, thread_pool, Camera, ObjectMode, Progress, RenderExtent, RenderOutput, RenderSettings,
    World,
};

/// Build the world, render it and write `out` (a .png or .exr path).
pub fn run(out: &Path) -> Result<RenderOutput, Box<dyn std::error::Error>> {
    // Compute the world: one low-poly sphere, every object Phong at the documented alpha.
    let device = Device::new()?;
    let scene = Model::from_mesh(uv_sphere(12, 6, 1.0));
    let mode = ObjectMode::Phong { alpha: phongrt::phong::DEFAULT_ALPHA };
    let world = World::builder(&device, &scene).mode(mode).build()?;

    // Compute the view and render on our own pool, printing the progress now and then.
    let settings = RenderSettings { width: 320, height: 240, spp: 4, ..RenderSettings::default() };
    let (lo, hi) = world.bounds();
    let camera = Camera::frame_bounds(lo, hi, settings.width as f32 / settings.height as f32);
    let pool = thread_pool(None)?;
    let progress = |p: Progress| eprintln!("{:.0}% done", 100.0 * p.fraction());
    let output =
        pool.install(|| render_extent(&world, &camera, &settings, &RenderExtent::default(), &progress))?;
    output.image.save(out)?;
    Ok(output)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "sphere.png".to_string());
    let output = run(Path::new(&out))?;
    eprintln!("wrote {out}: {}x{}, {}", output.image.width, output.image.height, output.rays);
    Ok(())
}
