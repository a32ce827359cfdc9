//! The renderer: silhouette coverage against the analytic projected area, Phong silhouettes
//! smoother than flat ones, effects that cost zero rays when not called for, determinism
//! across thread counts, scene-file errors.
mod common;

use std::path::Path;

use glam::Vec3;
use phongrt::embree::Device;
use phongrt::scene::{uv_sphere, Material, Scene};
use phongrt_render::scene_file::SceneFile;
use phongrt_render::{render, Camera, Light, ObjectMode, ObjectSettings, RenderSettings, SurfaceMode, World};

fn settings(w: u32, threads: Option<usize>) -> RenderSettings {
    RenderSettings { width: w, height: w, spp: 1, threads, progress: false, seed: 0, packets: true }
}

fn sphere_world(device: &Device, seg: u32, rings: u32, mode: ObjectMode) -> World {
    World::from_scene(device, &Scene::from_mesh(uv_sphere(seg, rings, 1.0)), |_, _| ObjectSettings::new(mode))
        .unwrap()
}

fn camera() -> Camera {
    Camera { eye: Vec3::new(0.0, 0.0, 4.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_deg: 40.0 }
}

/// Pixels covered by the sphere (not background) and, per image row, the covered half-width.
fn coverage(world: &World, w: u32) -> (usize, Vec<f32>) {
    let out = render(world, &camera(), &settings(w, Some(2))).unwrap();
    let bg = world.background;
    let mut count = 0;
    let mut widths = vec![0.0; w as usize];
    for y in 0..w {
        let mut row = 0;
        for x in 0..w {
            if out.image.get(x, y) != bg {
                row += 1;
            }
        }
        count += row;
        widths[y as usize] = row as f32 / 2.0;
    }
    (count, widths)
}

/// The projected disc of a unit sphere seen from distance 4 with a 40 degree fov, in pixels.
fn analytic_radius_px(w: u32) -> f32 {
    let half = (20f32).to_radians().tan();
    // Silhouette half-angle: asin(1/4); its tangent over the image half-extent.
    let a = (1.0f32 / 4.0).asin().tan();
    a / half * w as f32 / 2.0
}

#[test]
fn fine_sphere_silhouette_matches_the_projected_area() {
    let device = Device::new().unwrap();
    let w = 400;
    for mode in [ObjectMode::Flat, ObjectMode::Phong { alpha: 1.0 }] {
        let world = sphere_world(&device, 96, 48, mode);
        let (count, _) = coverage(&world, w);
        let r = analytic_radius_px(w);
        let want = std::f32::consts::PI * r * r;
        let rel = (count as f32 - want).abs() / want;
        assert!(rel < 0.01, "{mode:?}: {count} covered pixels vs analytic {want:.0} ({rel:.4})");
    }
}

#[test]
fn phong_silhouette_of_a_low_poly_sphere_is_rounder_than_flat() {
    let device = Device::new().unwrap();
    let w = 400;
    let deviation = |mode| {
        let (count, widths) = coverage(&sphere_world(&device, 12, 6, mode), w);
        // Roundness: per row, covered half-width against the circle of the same area.
        let r = (count as f32 / std::f32::consts::PI).sqrt();
        let (n, sum) = widths.iter().enumerate().fold((0, 0.0), |(n, s), (y, &hw)| {
            let dy = (y as f32 + 0.5) - w as f32 / 2.0;
            if dy.abs() >= r * 0.95 || hw == 0.0 {
                return (n, s);
            }
            let circle = (r * r - dy * dy).sqrt();
            (n + 1, s + (hw - circle).abs())
        });
        sum / n as f32
    };
    let flat = deviation(ObjectMode::Flat);
    let phong = deviation(ObjectMode::Phong { alpha: 1.0 });
    println!("mean silhouette deviation from a circle: flat {flat:.2} px, phong {phong:.2} px");
    // Measured: flat 2.62 px, phong 1.98 px at 400x400 (12x6 sphere). Stated factor: 1.25.
    assert!(phong * 1.25 < flat, "phong {phong} not clearly rounder than flat {flat}");
}

#[test]
fn effects_not_called_for_cost_zero_rays() {
    let device = Device::new().unwrap();
    let mut world = sphere_world(&device, 24, 12, ObjectMode::Phong { alpha: 1.0 });
    // No shadow-casting light, no reflective or transparent material, no AO.
    world.lights = vec![Light::Directional {
        direction: Vec3::new(0.3, 0.8, 0.5).normalize(),
        radiance: Vec3::ONE,
        shadows: false,
    }];
    let plan = world.effects();
    assert!(
        plan.shadow_lights.is_empty()
            && plan.reflective.is_empty()
            && plan.refractive.is_empty()
            && plan.ambient_occlusion.is_none()
    );
    assert_eq!(plan.to_string(), "effects: direct lighting");
    let out = render(&world, &camera(), &settings(64, Some(1))).unwrap();
    assert_eq!(out.rays.primary, 64 * 64);
    assert_eq!(out.rays.total(), out.rays.primary, "{}", out.rays);

    // A shadow-casting light: shadow rays, still no secondary rays.
    world.lights = vec![Light::Directional {
        direction: Vec3::new(0.3, 0.8, 0.5).normalize(),
        radiance: Vec3::ONE,
        shadows: true,
    }];
    let out = render(&world, &camera(), &settings(64, Some(1))).unwrap();
    assert!(
        out.rays.shadow > 0
            && out.rays.reflection == 0
            && out.rays.refraction == 0
            && out.rays.ambient_occlusion == 0
    );
    assert!(world.effects().to_string().contains("shadows (1 lights)"));

    // A mirror material: reflection rays appear, and only then.
    world.objects[0].surface = phongrt_render::Surface::from_material(&Material {
        illum: Some(3),
        ks: Vec3::splat(0.5),
        ..Material::default()
    });
    let out = render(&world, &camera(), &settings(64, Some(1))).unwrap();
    assert!(out.rays.reflection > 0 && out.rays.refraction == 0);
    // Glass: refraction.
    world.objects[0].surface =
        phongrt_render::Surface::from_material(&Material { dissolve: 0.2, ni: 1.5, ..Material::default() });
    let out = render(&world, &camera(), &settings(64, Some(1))).unwrap();
    // Glass refracts and, by Fresnel, reflects.
    assert!(out.rays.refraction > 0 && out.rays.reflection > 0);
    assert!(world.effects().to_string().contains("refraction (1 objects)"));
    // Area light: soft shadows.
    world.lights = vec![Light::Sphere {
        center: Vec3::new(2.0, 3.0, 2.0),
        radius: 0.5,
        intensity: Vec3::splat(10.0),
        samples: 4,
    }];
    assert!(world.effects().to_string().contains("soft shadows"));
}

#[test]
fn images_do_not_depend_on_thread_count() {
    let device = Device::new().unwrap();
    let mut world = sphere_world(&device, 12, 6, ObjectMode::Phong { alpha: 1.0 });
    world.lights.push(Light::Sphere {
        center: Vec3::new(-2.0, 3.0, 3.0),
        radius: 0.7,
        intensity: Vec3::splat(8.0),
        samples: 4,
    });
    let mut s = settings(96, Some(1));
    s.spp = 4;
    let a = render(&world, &camera(), &s).unwrap();
    s.threads = Some(2);
    let b = render(&world, &camera(), &s).unwrap();
    s.threads = Some(7);
    let c = render(&world, &camera(), &s).unwrap();
    assert_eq!(a.image, b.image);
    assert_eq!(a.image, c.image);
    assert_eq!(a.rays, c.rays);
    assert!(a.image.pixels.iter().all(|p| p.is_finite()));
}

#[test]
fn scene_file_errors_name_file_key_and_problem() {
    let p = Path::new("scenes/bad.toml");
    let cases = [
        ("[camera]\nfov = 200.0\n", "camera.fov"),
        ("[render]\nspp = 0\n", "render.spp"),
        ("[[object]]\nname = \"x\"\nalpha = 1.5\n", "object[0].alpha"),
        ("[[light]]\ntype = \"sphere\"\ncenter = [0,0,0]\nradius = -1.0\n", "light[0].radius"),
        ("[[light]]\ntype = \"laser\"\n", "laser"),
        ("[camera]\nzoom = 2\n", "zoom"),
        ("[render\nwidth = 3\n", "line 1"),
    ];
    for (text, key) in cases {
        let e = SceneFile::parse(text, p).unwrap_err().to_string();
        assert!(e.contains("scenes/bad.toml") && e.contains(key) && !e.contains('\n'), "{text:?}: {e}");
    }
    let ok = SceneFile::parse("obj = \"a.obj\"\n[[object]]\nname = \"*\"\nmode = \"flat\"\n", p).unwrap();
    assert_eq!(ok.obj_path(p).unwrap(), Path::new("scenes/a.obj"));
}

#[test]
fn scene_file_mode_takes_the_command_line_mode_names() {
    use clap::ValueEnum;
    for &m in SurfaceMode::value_variants() {
        let name = m.to_possible_value().unwrap().get_name().to_string();
        let text = format!("[[object]]\nname = \"*\"\nmode = \"{name}\"\n");
        let sf = SceneFile::parse(&text, Path::new("s.toml")).unwrap();
        assert_eq!(sf.objects[0].mode, Some(m), "mode = {name:?}");
    }
    let e = SceneFile::parse("[[object]]\nname = \"*\"\nmode = \"smooth\"\n", Path::new("s.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("s.toml") && e.contains("`flat`") && e.contains("`phong`"), "{e}");
}

/// A camera inside the closed Stanford bunny (69,666 triangles, many of them slivers) sees no
/// background: the view of issue 19 at alpha 0.75, zoomed (fov 1e-5) onto a sliver whose f32
/// misses once showed 6,760 background pixels of 65,536. Skipped when the corpus is absent.
#[test]
fn no_background_inside_the_closed_bunny_at_slivers() {
    let Some(path) = common::corpus().map(|c| c.join("stanford_bunny_69k/bunny.obj")).filter(|p| p.is_file())
    else {
        println!("skipped: ../shared/corpus/stanford_bunny_69k/bunny.obj is absent");
        return;
    };
    let input = phongrt::scene::load_obj(&path, &Default::default()).unwrap();
    let device = Device::new().unwrap();
    let world =
        World::from_scene(&device, &input, |_, _| ObjectSettings::new(ObjectMode::Phong { alpha: 0.75 }))
            .unwrap();
    let camera = Camera {
        eye: Vec3::new(0.22222222, -0.440548, 0.17223267),
        look_at: Vec3::new(-0.016917244, -0.90985197, 0.525893),
        up: Vec3::Y,
        fov_y_deg: 1e-5,
    };
    let out = render(&world, &camera, &settings(256, Some(2))).unwrap();
    let background = out.image.pixels.iter().filter(|&&p| p == world.background).count();
    assert_eq!(background, 0, "{background} background pixels of {}", out.image.pixels.len());
}
