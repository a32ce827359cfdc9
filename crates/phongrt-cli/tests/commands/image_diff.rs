//! Renders of the in-repo scenes against reference images made by the same commands, so that a
//! change to the intersectors or the geometry route (clusters, packets, a faster solve) shows
//! as an image diff: the images may move by rounding only.
//!
//! The references in tests/data/images were rendered at commit 7c0c1c6 with
//! `phongrt render SCENE --mode phong [--ground] --width W --height W --spp 4 -o REF.png`.
//! After an intended change of the image (shading, camera, lights), render them anew with the
//! same commands and say so in the commit. The two `--ground` references were rendered anew when
//! the default view began to frame the cast shadow (`--frame-shadow`); rendered with
//! `--frame-shadow off --front-cues off`, the new binary matched the old references within 6
//! (sphere, 30 channel values) and 12 levels (wuson, 81 channel values).
use crate::common;

use std::path::Path;

use assert_cmd::Command;

/// The reference images: tests/data/images of this package.
const IMAGES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/images");

/// Pixels that differ by more than `level` (of 255) in any channel, and the largest difference.
fn diff(a: &image::RgbImage, b: &image::RgbImage, level: u8) -> (usize, u8) {
    assert_eq!(a.dimensions(), b.dimensions());
    let mut count = 0;
    let mut max = 0;
    for (p, q) in a.pixels().zip(b.pixels()) {
        let d = (0..3).map(|c| p[c].abs_diff(q[c])).max().unwrap_or(0);
        max = max.max(d);
        count += usize::from(d > level);
    }
    (count, max)
}

/// Render `scene` as the reference was made and compare: at most 0.3% of the pixels may move by
/// more than 2 levels (a shadow-edge or silhouette pixel flipping under rounding).
fn check(scene: &str, reference: &str, width: u32, ground: bool) {
    let out = tempfile::tempdir().unwrap();
    let path = out.path().join("out.png");
    let w = width.to_string();
    let mut args = vec!["render", scene, "--mode", "phong", "--width", &w, "--height", &w, "--spp", "4"];
    if ground {
        args.push("--ground");
    }
    Command::cargo_bin("phongrt")
        .unwrap()
        .current_dir(common::root())
        .args(&args)
        .arg("-o")
        .arg(&path)
        .assert()
        .success();
    let got = image::open(&path).unwrap().to_rgb8();
    let want = image::open(Path::new(IMAGES).join(reference)).unwrap().to_rgb8();
    let (moved, max) = diff(&got, &want, 2);
    let pixels = (width * width) as usize;
    assert!(moved * 1000 <= pixels * 3, "{scene}: {moved} of {pixels} pixels moved (max {max} levels)");
}

#[test]
fn the_low_poly_sphere_renders_as_its_reference() {
    check("scenes/sphere_lowpoly.obj", "sphere_lowpoly_phong_128.png", 128, true);
}

#[test]
fn wuson_renders_as_its_reference() {
    check("scenes/wuson/WusonOBJ.obj", "wuson_phong_128.png", 128, true);
}

#[test]
fn the_capped_cylinder_renders_as_its_reference() {
    check("scenes/cylinder_capped.obj", "cylinder_capped_phong_96.png", 96, false);
}

#[test]
fn a_changed_image_is_caught() {
    // The check itself: the sphere's reference against wuson's differs in most pixels.
    let a = image::open(Path::new(IMAGES).join("sphere_lowpoly_phong_128.png")).unwrap();
    let b = image::open(Path::new(IMAGES).join("wuson_phong_128.png")).unwrap();
    let (moved, max) = diff(&a.to_rgb8(), &b.to_rgb8(), 2);
    assert!(moved > 1000 && max > 50, "{moved} {max}");
}
