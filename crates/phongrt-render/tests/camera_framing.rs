//! The default camera on real models: the silhouette fills about 80% of the frame, the side
//! facing the camera is the lit one, and the up axis and front are found (corpus models; those
//! are #[ignore = "needs ../shared/corpus"] and fail loudly without it; .ci/run runs them).

mod common;

use glam::Vec3;
use phongrt::embree::{Device, Ray};
use phongrt::scene::{load_obj, LoadOptions};
use phongrt_render::camera::{default_view, default_view_with, shadow_points, DefaultViewOptions};
use phongrt_render::{Camera, Ground, ObjectMode, ObjectSettings, World};

/// The corpus folder: $PHONGRT_CORPUS, else ../shared/corpus beside the project.
fn corpus() -> std::path::PathBuf {
    std::env::var_os("PHONGRT_CORPUS").map(Into::into).unwrap_or_else(|| root().join("../shared/corpus"))
}
const W: u32 = 160;
const H: u32 = 120;
/// The fill the framing aims at is 0.8 of the tighter frame extent, measured on the vertices;
/// the silhouette (Phong patches bulge a little past them, and pixels quantise) may differ by 0.1.
const FILL: std::ops::RangeInclusive<f32> = 0.7..=0.9;

struct Measured {
    fill: f32,
    lit: f32,
    camera: Camera,
    up: Vec3,
    front: Vec3,
}

/// Render the hit mask and key-light facing of `rel` through its default camera.
fn measure(rel: &str) -> Option<Measured> {
    let path = corpus().join(rel);
    assert!(
        path.exists(),
        "{} not found: this test needs ../shared/corpus (or PHONGRT_CORPUS)",
        path.display()
    );
    let input = load_obj(&path, &LoadOptions::default()).unwrap();
    let (camera, det) = default_view(&input, None, 0.0, None, W as f32 / H as f32);
    let device = Device::new().unwrap();
    let world = World::from_scene(&device, &input, |_, _| {
        ObjectSettings::new(ObjectMode::Phong { alpha: phongrt::phong::DEFAULT_ALPHA })
    })
    .unwrap();
    let frame = camera.frame(W as f32 / H as f32).unwrap();
    let l = camera.key_light_direction();
    let (mut x0, mut x1, mut y0, mut y1) = (W, 0, H, 0);
    let (mut hits, mut lit) = (0u32, 0u32);
    for y in 0..H {
        for x in 0..W {
            let ray = Ray::new(frame.eye, frame.direction(x as f32 + 0.5, y as f32 + 0.5, W, H));
            let Some(hit) = world.scene().intersect1(ray) else { continue };
            let obj = &world.objects()[hit.geom_id as usize];
            let sp = obj.surface_point(&hit, &ray, world.shading(), world.terminator());
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x + 1), y0.min(y), y1.max(y + 1));
            hits += 1;
            if sp.n.dot(l) > 0.0 {
                lit += 1;
            }
        }
    }
    assert!(hits > 0, "{rel}: the default view misses the model");
    let fill = ((x1 - x0) as f32 / W as f32).max((y1 - y0) as f32 / H as f32);
    // The silhouette is centred: the margins on each side differ by at most 15% of the frame.
    let (mx, my) = ((x0 as f32 - (W - x1) as f32) / W as f32, (y0 as f32 - (H - y1) as f32) / H as f32);
    assert!(mx.abs() <= 0.15 && my.abs() <= 0.15, "{rel}: silhouette off centre by {mx}, {my}");
    let m = Measured { fill, lit: lit as f32 / hits as f32, camera, up: det.up, front: det.front };
    eprintln!("{rel}: fill {:.2}, lit {:.2}, {det}", m.fill, m.lit);
    Some(m)
}

fn check(rel: &str) -> Option<Measured> {
    let m = measure(rel)?;
    assert!(FILL.contains(&m.fill), "{rel}: the silhouette spans {:.2} of the frame", m.fill);
    // Most of what the camera sees faces the key light (the light is at the camera's upper left).
    assert!(m.lit >= 0.6, "{rel}: only {:.2} of the visible surface faces the key light", m.lit);
    Some(m)
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn wuson_is_seen_from_its_head_end_and_fills_the_frame() {
    if let Some(m) = check("wuson/WusonOBJ.obj") {
        assert_eq!((m.up, m.front), (Vec3::Y, -Vec3::Z));
        assert!((m.camera.eye - m.camera.look_at).z < 0.0, "the camera is behind the bull");
    }
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn spot_is_seen_from_its_head_end_and_fills_the_frame() {
    if let Some(m) = check("spot/spot.obj") {
        assert_eq!((m.up, m.front), (Vec3::Y, -Vec3::Z));
    }
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn mug_is_z_up_and_fills_the_frame() {
    if let Some(m) = check("mug/mug.obj") {
        assert_eq!(m.up, Vec3::Z);
        assert_eq!(m.camera.up, Vec3::Z);
    }
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn regr01_is_z_up_and_fills_the_frame() {
    if let Some(m) = check("regr01/regr01.obj") {
        assert_eq!(m.up, Vec3::Z);
    }
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn concave_polygon_is_seen_face_on_and_lit() {
    if let Some(m) = check("concave_polygon/concave_polygon.obj") {
        // Face-on within the three-quarter angles: the view is far from edge-on.
        let back = (m.camera.eye - m.camera.look_at).normalize();
        assert!(back.dot(m.front).abs() > 0.7, "edge-on view: {back} against the face {}", m.front);
    }
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn duck_suzanne_teapot_and_head_fill_the_frame() {
    for rel in ["duck/duck.obj", "suzanne/suzanne.obj", "teapot/teapot.obj", "african_head/african_head.obj"]
    {
        if let Some(m) = check(rel) {
            assert_eq!(m.up, Vec3::Y, "{rel}");
        }
    }
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn orbit_turns_the_view_about_the_up_axis() {
    let path = corpus().join("mug/mug.obj");
    assert!(path.exists(), "{} not found: this test needs ../shared/corpus", path.display());
    let input = load_obj(&path, &LoadOptions::default()).unwrap();
    let (a, _) = default_view(&input, None, 0.0, None, 1.0);
    let (b, _) = default_view(&input, None, 90.0, None, 1.0);
    let (da, db) = (a.eye - a.look_at, b.eye - b.look_at);
    // Same height above the model, horizontal directions a quarter turn apart.
    assert!((da.z / da.length() - db.z / db.length()).abs() < 1e-3);
    let (ha, hb) = (Vec3::new(da.x, da.y, 0.0).normalize(), Vec3::new(db.x, db.y, 0.0).normalize());
    assert!(ha.dot(hb).abs() < 1e-3, "{ha} and {hb} are not a quarter turn apart");
    assert!(ha.cross(hb).z > 0.0, "the orbit turns clockwise seen from above");
}

#[test]
fn a_given_up_axis_is_the_cameras_and_the_key_light_is_at_its_upper_left() {
    let input = phongrt::scene::Model::from_mesh(phongrt::scene::uv_sphere(24, 12, 1.0));
    let (c, _) = default_view(&input, Some(Vec3::Z), 0.0, None, 4.0 / 3.0);
    assert_eq!(c.up, Vec3::Z);
    let back = (c.eye - c.look_at).normalize();
    assert!(back.z > 0.3, "a z-up view looks from above the horizon: {back}");
    let l = c.key_light_direction();
    let right = (-back).cross(c.up).normalize();
    assert!(l.dot(back) > 0.0 && l.dot(right) < 0.0 && l.dot(c.up) > 0.0, "key light {l}");
}

/// The default view with or without a ground (and front cues, the default) of `input`.
fn view_on_ground(input: &phongrt::scene::Model, ground: bool, front_cues: bool, aspect: f32) -> Camera {
    let options = DefaultViewOptions { ground, front_cues, ..DefaultViewOptions::default() };
    default_view_with(input, None, 0.0, None, aspect, options).0
}

/// The fraction of the model's vertices' shadows on the ground (at the bottom of its bounds,
/// under the camera's key light) whose projection lies inside the `w`×`h` frame.
fn shadow_inside(input: &phongrt::scene::Model, camera: &Camera, w: u32, h: u32) -> f32 {
    let up = camera.up.normalize();
    let (lo, hi) = input.bounds();
    let bottom = [lo, hi].iter().map(|c| c.dot(up)).fold(f32::INFINITY, f32::min);
    let points: Vec<Vec3> = input.meshes.iter().flat_map(|m| m.positions.iter().copied()).collect();
    let shadows = shadow_points(&points, up, bottom, camera.key_light_direction());
    assert_eq!(shadows.len(), points.len());
    let frame = camera.frame(w as f32 / h as f32).unwrap();
    let inside = shadows
        .iter()
        .filter(|s| {
            frame
                .project(**s, w, h)
                .is_some_and(|(x, y)| (0.0..=w as f32).contains(&x) && (0.0..=h as f32).contains(&y))
        })
        .count();
    inside as f32 / shadows.len() as f32
}

#[test]
fn the_default_view_on_a_ground_frames_the_cast_shadow() {
    let mut models = vec![
        (
            "sphere_lowpoly",
            load_obj(&root().join("scenes/sphere_lowpoly.obj"), &LoadOptions::default()).unwrap(),
        ),
        ("wuson", load_obj(&root().join("scenes/wuson/WusonOBJ.obj"), &LoadOptions::default()).unwrap()),
        ("mug", load_obj(&root().join("scenes/mug/mug.obj"), &LoadOptions::default()).unwrap()),
    ];
    for rel in ["teapot/teapot.obj", "spider/spider.obj"] {
        let path = corpus().join(rel);
        if path.exists() {
            models.push((rel, load_obj(&path, &LoadOptions::default()).unwrap()));
        }
    }
    let mut cut_before = 0;
    for (name, input) in &models {
        for (w, h) in [(W, H), (120, 320)] {
            let aspect = w as f32 / h as f32;
            let new = shadow_inside(input, &view_on_ground(input, true, true, aspect), w, h);
            let old = shadow_inside(input, &view_on_ground(input, false, true, aspect), w, h);
            println!(
                "{name} at {w}x{h}: shadow inside the frame {new:.3} (the model alone framed: {old:.3})"
            );
            assert_eq!(new, 1.0, "{name} at {w}x{h}");
            cut_before += (old < 1.0) as usize;
        }
    }
    assert!(cut_before > 0, "no view framed on the model alone cut its shadow: the test lost its power");
}

#[test]
fn the_ground_is_large_enough_that_the_default_view_sees_no_far_edge() {
    // A portrait frame puts the camera far off, where a ground of 20 bounds diagonals ended
    // inside the view (its far edge showed as a band of background across the top).
    let input = load_obj(&root().join("scenes/sphere_lowpoly.obj"), &LoadOptions::default()).unwrap();
    let (w, h) = (48u32, 128u32);
    let camera = view_on_ground(&input, true, true, w as f32 / h as f32);
    let device = Device::new().unwrap();
    let mut top_background = Vec::new();
    for fit in [true, false] {
        let g = Ground { up: camera.up, ..Ground::default() };
        let radius = fit.then(|| g.radius_for_view(input.bounds(), &camera, w as f32 / h as f32));
        let ground = Some(Ground { radius, ..g });
        let world = World::builder(&device, &input).mode(ObjectMode::Flat).ground(ground).build().unwrap();
        let frame = camera.frame(w as f32 / h as f32).unwrap();
        let misses = (0..w)
            .filter(|&x| {
                world
                    .scene()
                    .intersect1(Ray::new(frame.eye, frame.direction(x as f32 + 0.5, 0.5, w, h)))
                    .is_none()
            })
            .count();
        top_background.push(misses);
    }
    println!(
        "top-row rays that miss the ground: sized to the view {}, 20 diagonals {}",
        top_background[0], top_background[1]
    );
    assert_eq!(top_background[0], 0);
    assert!(top_background[1] > 0, "the 20-diagonal ground shows no edge here: the test lost its power");
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn the_spider_shows_its_face() {
    let spider = corpus().join("spider/spider.obj");
    assert!(spider.exists(), "{} not found: this test needs ../shared/corpus", spider.display());
    let input = load_obj(&spider, &LoadOptions::default()).unwrap();
    let opts = DefaultViewOptions::default();
    let (_, det) = default_view_with(&input, None, 0.0, None, 4.0 / 3.0, opts);
    // Its objects "Kopf" (head) and "Auge" (eye) lie towards -x.
    assert!(det.front.dot(-Vec3::X) > 0.95, "spider front {}", det.front);
    let off = DefaultViewOptions { front_cues: false, ..opts };
    assert_eq!(default_view_with(&input, None, 0.0, None, 4.0 / 3.0, off).1.front, Vec3::Z);
}

#[test]
fn the_mug_shows_its_handle() {
    // The mug's handle sticks out towards +y: the front turns a quarter from it, and the camera
    // sees the handle 60 degrees off its line of sight, to the right.
    let input = load_obj(&root().join("scenes/mug/mug.obj"), &LoadOptions::default()).unwrap();
    let (cam, det) = default_view(&input, None, 0.0, None, 4.0 / 3.0);
    assert!(det.front.dot(Vec3::X) > 0.99, "mug front {}", det.front);
    let back = (cam.eye - cam.look_at).normalize();
    let horiz = Vec3::new(back.x, back.y, 0.0).normalize();
    let right = (-back).cross(cam.up).normalize();
    assert!((horiz.dot(Vec3::Y) - 0.5).abs() < 0.01, "the handle is not 60 degrees off the view: {horiz}");
    assert!(right.dot(Vec3::Y) > 0.8, "the handle is not on the right: {right}");
    let off = DefaultViewOptions { front_cues: false, ..DefaultViewOptions::default() };
    assert_eq!(default_view_with(&input, None, 0.0, None, 4.0 / 3.0, off).1.front, -Vec3::Y);
}

fn root() -> std::path::PathBuf {
    common::root()
}

#[test]
fn a_given_light_casts_the_framed_shadow() {
    // A scene file's directional light (scenes/figure1_sphere.toml's) replaces the key light.
    let input = load_obj(&root().join("scenes/sphere_lowpoly.obj"), &LoadOptions::default()).unwrap();
    let light = Vec3::new(-0.5, 0.7, 0.6).normalize();
    let (w, h) = (120u32, 320u32);
    let inside = |ground| {
        let opts = DefaultViewOptions { ground, ground_light: Some(light), ..DefaultViewOptions::default() };
        let camera = default_view_with(&input, None, 0.0, None, w as f32 / h as f32, opts).0;
        let frame = camera.frame(w as f32 / h as f32).unwrap();
        let points: Vec<Vec3> = input.meshes[0].positions.clone();
        let bottom = input.bounds().0.y;
        let shadows = shadow_points(&points, Vec3::Y, bottom, light);
        let n = shadows
            .iter()
            .filter(|s| {
                frame
                    .project(**s, w, h)
                    .is_some_and(|(x, y)| (0.0..=w as f32).contains(&x) && (0.0..=h as f32).contains(&y))
            })
            .count();
        n as f32 / shadows.len() as f32
    };
    let (with, without) = (inside(true), inside(false));
    println!("shadow of the given light inside the frame: {with:.3} (model alone framed: {without:.3})");
    assert_eq!(with, 1.0);
    assert!(without < 1.0);
}
