//! What MTL materials call for: Blinn-Phong highlights (only for glossy materials, counted),
//! glass with Fresnel reflection and shadows attenuated by its transmission (the iterative
//! shadow ray only where a material is transmissive), warnings for out-of-range values, and an
//! effects plan that lists each effect once.

use std::path::Path;

use glam::Vec3;
use phongrt::embree::Device;
use phongrt::scene::{uv_sphere, Material, Model};
use phongrt_render::world::fresnel_dielectric;
use phongrt_render::{
    render, Camera, Ground, Light, ObjectMode, RenderSettings, Surface, World, WorldBuilder,
};

fn settings(w: u32) -> RenderSettings {
    RenderSettings { width: w, height: w, spp: 1, seed: 0, packets: true }
}

fn camera() -> Camera {
    Camera { eye: Vec3::new(0.0, 0.0, 4.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_deg: 40.0 }
}

/// The Phong unit sphere over `ground`, with `more` of the builder's settings.
fn sphere_world(
    device: &Device,
    ground: Option<Ground>,
    more: impl for<'a> FnOnce(WorldBuilder<'a>) -> WorldBuilder<'a>,
) -> World {
    let scene = Model::from_mesh(uv_sphere(48, 24, 1.0));
    more(World::builder(device, &scene).mode(ObjectMode::Phong { alpha: 0.75 }).ground(ground))
        .build()
        .unwrap()
}

fn glossy() -> Material {
    Material { illum: Some(2), ks: Vec3::splat(0.5), ns: 64.0, ..Material::default() }
}

#[test]
fn a_glossy_material_has_a_highlight_where_the_mirror_direction_meets_the_light() {
    let device = Device::new().unwrap();
    // The light straight behind the camera: the highlight is at the image centre.
    let light = Light::Directional { direction: Vec3::Z, radiance: Vec3::ONE, shadows: false };
    let world = sphere_world(&device, None, |b| b.lights([light]));
    let plain = render(&world, &camera(), &settings(64)).unwrap();
    assert_eq!(plain.rays.specular, 0, "a diffuse material evaluates no lobe");
    let world =
        sphere_world(&device, None, |b| b.lights([light]).surface("*", Surface::from_material(&glossy())));
    assert!(world.effects().to_string().contains("highlights (1 objects)"), "{}", world.effects());
    let shiny = render(&world, &camera(), &settings(64)).unwrap();
    assert!(shiny.rays.specular > 0 && shiny.rays.total() == plain.rays.total(), "{}", shiny.rays);
    let (c0, c1) = (plain.image.get(32, 32), shiny.image.get(32, 32));
    // Normalised Blinn-Phong at the peak: Ks (Ns + 8) / 8 = 0.5 * 9 = 4.5 times the light.
    assert!((c1 - c0).x > 4.0, "no highlight at the centre: {c0} -> {c1}");
    // Off the highlight (near the rim) the lobe adds next to nothing.
    let (e0, e1) = (plain.image.get(32, 50), shiny.image.get(32, 50));
    assert!((e1 - e0).x.abs() < 0.02, "the lobe is not narrow: {e0} -> {e1}");
}

#[test]
fn illum_1_or_zero_shininess_calls_for_no_highlight() {
    for m in [
        Material { illum: Some(1), ..glossy() },
        Material { ns: 0.0, ..glossy() },
        Material { ks: Vec3::ZERO, ..glossy() },
    ] {
        assert!(!Surface::from_material(&m).glossy(), "{m:?}");
    }
    assert!(Surface::from_material(&glossy()).glossy());
}

#[test]
fn negative_ns_and_ks_above_one_warn_once_naming_the_file_and_are_clamped() {
    let m = Material { name: "shiny".into(), ks: Vec3::new(1.5, 0.2, 0.2), ns: -3.0, ..glossy() };
    let (s, w) = Surface::from_material_checked(&m, Path::new("models/a.obj"));
    assert_eq!(w.len(), 2, "{w:?}");
    assert!(w.iter().all(|l| l.starts_with("models/a.obj: material \"shiny\": ") && !l.contains('\n')));
    assert!(w[0].contains("Ks") && w[1].contains("Ns"), "{w:?}");
    // Ns clamped to 0: no lobe.
    assert_eq!(s.shininess, 0.0);
    assert!(!s.glossy());
    let (s, w) = Surface::from_material_checked(
        &Material { ks: Vec3::new(1.5, 0.2, 0.2), ..glossy() },
        Path::new("a.obj"),
    );
    assert_eq!(w.len(), 1, "{w:?}");
    assert_eq!(s.specular, Vec3::new(1.0, 0.2, 0.2));
    let (_, none) = Surface::from_material_checked(&glossy(), Path::new("a.obj"));
    assert!(none.is_empty());
}

/// An MTL `Kd` outside [0, 1] (above 1 the surface would reflect more light than it receives;
/// below 0, negative light) warns once, naming the file and the material, and is clamped; a
/// NaN (from a material built in code: the MTL reader refuses one) warns too, and is made 0.
#[test]
fn kd_outside_0_to_1_warns_naming_the_file_and_is_clamped() {
    let m = Material { name: "hot".into(), kd: Vec3::new(f32::NAN, 0.2, 0.5), ..glossy() };
    let (s, w) = Surface::from_material_checked(&m, Path::new("a.obj"));
    assert_eq!((w.len(), s.kd), (1, Vec3::new(0.0, 0.2, 0.5)), "{w:?}");
    let m = Material { name: "hot".into(), kd: Vec3::new(1.5, -0.2, 0.5), ..glossy() };
    let (s, w) = Surface::from_material_checked(&m, Path::new("models/a.obj"));
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].starts_with("models/a.obj: material \"hot\": Kd 1.5 -0.2 0.5") && !w[0].contains('\n'),
        "{w:?}"
    );
    assert_eq!(s.kd, Vec3::new(1.0, 0.0, 0.5));
    let (s, none) =
        Surface::from_material_checked(&Material { kd: Vec3::ONE, ..glossy() }, Path::new("a.obj"));
    assert!(none.is_empty(), "{none:?}");
    assert_eq!(s.kd, Vec3::ONE);
}

#[test]
fn fresnel_reflectance_is_4_percent_head_on_and_rises_to_1_at_grazing() {
    let eta = 1.0 / 1.5f32;
    let cos_t = |ci: f32| (1.0 - eta * eta * (1.0 - ci * ci)).sqrt();
    assert!((fresnel_dielectric(1.0, 1.0, eta) - 0.04).abs() < 1e-4);
    let mut last = 0.0;
    for k in (1..=100).rev() {
        let ci = k as f32 / 100.0;
        let f = fresnel_dielectric(ci, cos_t(ci), eta);
        assert!(f >= last - 1e-6 && f <= 1.0, "not rising towards grazing at cos {ci}: {f}");
        last = f;
    }
    assert!(last > 0.8, "{last}");
}

/// The ground under the unit sphere (0.6 off its axis), seen from outside the sphere.
fn ground_under(world: &World) -> Vec3 {
    let p = Vec3::new(0.6, -1.0, 0.0);
    let cam = Camera { eye: p + Vec3::new(1.5, 0.4, 0.0), look_at: p, up: Vec3::Y, fov_y_deg: 1.0 };
    render(world, &cam, &settings(4)).unwrap().image.get(2, 2)
}

#[test]
fn glass_casts_a_shadow_attenuated_by_its_transmission_and_opaque_one_a_full_shadow() {
    let device = Device::new().unwrap();
    let light = Light::Directional { direction: Vec3::Y, radiance: Vec3::ONE, shadows: true };
    let world = sphere_world(&device, Some(Ground::default()), |b| b.ambient(Vec3::ZERO).lights([light]));
    let opaque = ground_under(&world);
    assert!(opaque.max_element() < 1e-6, "an opaque sphere's shadow is lit: {opaque}");
    let glass = Surface { transmission: 0.8, ior: 1.5, ..Surface::diffuse(Vec3::ZERO) };
    let world = sphere_world(&device, Some(Ground::default()), |b| {
        b.ambient(Vec3::ZERO).lights([light]).surface("*", glass)
    });
    let glass = ground_under(&world);
    // Through two surfaces of transmission 0.8: 0.64 of the ground's lit 0.6 (the camera is
    // outside the sphere, looking at the ground beside its foot: no refraction on the way).
    let lit = 0.6;
    assert!((glass.x - 0.64 * lit).abs() < 0.02, "shadow through glass {glass}, want {}", 0.64 * lit);
}

#[test]
fn shadow_rays_pass_transmissive_surfaces_only_when_a_material_is_transmissive() {
    let device = Device::new().unwrap();
    let light = Light::Directional { direction: Vec3::Y, radiance: Vec3::ONE, shadows: true };
    let world = sphere_world(&device, Some(Ground::default()), |b| b.lights([light]));
    let cam = Camera { eye: Vec3::new(0.0, 1.0, 5.0), look_at: Vec3::new(0.0, -0.5, 0.0), ..camera() };
    let opaque = render(&world, &cam, &settings(48)).unwrap();
    assert_eq!((opaque.rays.refraction, opaque.rays.reflection), (0, 0));
    // One shadow ray per lit shading point: no pass-through loop for an opaque scene.
    let lit_points = opaque.rays.primary;
    assert!(opaque.rays.shadow <= lit_points, "{}", opaque.rays);
    let glass = Surface { transmission: 0.8, ior: 1.5, ..Surface::diffuse(Vec3::ZERO) };
    let world = sphere_world(&device, Some(Ground::default()), |b| b.lights([light]).surface("*", glass));
    let glass = render(&world, &cam, &settings(48)).unwrap();
    assert!(glass.rays.refraction > 0 && glass.rays.reflection > 0, "{}", glass.rays);
    let plan = world.effects().to_string();
    assert!(plan.contains("shadows through glass (1 objects)") && plan.contains("Fresnel"), "{plan}");
}

#[test]
fn the_effects_plan_lists_an_area_light_once() {
    let device = Device::new().unwrap();
    let area = Light::Sphere {
        center: Vec3::new(2.0, 3.0, 2.0),
        radius: 0.5,
        intensity: Vec3::splat(10.0),
        samples: 4,
    };
    let world = sphere_world(&device, None, |b| b.lights([area]));
    assert_eq!(world.effects().to_string(), "effects: direct lighting, soft shadows (1 area lights)");
    let sun = Light::Directional { direction: Vec3::Y, radiance: Vec3::ONE, shadows: true };
    let world = sphere_world(&device, None, |b| b.lights([area, sun]));
    assert_eq!(
        world.effects().to_string(),
        "effects: direct lighting, shadows (1 lights), soft shadows (1 area lights)"
    );
}
