//! `map_Kd` textures: sRGB decode, bilinear filtering and repeat wrap; the OBJ's `vt` carried per
//! corner; backslash paths; a missing or undecodable texture and bad `vt` lines as one-line
//! warnings with the flat colour; texture lookups only for textured objects.

mod common;

use std::path::Path;

use glam::{Vec2, Vec3};
use phongrt::embree::Device;
use phongrt::scene::{load_obj, LoadOptions};
use phongrt_render::texture::{srgb_to_linear, Texture};
use phongrt_render::{render, Camera, Light, ObjectMode, ObjectSettings, RenderSettings, World};

#[test]
fn bilinear_lookup_wraps_and_hits_texel_centres() {
    // 2x1: red, green. Texel centres at u = 0.25 and 0.75.
    let t = Texture::from_linear(2, 1, vec![Vec3::X, Vec3::Y]).unwrap();
    assert!((t.sample(Vec2::new(0.25, 0.5)) - Vec3::X).length() < 1e-6);
    assert!((t.sample(Vec2::new(0.75, 0.5)) - Vec3::Y).length() < 1e-6);
    assert!((t.sample(Vec2::new(0.5, 0.5)) - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6);
    // Repeat: u = 1.25 and -0.75 are u = 0.25; u = 0 is halfway between the last and first texel.
    assert!((t.sample(Vec2::new(1.25, 0.5)) - Vec3::X).length() < 1e-6);
    assert!((t.sample(Vec2::new(-0.75, 0.5)) - Vec3::X).length() < 1e-6);
    assert!((t.sample(Vec2::new(0.0, 0.5)) - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6);
    assert!(t.sample(Vec2::new(f32::NAN, 0.5)).is_finite());
    assert!(Texture::from_linear(2, 2, vec![Vec3::ZERO]).is_none());
}

#[test]
fn srgb_decode_is_the_standard_curve() {
    assert_eq!(srgb_to_linear(0.0), 0.0);
    assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
    assert!((srgb_to_linear(128.0 / 255.0) - 0.2158).abs() < 1e-3);
}

/// A unit quad facing +z with vt (0,0)..(1,1) and a material `map_Kd .\tex.png` (backslash).
fn write_quad(dir: &Path, texture: Option<&[u8]>, vt_extra: &str) -> std::path::PathBuf {
    let obj = dir.join("quad.obj");
    std::fs::write(
        &obj,
        format!(
            "mtllib quad.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n{vt_extra}\
             usemtl m\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"
        ),
    )
    .unwrap();
    std::fs::write(dir.join("quad.mtl"), "newmtl m\nKd 1 1 1\nmap_Kd .\\tex.png\n").unwrap();
    if let Some(bytes) = texture {
        std::fs::write(dir.join("tex.png"), bytes).unwrap();
    }
    obj
}

/// A 2x2 PNG: left column sRGB 255 red, right column sRGB 128 grey.
fn png_2x2() -> Vec<u8> {
    let mut img = image::RgbImage::new(2, 2);
    for y in 0..2 {
        img.put_pixel(0, y, image::Rgb([255, 0, 0]));
        img.put_pixel(1, y, image::Rgb([128, 128, 128]));
    }
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

fn render_quad(obj: &Path) -> (phongrt_render::RenderOutput, World) {
    let scene = load_obj(obj, &LoadOptions::default()).unwrap();
    let device = Device::new().unwrap();
    let world = World::builder(&device, &scene)
        .mode(ObjectMode::Phong { alpha: 0.75 })
        .ambient(Vec3::ZERO)
        .lights([Light::Directional { direction: Vec3::Z, radiance: Vec3::ONE, shadows: false }])
        .build()
        .unwrap();
    let cam = Camera { eye: Vec3::new(0.0, 0.0, 3.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_deg: 30.0 };
    let s = RenderSettings { width: 32, height: 32, spp: 1, seed: 0, packets: true };
    (render(&world, &cam, &s).unwrap(), world)
}

#[test]
fn a_textured_quad_shows_the_texture_through_a_backslash_path() {
    let dir = tempfile::tempdir().unwrap();
    let obj = write_quad(dir.path(), Some(&png_2x2()), "");
    let (out, world) = render_quad(&obj);
    assert!(world.warnings().is_empty(), "{:?}", world.warnings());
    assert!(world.effects().to_string().contains("textures (1 objects)"));
    assert!(out.rays.texture > 0, "{}", out.rays);
    // At the texel centres (u = 0.25 at pixel 6, u = 0.75 at pixel 25, within 0.0125): red, and
    // sRGB 128 decoded to linear 0.216 grey.
    let (l, r) = (out.image.get(6, 16), out.image.get(25, 16));
    assert!(l.x > 0.95 && l.y < 0.01, "left {l}");
    assert!((r.y - 0.216).abs() < 0.01 && (r.x - 0.216).abs() < 0.03 && r.y == r.z, "right {r}");
}

#[test]
fn a_missing_or_undecodable_texture_warns_and_renders_the_flat_colour() {
    let dir = tempfile::tempdir().unwrap();
    let obj = write_quad(dir.path(), None, "");
    let scene = load_obj(&obj, &LoadOptions::default()).unwrap();
    assert!(
        scene.warnings.iter().any(|w| w.contains("tex.png not found") && !w.contains('\n')),
        "{:?}",
        scene.warnings
    );
    let (out, _) = render_quad(&obj);
    assert_eq!(out.rays.texture, 0);
    assert!((out.image.get(16, 16) - Vec3::ONE).length() < 1e-3, "flat Kd 1 expected");

    let dir = tempfile::tempdir().unwrap();
    let obj = write_quad(dir.path(), Some(b"not a png at all"), "");
    let (out, world) = render_quad(&obj);
    assert_eq!(world.warnings().len(), 1, "{:?}", world.warnings());
    assert!(world.warnings()[0].contains("tex.png: cannot decode texture"), "{:?}", world.warnings());
    assert_eq!(out.rays.texture, 0);
    assert!((out.image.get(16, 16) - Vec3::ONE).length() < 1e-3);
}

#[test]
fn untextured_objects_make_no_texture_lookups() {
    let device = Device::new().unwrap();
    let scene = phongrt::scene::Model::from_mesh(phongrt::scene::uv_sphere(12, 6, 1.0));
    let world = World::from_scene(&device, &scene, |_, _| ObjectSettings::new(ObjectMode::Flat)).unwrap();
    let cam = Camera { eye: Vec3::new(0.0, 0.0, 4.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_deg: 40.0 };
    let s = RenderSettings { width: 16, height: 16, spp: 1, seed: 0, packets: true };
    let out = render(&world, &cam, &s).unwrap();
    assert_eq!(out.rays.texture, 0);
    assert!(!world.effects().to_string().contains("textures"));
}

#[test]
fn bad_vt_lines_warn_with_the_line_and_load() {
    let dir = tempfile::tempdir().unwrap();
    let obj = write_quad(dir.path(), Some(&png_2x2()), "vt 0.5 nan\nvt 1 2 3 4\n");
    let scene = load_obj(&obj, &LoadOptions::default()).unwrap();
    let w: Vec<_> = scene.warnings.iter().filter(|w| w.contains("`vt`")).collect();
    assert_eq!(w.len(), 1, "{:?}", scene.warnings);
    assert!(w[0].contains("quad.obj:10:") && w[0].contains("2 `vt` lines"), "{}", w[0]);
    assert_eq!(scene.meshes[0].corner_uvs.len(), 2);
    assert_eq!(scene.meshes[0].corner_uvs[0][1], [1.0, 0.0]);
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn the_spiders_backslash_jpeg_textures_load() {
    let obj = common::corpus_required().join("spider/spider.obj");
    let scene = load_obj(&obj, &LoadOptions::default()).unwrap();
    assert!(!scene.warnings.iter().any(|w| w.contains("not found")), "{:?}", scene.warnings);
    let device = Device::new().unwrap();
    let world = World::from_scene(&device, &scene, |_, _| ObjectSettings::new(ObjectMode::Flat)).unwrap();
    assert!(world.warnings().is_empty(), "{:?}", world.warnings());
    let textured = world.objects().iter().filter(|o| o.texture.is_some()).count();
    assert_eq!(textured, world.objects().len(), "every spider part has a `.\\x.jpg` texture");
}
