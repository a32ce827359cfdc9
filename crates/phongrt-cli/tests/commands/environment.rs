//! `[environment]`: a constant colour or an equirectangular map as a light, sampled only when
//! asked for (counted as environment rays), and a missing or corrupt map as an error naming it.

use crate::common;

use std::sync::Arc;

use assert_cmd::Command;
use glam::Vec3;
use phongrt::embree::Device;
use phongrt::scene::{uv_sphere, Model};
use phongrt_render::texture::Texture;
use phongrt_render::{
    render, Camera, Environment, EnvironmentSource, ObjectMode, RenderSettings, Surface, World,
};

fn world(device: &Device, environment: Option<Environment>) -> World {
    let scene = Model::from_mesh(uv_sphere(48, 24, 1.0));
    World::builder(device, &scene)
        .mode(ObjectMode::Phong { alpha: 0.75 })
        .lights([])
        .ambient(Vec3::ZERO)
        .surface("*", Surface::diffuse(Vec3::splat(0.5)))
        .environment(environment)
        .build()
        .unwrap()
}

fn shot(w: &World) -> phongrt_render::RenderOutput {
    let cam = Camera { eye: Vec3::new(0.0, 0.0, 4.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_deg: 40.0 };
    let s = RenderSettings { width: 32, height: 32, spp: 1, seed: 0, packets: true };
    render(w, &cam, &s).unwrap()
}

#[test]
fn a_constant_environment_lights_a_convex_diffuse_surface_by_kd_times_its_radiance() {
    let device = Device::new().unwrap();
    let w = world(&device, None);
    let dark = shot(&w);
    assert_eq!(dark.rays.environment, 0, "no environment asked for: no environment rays");
    assert!(!w.effects().to_string().contains("environment"));
    let w = world(
        &device,
        Some(Environment { source: EnvironmentSource::Constant(Vec3::splat(0.8)), samples: 16 }),
    );
    assert!(w.effects().to_string().contains("environment light (constant, 16 samples)"), "{}", w.effects());
    let lit = shot(&w);
    assert!(lit.rays.environment > 0, "{}", lit.rays);
    // Nothing blocks a convex surface: 0.5 * 0.8 (a few samples below the true surface are lost).
    let c = lit.image.get(16, 16);
    assert!((c.x - 0.4).abs() < 0.01, "centre {c}");
    // Rays that miss see the environment.
    assert!((lit.image.get(0, 0) - Vec3::splat(0.8)).length() < 1e-6);
}

#[test]
fn an_equirectangular_map_is_bright_above_and_dark_below() {
    // 4x2: a white sky over a black ground.
    let mut texels = vec![Vec3::ONE; 4];
    texels.extend([Vec3::ZERO; 4]);
    let tex = Texture::from_linear(4, 2, texels).unwrap();
    let env =
        Environment { source: EnvironmentSource::Map { texture: Arc::new(tex), up: Vec3::Y }, samples: 4 };
    assert!((env.radiance(Vec3::Y) - Vec3::ONE).length() < 1e-6);
    assert!(env.radiance(-Vec3::Y).length() < 1e-6);
    let tex = Texture::from_linear(4, 2, [vec![Vec3::ONE; 4], vec![Vec3::ZERO; 4]].concat()).unwrap();
    let zup =
        Environment { source: EnvironmentSource::Map { texture: Arc::new(tex), up: Vec3::Z }, samples: 4 };
    assert!((zup.radiance(Vec3::Z) - Vec3::ONE).length() < 1e-6, "the map's sky follows the up axis");
}

#[test]
fn an_exr_map_loads_and_a_missing_or_corrupt_one_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("sky.exr");
    image::Rgb32FImage::from_pixel(8, 4, image::Rgb([0.5, 0.6, 0.7])).save(&good).unwrap();
    let t = Environment::load_map(&good).unwrap();
    assert_eq!((t.width, t.height), (8, 4));
    let bad = dir.path().join("broken.hdr");
    std::fs::write(&bad, b"#?RADIANCE\nnot really\n").unwrap();
    for p in [dir.path().join("missing.hdr"), bad] {
        let e = Environment::load_map(&p).unwrap_err();
        assert!(e.starts_with(&p.display().to_string()) && !e.contains('\n'), "{e}");
    }
    // The command line: an error naming the file, no image written.
    let obj = std::fs::canonicalize(common::root().join("scenes/sphere_lowpoly.obj")).unwrap();
    let toml = dir.path().join("s.toml");
    std::fs::write(
        &toml,
        format!("obj = {:?}\n[environment]\nmap = \"nope.hdr\"\n", obj.display().to_string()),
    )
    .unwrap();
    let out = dir.path().join("o.png");
    let a = Command::cargo_bin("phongrt")
        .unwrap()
        .args(["render", "-q", "-o"])
        .arg(&out)
        .arg(&toml)
        .assert()
        .failure();
    let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
    assert!(err.contains("nope.hdr") && err.contains("environment map"), "{err}");
    assert!(!out.exists());
}
