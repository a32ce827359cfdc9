//! How far Phong tessellation bulges past the flat mesh for a few shape factors: the evidence for
//! the default alpha of 3/4.
//!
//! ```sh
//! cargo run --release --example alpha_bulge -- scenes/sphere_lowpoly.obj scenes/mug/mug.obj ../shared/corpus/spider/spider.obj
//! ```
//!
//! Per model and alpha: the largest distance of the surface from the centre of the bounds over the
//! largest corner distance (on a sphere: the largest radius over the true radius), and the
//! silhouette's area (pixels covered at 400×400 from the default camera) against flat triangles'.
use std::path::Path;

use glam::Vec3;
use phongrt::embree::{Device, Ray};
use phongrt::scene::{load_obj, LoadOptions, Model};
use phongrt_render::{Camera, ObjectMode, World};

const SIZE: u32 = 400;

/// Pixels whose centre ray hits the scene, from the command line's default camera.
fn coverage(world: &World, camera: &Camera) -> usize {
    let frame = camera.frame(1.0).expect("camera");
    let mut n = 0;
    for y in 0..SIZE {
        for x in 0..SIZE {
            let d = frame.direction(x as f32 + 0.5, y as f32 + 0.5, SIZE, SIZE);
            n += world.scene().intersect1(Ray::new(frame.eye, d)).is_some() as usize;
        }
    }
    n
}

/// The largest distance of any surface point (sampled on a 64×64 grid per patch) from `center`.
fn largest_radius(world: &World, center: Vec3) -> f32 {
    let mut r: f32 = 0.0;
    for o in world.objects() {
        let Some(pm) = o.geometry.phong() else { continue };
        for prim in 0..o.indices.len() as u32 {
            for i in 0..=64 {
                for j in 0..=64 - i {
                    let (u, v) = (i as f32 / 64.0, j as f32 / 64.0);
                    if let Some((p, _)) = pm.surface_point(prim, u, v) {
                        r = r.max((p - center).length());
                    }
                }
            }
        }
    }
    r
}

fn main() -> anyhow::Result<()> {
    // On one thread of a pool that sets flush-to-zero and denormals-are-zero, as every thread
    // that traces rays.
    phongrt::embree::thread_pool_builder().num_threads(1).build()?.install(run)
}

fn run() -> anyhow::Result<()> {
    let device = Device::new()?;
    println!("| model | alpha | largest radius / corner radius | silhouette area / flat |");
    println!("|---|---|---|---|");
    for arg in std::env::args().skip(1) {
        let scene: Model = load_obj(Path::new(&arg), &LoadOptions::default())?;
        let (lo, hi) = scene.bounds();
        let center = 0.5 * (lo + hi);
        let corner_radius = scene
            .meshes
            .iter()
            .flat_map(|m| m.positions.iter())
            .map(|p| (*p - center).length())
            .fold(0.0f32, f32::max);
        let camera = Camera::frame_bounds(lo, hi, 1.0);
        let flat = World::builder(&device, &scene).mode(ObjectMode::Flat).build()?;
        let flat_px = coverage(&flat, &camera);
        let name =
            Path::new(&arg).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or(arg.clone());
        // The sphere through the corners, seen from the same camera: the silhouette a round model
        // would have (meaningful for the sphere only).
        let d = (camera.eye - center).length();
        let disc = (corner_radius / d).asin().tan() / (0.5 * camera.fov_y_deg).to_radians().tan()
            * SIZE as f32
            / 2.0;
        let disc_area = std::f32::consts::PI * disc * disc;
        println!(
            "| {name} | (round: sphere through the corners) | 1 | {:.4} |",
            disc_area as f64 / flat_px as f64
        );
        for alpha in [0.5, 0.75, 1.0] {
            let w = World::builder(&device, &scene).mode(ObjectMode::Phong { alpha }).build()?;
            let r = largest_radius(&w, center) / corner_radius;
            let px = coverage(&w, &camera);
            println!("| {name} | {alpha} | {r:.4} | {:.4} |", px as f64 / flat_px as f64);
        }
    }
    Ok(())
}
