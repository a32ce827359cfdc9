//! The origin skip is exact: an occlusion ray that starts on a Phong patch leaves that patch out
//! (without a solve) only where it provably cannot hit it. Audited here over renders of every
//! in-repo scene: each skipped solve is run anyway, and one that hits fails the render. The
//! curved rule (off by default) is turned on here, so its skips are audited too.
mod common;
use std::path::{Path, PathBuf};

use assert_cmd::Command;
use glam::Vec3;
use phongrt::embree::Device;
use phongrt::phong::convexity::{audit, curved_rule};
use phongrt::scene::{load_obj, LoadOptions};
use phongrt_render::{
    default_lights, render, AmbientOcclusion, Camera, Light, ObjectMode, RenderSettings, Terminator, World,
};

/// The in-repo scenes of `ext` (in `scenes/` and one level below).
fn scenes(ext: &str) -> Vec<PathBuf> {
    let root = common::root().join("scenes");
    let mut out = Vec::new();
    for e in std::fs::read_dir(&root).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(std::fs::read_dir(&p).unwrap().flatten().map(|e| e.path()));
        } else {
            out.push(p);
        }
    }
    out.retain(|p| p.extension().is_some_and(|x| x == ext));
    out.sort();
    out
}

/// `path` in Phong mode at 24², with shadows from a point and an area light and ambient
/// occlusion, one ray at a time or in packets, under each terminator rule.
fn render_audited(device: &Device, path: &Path) {
    let scene = load_obj(path, &LoadOptions::default()).unwrap();
    let (lo, hi) = scene.bounds();
    let r = (hi - lo).length();
    let area =
        Light::Sphere { center: hi + Vec3::splat(r), radius: 0.1 * r, intensity: Vec3::ONE, samples: 2 };
    let builder = World::builder(device, &scene)
        .mode(ObjectMode::Phong { alpha: 1.0 })
        .lights(default_lights().into_iter().chain([area]))
        .ambient_occlusion(Some(AmbientOcclusion { samples: 2, distance: r }));
    let camera = Camera::frame_bounds(lo, hi, 1.0);
    let pool = phongrt_render::thread_pool(Some(2)).unwrap();
    for terminator in [Terminator::Lift, Terminator::Plain] {
        let world = builder.clone().terminator(terminator).build().unwrap();
        for packets in [true, false] {
            let s = RenderSettings { width: 24, height: 24, spp: 1, seed: 0, packets };
            pool.install(|| render(&world, &camera, &s))
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        }
    }
}

#[test]
fn no_skipped_origin_test_of_an_in_repo_scene_would_have_hit() {
    audit::set(true);
    // The curved rule is off by default: audited on, with every other rule.
    curved_rule::set(true);
    let device = Device::new().unwrap();
    let objs = scenes("obj");
    assert!(objs.len() >= 5, "{objs:?}");
    for path in &objs {
        let before = audit::counts().0;
        render_audited(&device, path);
        assert!(audit::counts().0 > before, "{}: no origin test was skipped", path.display());
    }
    let (skipped, hits) = audit::counts();
    assert_eq!(hits, 0);
    eprintln!("{skipped} skipped origin tests audited, none a hit");
}

#[test]
fn no_skipped_origin_test_of_an_in_repo_scene_file_would_have_hit() {
    let files = scenes("toml");
    assert!(files.len() >= 4, "{files:?}");
    let dir = tempfile::tempdir().unwrap();
    for path in &files {
        // The audit panics on a skipped solve that hits: the render then fails.
        Command::cargo_bin("phongrt")
            .unwrap()
            .current_dir(common::root())
            .env("PHONGRT_AUDIT_ORIGIN_SKIPS", "1")
            .env("PHONGRT_ORIGIN_CURVED_RULE", "1")
            .args([
                "render",
                path.to_str().unwrap(),
                "--width",
                "24",
                "--height",
                "24",
                "--spp",
                "1",
                "-q",
                "-o",
            ])
            .arg(dir.path().join("out.png"))
            .assert()
            .success();
    }
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn no_skipped_origin_test_of_the_african_head_would_have_hit() {
    // Most of the head's patches are saddles: its skips are mostly the curved rule's.
    audit::set(true);
    // The curved rule is off by default: audited on, with every other rule.
    curved_rule::set(true);
    let device = Device::new().unwrap();
    let before = audit::counts().0;
    render_audited(&device, &common::corpus_required().join("african_head/african_head.obj"));
    let (skipped, hits) = audit::counts();
    assert!(skipped > before, "no origin test was skipped");
    assert_eq!(hits, 0);
    eprintln!("{} skipped origin tests of the head audited, none a hit", skipped - before);
}
