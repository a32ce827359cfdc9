//! The renderer: silhouette coverage against the analytic projected area, Phong silhouettes
//! smoother than flat ones, effects that cost zero rays when not called for, determinism
//! across thread counts, scene-file errors.
mod common;

use std::path::Path;

use glam::Vec3;
use phongrt::embree::Device;
use phongrt::scene::{uv_sphere, Material, Model};
use phongrt_render::scene_file::SceneFile;
use phongrt_render::{
    default_lights, render, render_extent, Camera, Light, ObjectMode, ObjectSettings, Progress, RenderExtent,
    RenderOutput, RenderSettings, SurfaceMode, World, WorldBuilder,
};

fn settings(w: u32) -> RenderSettings {
    RenderSettings { width: w, height: w, spp: 1, seed: 0, packets: true }
}

/// Render on a pool of `threads` workers (the caller owns the pool).
fn render_on(threads: usize, world: &World, camera: &Camera, s: &RenderSettings) -> RenderOutput {
    let pool = phongrt_render::thread_pool(Some(threads)).unwrap();
    pool.install(|| render(world, camera, s)).unwrap()
}

fn sphere_world(device: &Device, seg: u32, rings: u32, mode: ObjectMode) -> World {
    sphere_world_with(device, seg, rings, mode, |b| b)
}

/// As `sphere_world`, with `more` of the builder's settings.
fn sphere_world_with(
    device: &Device,
    seg: u32,
    rings: u32,
    mode: ObjectMode,
    more: impl for<'a> FnOnce(WorldBuilder<'a>) -> WorldBuilder<'a>,
) -> World {
    let scene = Model::from_mesh(uv_sphere(seg, rings, 1.0));
    more(World::builder(device, &scene).mode(mode)).build().unwrap()
}

fn camera() -> Camera {
    Camera { eye: Vec3::new(0.0, 0.0, 4.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_deg: 40.0 }
}

/// Pixels covered by the sphere (not background) and, per image row, the covered half-width.
fn coverage(world: &World, w: u32) -> (usize, Vec<f32>) {
    let out = render(world, &camera(), &settings(w)).unwrap();
    let bg = world.background();
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
    // No shadow-casting light, no reflective or transparent material, no AO.
    let light = |shadows| Light::Directional {
        direction: Vec3::new(0.3, 0.8, 0.5).normalize(),
        radiance: Vec3::ONE,
        shadows,
    };
    let world_with = |lights: Vec<Light>, surface: Option<Material>| {
        sphere_world_with(&device, 24, 12, ObjectMode::Phong { alpha: 1.0 }, |b| match surface {
            Some(m) => b.lights(lights).surface("*", phongrt_render::Surface::from_material(&m)),
            None => b.lights(lights),
        })
    };
    let world = world_with(vec![light(false)], None);
    let plan = world.effects();
    assert!(
        plan.shadow_lights.is_empty()
            && plan.reflective.is_empty()
            && plan.refractive.is_empty()
            && plan.ambient_occlusion.is_none()
    );
    assert_eq!(plan.to_string(), "effects: direct lighting");
    let out = render(&world, &camera(), &settings(64)).unwrap();
    assert_eq!(out.rays.primary, 64 * 64);
    assert_eq!(out.rays.total(), out.rays.primary, "{}", out.rays);

    // A shadow-casting light: shadow rays, still no secondary rays.
    let world = world_with(vec![light(true)], None);
    let out = render(&world, &camera(), &settings(64)).unwrap();
    assert!(
        out.rays.shadow > 0
            && out.rays.reflection == 0
            && out.rays.refraction == 0
            && out.rays.ambient_occlusion == 0
    );
    assert!(world.effects().to_string().contains("shadows (1 lights)"));

    // A mirror material: reflection rays appear, and only then.
    let mirror = Material { illum: Some(3), ks: Vec3::splat(0.5), ..Material::default() };
    let world = world_with(vec![light(true)], Some(mirror));
    let out = render(&world, &camera(), &settings(64)).unwrap();
    assert!(out.rays.reflection > 0 && out.rays.refraction == 0);
    // Glass: refraction.
    let world =
        world_with(vec![light(true)], Some(Material { dissolve: 0.2, ni: 1.5, ..Material::default() }));
    let out = render(&world, &camera(), &settings(64)).unwrap();
    // Glass refracts and, by Fresnel, reflects.
    assert!(out.rays.refraction > 0 && out.rays.reflection > 0);
    assert!(world.effects().to_string().contains("refraction (1 objects)"));
    // Area light: soft shadows.
    let area = Light::Sphere {
        center: Vec3::new(2.0, 3.0, 2.0),
        radius: 0.5,
        intensity: Vec3::splat(10.0),
        samples: 4,
    };
    let glass = Material { dissolve: 0.2, ni: 1.5, ..Material::default() };
    let world = world_with(vec![area], Some(glass));
    assert!(world.effects().to_string().contains("soft shadows"));
}

#[test]
fn images_do_not_depend_on_thread_count() {
    let device = Device::new().unwrap();
    let area = Light::Sphere {
        center: Vec3::new(-2.0, 3.0, 3.0),
        radius: 0.7,
        intensity: Vec3::splat(8.0),
        samples: 4,
    };
    let world = sphere_world_with(&device, 12, 6, ObjectMode::Phong { alpha: 1.0 }, |b| {
        b.lights(default_lights().into_iter().chain([area]))
    });
    let s = RenderSettings { spp: 4, ..settings(96) };
    let a = render_on(1, &world, &camera(), &s);
    let b = render_on(2, &world, &camera(), &s);
    let c = render_on(7, &world, &camera(), &s);
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

/// A reflectance above 1 would make a surface reflect more light than it receives: `kd`,
/// `mirror` and `specular` of an object and the ground's `kd` are refused above 1, as below 0,
/// with the file, the key and the value on one line; 1 itself is accepted.
#[test]
fn scene_file_reflectances_outside_0_to_1_are_one_line_errors_naming_the_key() {
    let p = Path::new("scenes/bright.toml");
    for (section, key, at) in [
        ("[[object]]\nname = \"*\"\n", "kd", "object[0].kd"),
        ("[[object]]\nname = \"*\"\n", "mirror", "object[0].mirror"),
        ("[[object]]\nname = \"*\"\n", "specular", "object[0].specular"),
        ("[ground]\n", "kd", "ground.kd"),
    ] {
        for (value, problem) in [("[0.5, 1.2, 0.5]", "above 1"), ("[0.5, -0.1, 0.5]", "negative")] {
            let text = format!("{section}{key} = {value}\n");
            let e = SceneFile::parse(&text, p).unwrap_err().to_string();
            assert!(
                e.contains("scenes/bright.toml")
                    && e.contains(at)
                    && e.contains(problem)
                    && !e.contains('\n'),
                "{text:?}: {e}"
            );
        }
        SceneFile::parse(&format!("{section}{key} = [1.0, 1.0, 0.0]\n"), p).unwrap();
    }
}

#[test]
fn scene_file_mode_takes_the_command_line_mode_names() {
    for m in SurfaceMode::ALL {
        let name = m.name();
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
/// misses once showed 6,760 background pixels of 65,536.
#[test]
#[ignore = "needs ../shared/corpus"]
fn no_background_inside_the_closed_bunny_at_slivers() {
    let path = common::corpus_required().join("stanford_bunny_69k/bunny.obj");
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
    let out = render(&world, &camera, &settings(256)).unwrap();
    let background = out.image.pixels.iter().filter(|&&p| p == world.background()).count();
    assert_eq!(background, 0, "{background} background pixels of {}", out.image.pixels.len());
}

/// Progress comes per sample pass, not per tile: a tiny image at many samples per pixel (one
/// 16x16 tile, so one tile is the whole render) reports before it is done, every report within
/// the total, the samples done never going back, and the last report is the whole render.
#[test]
fn progress_reports_samples_done_within_a_tile_and_ends_at_the_total() {
    let device = Device::new().unwrap();
    let world = sphere_world(&device, 24, 12, ObjectMode::Phong { alpha: 0.75 });
    let s = RenderSettings { spp: 4096, ..settings(16) };
    let reports = std::sync::Mutex::new(Vec::<Progress>::new());
    let out =
        render_extent(&world, &camera(), &s, &RenderExtent::default(), &|p| reports.lock().unwrap().push(p))
            .unwrap();
    let reports = reports.into_inner().unwrap();
    let total = 16 * 16 * 4096;
    let last = reports.last().expect("at least the final report");
    assert_eq!((last.done, last.total), (total, total));
    assert_eq!(last.eta(), Some(std::time::Duration::ZERO));
    assert!(reports.iter().all(|p| p.total == total && p.done <= total));
    assert!(
        reports.windows(2).all(|w| w[0].done <= w[1].done),
        "one tile, one thread: samples done only grow"
    );
    // A report comes at most every 100 ms after the first 100 ms: a render this long has some
    // before its end (each sample pass of 8 rays checks the clock).
    if out.elapsed.as_secs_f64() > 0.5 {
        let early = reports.iter().filter(|p| p.done < total).count();
        assert!(early >= 1, "{} s render, no report before the end", out.elapsed.as_secs_f64());
    }
}
