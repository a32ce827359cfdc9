//! The renderer's 8-ray packets (camera rays from 4x2 pixel blocks, hard shadows per light):
//! the image, alpha and ray counts are exactly those of the single-ray renderer, for the demo
//! scene and for worlds that use every light kind and effect, whatever the crop and threads.
use crate::common;

use assert_cmd::Command;
use glam::Vec3;
use phongrt::embree::Device;
use phongrt::scene::{load_obj, uv_sphere, LoadOptions, Material, Model};
use phongrt_render::{
    default_lights, render_extent, AmbientOcclusion, Camera, Ground, Light, ObjectMode, RenderExtent,
    RenderOutput, RenderSettings, Surface, Window, World,
};

fn settings(w: u32, h: u32, spp: u32, packets: bool) -> RenderSettings {
    RenderSettings { width: w, height: h, spp, seed: 3, packets }
}

/// Render with packets on and off, on a pool of `threads` workers, and check they agree exactly;
/// returns the packet render.
fn same_both_ways(
    world: &World,
    camera: &Camera,
    s: &RenderSettings,
    extent: &RenderExtent,
    threads: usize,
) -> RenderOutput {
    let pool = phongrt_render::thread_pool(Some(threads)).unwrap();
    let with = |packets| {
        let s = RenderSettings { packets, ..s.clone() };
        pool.install(|| render_extent(world, camera, &s, extent, &|_| {})).unwrap()
    };
    let (on, off) = (with(true), with(false));
    let differ = on.image.pixels.iter().zip(&off.image.pixels).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "{differ} of {} pixels differ with packets", on.image.pixels.len());
    assert_eq!(on.alpha, off.alpha);
    assert_eq!(on.rays, off.rays, "ray counts differ with packets");
    assert_eq!(on.clamped_samples, off.clamped_samples);
    on
}

/// A Phong sphere on a flat ground with a shadowing directional light, a shadowing point light,
/// a light without shadows, a sphere light and ambient occlusion.
fn busy_world(device: &Device, surface: Option<Surface>) -> World {
    let scene = Model::from_mesh(uv_sphere(10, 5, 1.0));
    let lights = [
        Light::Point { position: Vec3::new(1.5, 2.5, 2.0), intensity: Vec3::splat(3.0), shadows: true },
        Light::Directional {
            direction: Vec3::new(0.8, 0.3, 0.2).normalize(),
            radiance: Vec3::splat(0.3),
            shadows: false,
        },
        Light::Sphere {
            center: Vec3::new(-2.0, 3.0, 1.0),
            radius: 0.5,
            intensity: Vec3::splat(4.0),
            samples: 2,
        },
    ];
    let world = World::builder(device, &scene)
        .mode(ObjectMode::Phong { alpha: 1.0 })
        .ground(Some(Ground::default()))
        .lights(default_lights().into_iter().chain(lights))
        .ambient_occlusion(Some(AmbientOcclusion { samples: 2, distance: 0.7 }));
    let world = match surface {
        Some(s) => world.surface("*", s),
        None => world,
    };
    world.build().unwrap()
}

fn camera() -> Camera {
    Camera { eye: Vec3::new(0.5, 1.2, 4.0), look_at: Vec3::new(0.0, -0.3, 0.0), up: Vec3::Y, fov_y_deg: 45.0 }
}

#[test]
fn packets_give_the_single_ray_image_with_every_light_kind_and_effect() {
    let device = Device::new().unwrap();
    let world = busy_world(&device, None);
    // Odd sizes: blocks at the right and bottom edges have lanes outside the frame.
    let out = same_both_ways(&world, &camera(), &settings(61, 47, 4, true), &RenderExtent::default(), 2);
    assert!(out.rays.shadow > 0 && out.rays.ambient_occlusion > 0 && out.rays.terminator > 0, "{}", out.rays);
    // A glossy mirror sphere: reflection rays, specular lobes; their shadows go one by one.
    let mirror = Material { illum: Some(3), ks: Vec3::splat(0.4), ns: 40.0, ..Material::default() };
    let world = busy_world(&device, Some(Surface::from_material(&mirror)));
    let out = same_both_ways(&world, &camera(), &settings(40, 40, 1, true), &RenderExtent::default(), 1);
    assert!(out.rays.reflection > 0 && out.rays.specular > 0, "{}", out.rays);
    // Glass: shadow rays pass through transmissive surfaces, one ray per surface.
    let glass = Material { dissolve: 0.3, ni: 1.5, ..Material::default() };
    let world = busy_world(&device, Some(Surface::from_material(&glass)));
    let out = same_both_ways(&world, &camera(), &settings(40, 40, 1, true), &RenderExtent::default(), 2);
    assert!(out.rays.refraction > 0, "{}", out.rays);
}

#[test]
fn packet_renders_of_a_crop_with_alpha_are_the_window_of_the_whole_frame() {
    let device = Device::new().unwrap();
    let world = busy_world(&device, None);
    let s = settings(61, 47, 4, true);
    let alpha = RenderExtent { crop: None, alpha: true };
    let whole = same_both_ways(&world, &camera(), &s, &alpha, 2);
    // Crop corners off the 4x2 block grid, on 1 and 3 threads.
    for (threads, (x0, y0, x1, y1)) in [(1, (10, 5, 43, 40)), (3, (3, 1, 58, 46)), (2, (0, 0, 5, 3))] {
        let crop = Window { x0, y0, x1, y1, full_width: 61, full_height: 47 };
        let part =
            same_both_ways(&world, &camera(), &s, &RenderExtent { crop: Some(crop), alpha: true }, threads);
        let (w, a) = (whole.alpha.as_ref().unwrap(), part.alpha.as_ref().unwrap());
        for y in y0..y1 {
            for x in x0..x1 {
                let (i, j) = ((y - y0) * (x1 - x0) + (x - x0), y * 61 + x);
                assert_eq!(part.image.pixels[i as usize], whole.image.pixels[j as usize], "({x}, {y})");
                assert_eq!(a[i as usize], w[j as usize], "alpha ({x}, {y})");
            }
        }
    }
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn packets_give_the_single_ray_image_on_real_meshes_flat_and_phong() {
    let corpus = common::corpus_required();
    let device = Device::new().unwrap();
    for name in ["african_head/african_head.obj", "bunny_lowres/bunny.obj"] {
        let path = corpus.join(name);
        assert!(path.exists(), "{} is absent from the corpus", path.display());
        let scene = load_obj(&path, &LoadOptions::default()).unwrap();
        for mode in [ObjectMode::Flat, ObjectMode::Phong { alpha: 0.75 }] {
            let world =
                World::builder(&device, &scene).mode(mode).ground(Some(Ground::default())).build().unwrap();
            let (lo, hi) = world.bounds();
            let camera = Camera::frame_bounds(lo, hi, 1.0);
            same_both_ways(&world, &camera, &settings(128, 128, 1, true), &RenderExtent::default(), 2);
        }
    }
}

fn phongrt() -> Command {
    Command::cargo_bin("phongrt").unwrap()
}

#[test]
fn the_demo_scene_renders_the_same_with_packets_on_and_off() {
    let dir = tempfile::tempdir().unwrap();
    let sphere = common::root().join("scenes/sphere_lowpoly.obj");
    // scripts/demo.sh's render, each panel alone (the --compare panel's labels hold the
    // render times), in linear f32 (EXR): exact bits.
    let render = |mode: &str, packets: &str| {
        let out = dir.path().join(format!("demo-{mode}-{packets}.exr"));
        phongrt()
            .arg("render")
            .arg(&sphere)
            .args(["--mode", mode, "--ground", "--width", "360", "--height", "360", "--spp", "4", "-q"])
            .args(["--packets", packets, "-o"])
            .arg(&out)
            .assert()
            .success();
        image::open(&out).unwrap().to_rgba32f().into_raw().into_iter().map(f32::to_bits).collect::<Vec<_>>()
    };
    for mode in ["flat", "phong"] {
        let (on, off) = (render(mode, "on"), render(mode, "off"));
        assert_eq!(on.len(), 360 * 360 * 4);
        let differ = on.iter().zip(&off).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "{mode}: {differ} channel values differ with packets");
    }
}

#[test]
fn a_bad_packets_value_is_refused_naming_the_flag() {
    let sphere = common::root().join("scenes/sphere_lowpoly.obj");
    let out = phongrt().arg("render").arg(&sphere).args(["--packets", "sometimes"]).assert().failure();
    let err = String::from_utf8_lossy(&out.get_output().stderr).into_owned();
    assert!(err.contains("--packets") && err.contains("sometimes"), "{err}");
}

#[test]
fn shade8_answers_each_shaded_lane_as_shade_does() {
    use phongrt::embree::{Ray, PACKET8};
    use phongrt_render::{RayCounts, Rng};
    let device = Device::new().unwrap();
    let world = busy_world(&device, None);
    let frame = camera().frame(1.0).unwrap();
    for (trace, shade) in [(0xFF, 0xFF), (0xFF, 0x5A), (0x0F, 0xFF), (0x81, 0x01), (0xFF, 0x00)] {
        for by in (0..32).step_by(2) {
            for bx in (0..32).step_by(4) {
                let rays: [Ray; PACKET8] = std::array::from_fn(|k| {
                    let (x, y) = (bx + k as u32 % 4, by + k as u32 / 4);
                    Ray::new(frame.eye, frame.direction(x as f32 + 0.5, y as f32 + 0.5, 32, 32))
                });
                let mut rngs = std::array::from_fn(|k| Rng::new(k as u64));
                let mut counts = RayCounts::default();
                let got = world.shade8(&rays, trace, shade, &mut counts, &mut rngs);
                let mut expected = RayCounts::default();
                for k in 0..PACKET8 {
                    if trace & shade & (1 << k) == 0 {
                        assert_eq!(got[k], Vec3::ZERO, "lane {k} not shaded");
                        continue;
                    }
                    let c = world.shade(rays[k], &mut expected, &mut Rng::new(k as u64));
                    assert_eq!(got[k], c, "lane {k}, trace {trace:#04x}, shade {shade:#04x}");
                }
                assert_eq!(counts, expected);
            }
        }
    }
}
