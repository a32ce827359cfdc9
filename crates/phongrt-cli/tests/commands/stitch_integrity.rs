//! `stitch` refuses what would give a wrong image or lose work (issue 24).
use crate::common;

use std::path::{Path, PathBuf};

use assert_cmd::Command;

fn phongrt() -> Command {
    Command::new(common::target_dir().join("phongrt"))
}

// `phongrt stitch tiles/t_0.png tiles/t_*.png` overwrote the first tile.
#[test]
fn stitch_refuses_an_output_that_is_one_of_its_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let tiles: Vec<PathBuf> =
        (0..2).map(|i| tile_of(dir.path(), &format!("t_{i}"), "png", i, 2, &[])).collect();
    let before = std::fs::read(&tiles[0]).unwrap();
    let out = phongrt().arg("stitch").arg(&tiles[0]).args(&tiles).assert().failure().get_output().clone();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("t_0.png") && err.contains("same file"), "{err}");
    assert_eq!(std::fs::read(&tiles[0]).unwrap(), before, "the tile was changed");
}

// The same through a symbolic link to a tile.
#[test]
fn stitch_refuses_an_output_linked_to_one_of_its_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let tiles: Vec<PathBuf> =
        (0..2).map(|i| tile_of(dir.path(), &format!("t_{i}"), "png", i, 2, &[])).collect();
    let link = dir.path().join("out.png");
    std::os::unix::fs::symlink(&tiles[1], &link).unwrap();
    let before = std::fs::read(&tiles[1]).unwrap();
    let out = phongrt().arg("stitch").arg(&link).args(&tiles).assert().failure().get_output().clone();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("t_1.png") && err.contains("same file"), "{err}");
    assert_eq!(std::fs::read(&tiles[1]).unwrap(), before, "the tile was changed");
}

/// Render tile `i` of `n` of a small frame with `extra` flags into `dir/NAME.EXT` (with `--frames`,
/// the frame's file), and return its path.
fn tile_of(dir: &Path, name: &str, ext: &str, i: u32, n: u32, extra: &[&str]) -> PathBuf {
    let out = dir.join(format!("{name}.{ext}"));
    phongrt()
        .args(["render", "--width", "32", "--height", "24", "-q"])
        .args(if extra.first().is_some_and(|a| a.ends_with(".obj")) {
            &[][..]
        } else {
            &["scenes/sphere_lowpoly.obj"][..]
        })
        .args(extra)
        .args(["--tile", &format!("{i}/{n}"), "-o"])
        .arg(&out)
        .current_dir(common::root())
        .assert()
        .success();
    if out.exists() {
        return out;
    }
    // `--frames N --frame K` writes NAME_000K.EXT.
    let frame = extra.iter().position(|a| *a == "--frame").map(|p| extra[p + 1]).unwrap();
    dir.join(format!("{name}_{:0>4}.{ext}", frame))
}

/// `phongrt stitch OUT T0 T1`, which must fail with status 2: its standard error.
fn stitch_error(out: &Path, t0: &Path, t1: &Path) -> String {
    let a = phongrt().arg("stitch").arg(out).arg(t0).arg(t1).assert().code(2);
    String::from_utf8_lossy(&a.get_output().stderr).into_owned()
}

/// Stitch `a`'s tile 0 of 2 with `b`'s tile 1 of 2 and return stitch's stderr (it must fail with 2).
fn stitch_refused(a: &[&str], b: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let t0 = tile_of(dir.path(), "t_0", "png", 0, 2, a);
    let t1 = tile_of(dir.path(), "t_1", "png", 1, 2, b);
    let out = dir.path().join("out.png");
    let err = stitch_error(&out, &t0, &t1);
    assert!(!out.exists(), "stitch wrote an output it refused");
    assert!(err.contains("t_0") && err.contains("t_1") && err.contains("different renders"), "{err}");
    assert_eq!(err.lines().count(), 1, "not one line: {err}");
    err
}

#[test]
fn stitch_refuses_a_tile_with_another_seed() {
    let err = stitch_refused(&["--seed", "1"], &["--seed", "6"]);
    assert!(err.contains("seed 6 in") && err.contains("1 in"), "{err}");
}

#[test]
fn stitch_refuses_a_tile_of_another_frame() {
    let err = stitch_refused(&["--frames", "4", "--frame", "1"], &["--frames", "4", "--frame", "2"]);
    assert!(err.contains("frame 2 in") && err.contains("1 in"), "{err}");
}

#[test]
fn stitch_refuses_a_tile_rendered_flat() {
    let err = stitch_refused(&[], &["--mode", "flat"]);
    assert!(err.contains("mode flat in") && err.contains("phong:0.75 in"), "{err}");
}

#[test]
fn stitch_refuses_a_tile_with_another_spp() {
    let err = stitch_refused(&["--spp", "4"], &["--spp", "2"]);
    assert!(err.contains("spp 2 in") && err.contains("4 in"), "{err}");
}

#[test]
fn stitch_refuses_a_tile_of_another_scene() {
    let err = stitch_refused(&["scenes/sphere_lowpoly.obj"], &["scenes/sphere_sincos.obj"]);
    assert!(err.contains("scene sphere_sincos.obj in") && err.contains("sphere_lowpoly.obj in"), "{err}");
}

// A setting not named in the record (here the field of view) still changes the digest.
#[test]
fn stitch_refuses_a_tile_with_another_camera_by_its_digest() {
    let err = stitch_refused(&["--fov", "40"], &["--fov", "41"]);
    assert!(err.contains("scene files or settings differ") && err.contains("digest"), "{err}");
}

// The same OBJ path, its contents edited between the two tiles: the contents count, not the name.
#[test]
fn stitch_refuses_a_tile_whose_obj_file_changed_between_renders() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("m.obj");
    let src = std::fs::read_to_string(common::root().join("scenes/sphere_lowpoly.obj")).unwrap();
    std::fs::write(&obj, &src).unwrap();
    let obj_s = obj.to_str().unwrap();
    let t0 = tile_of(dir.path(), "t_0", "png", 0, 2, &[obj_s]);
    std::fs::write(&obj, format!("{src}\n# edited\n")).unwrap();
    let t1 = tile_of(dir.path(), "t_1", "png", 1, 2, &[obj_s]);
    let out = dir.path().join("out.png");
    let err = stitch_error(&out, &t0, &t1);
    assert!(err.contains("different renders") && err.contains("digest"), "{err}");
}

#[test]
fn stitch_refuses_exr_tiles_of_different_renders() {
    let dir = tempfile::tempdir().unwrap();
    let t0 = tile_of(dir.path(), "t_0", "exr", 0, 2, &["--seed", "1"]);
    let t1 = tile_of(dir.path(), "t_1", "exr", 1, 2, &["--seed", "2"]);
    let out = dir.path().join("out.exr");
    let err = stitch_error(&out, &t0, &t1);
    assert!(err.contains("seed 2 in") && err.contains("t_1.exr"), "{err}");
}

// A tile written before tiles recorded their render: only its window.
#[test]
fn stitch_refuses_a_tile_that_records_no_render_digest() {
    use phongrt_render::image_out::{encode_png8, Window};
    let dir = tempfile::tempdir().unwrap();
    let t0 = tile_of(dir.path(), "t_0", "png", 0, 2, &[]);
    let old = dir.path().join("old_1.png");
    let win = Window { x0: 0, y0: 12, x1: 32, y1: 24, full_width: 32, full_height: 24 };
    std::fs::write(&old, encode_png8(32, 12, false, &[0u8; 32 * 12 * 3], Some(win), None).unwrap()).unwrap();
    let out = dir.path().join("out.png");
    let err = stitch_error(&out, &t0, &old);
    assert!(err.contains("old_1.png") && err.contains("records no render digest"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}

// The digest is of the render, not of how it was split: tiles of one render at other thread
// counts and from other tilings (a crop) stitch, bit-identical to the whole render.
#[test]
fn tiles_of_one_render_at_other_thread_counts_and_tilings_stitch_to_the_whole_render() {
    let dir = tempfile::tempdir().unwrap();
    let t0 = tile_of(dir.path(), "t_0", "png", 0, 2, &["--threads", "1", "--seed", "3"]);
    let t1 = dir.path().join("c_1.png");
    phongrt()
        .args(["render", "scenes/sphere_lowpoly.obj", "--width", "32", "--height", "24", "-q"])
        .args(["--seed", "3", "--threads", "2", "--crop", "0,12,32,24", "-o"])
        .arg(&t1)
        .current_dir(common::root())
        .assert()
        .success();
    let whole = dir.path().join("whole.png");
    phongrt()
        .args([
            "render",
            "scenes/sphere_lowpoly.obj",
            "--width",
            "32",
            "--height",
            "24",
            "-q",
            "--seed",
            "3",
            "-o",
        ])
        .arg(&whole)
        .current_dir(common::root())
        .assert()
        .success();
    let out = dir.path().join("out.png");
    phongrt().arg("stitch").arg(&out).arg(&t0).arg(&t1).assert().success();
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&whole).unwrap());
}

// A texture rewritten between two tiles (one byte appended after its PNG data): the digest
// covers the textures' contents, so the tiles are refused although every setting is the same.
#[test]
fn stitch_refuses_a_tile_whose_texture_changed_between_renders() {
    let dir = tempfile::tempdir().unwrap();
    for f in ["duck.obj", "duck.mtl", "duckCM.png"] {
        std::fs::copy(common::root().join("scenes/duck").join(f), dir.path().join(f)).unwrap();
    }
    let obj = dir.path().join("duck.obj");
    let obj_s = obj.to_str().unwrap();
    let t0 = tile_of(dir.path(), "t_0", "png", 0, 2, &[obj_s]);
    let mut tex = std::fs::read(dir.path().join("duckCM.png")).unwrap();
    tex.push(0);
    std::fs::write(dir.path().join("duckCM.png"), tex).unwrap();
    let t1 = tile_of(dir.path(), "t_1", "png", 1, 2, &[obj_s]);
    let out = dir.path().join("out.png");
    let err = stitch_error(&out, &t0, &t1);
    assert!(err.contains("different renders") && err.contains("settings differ"), "{err}");
}

// Issue 24: stitch held every tile and the frame in memory and ignored PHONGRT_MAX_MEMORY (the
// 32768² frame would have needed about 57 GB). A stitch whose streamed rows need more than the
// budget is refused, from the headers, before any pixel is read.
#[test]
fn exr_stitch_beyond_the_memory_budget_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let tiles: Vec<PathBuf> =
        (0..2).map(|i| tile_of(dir.path(), &format!("t_{i}"), "exr", i, 2, &[])).collect();
    let out = dir.path().join("out.exr");
    let o =
        phongrt().arg("stitch").arg(&out).args(&tiles).env("PHONGRT_MAX_MEMORY", "20000").assert().failure();
    let err = String::from_utf8_lossy(&o.get_output().stderr).into_owned();
    assert!(err.contains("32x24 frame needs about") && err.contains("PHONGRT_MAX_MEMORY"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!out.exists());
    phongrt().arg("stitch").arg(&out).args(&tiles).env("PHONGRT_MAX_MEMORY", "10000000").assert().success();
}

// EXR tiles are streamed block by block too: a frame whose tiles and image alone would need
// 72 bytes a pixel (the held-whole stitch's estimate: 19 MB here) stitches within 4 MB, and
// its pixels are the whole render's, bit for bit.
#[test]
fn exr_stitch_streams_within_a_small_memory_budget() {
    let dir = tempfile::tempdir().unwrap();
    let size = ["--width", "640", "--height", "420", "--alpha-channel"];
    let render = |out: &Path, extra: &[&str]| {
        phongrt()
            .args(["render", "scenes/sphere_lowpoly.obj", "-q"])
            .args(size)
            .args(extra)
            .arg("-o")
            .arg(out)
            .current_dir(common::root())
            .assert()
            .success();
    };
    let tiles: Vec<PathBuf> = (0..5)
        .map(|i| {
            let t = dir.path().join(format!("t_{i}.exr"));
            render(&t, &["--tile", &format!("{i}/5")]);
            t
        })
        .collect();
    let out = dir.path().join("out.exr");
    phongrt().arg("stitch").arg(&out).args(&tiles).env("PHONGRT_MAX_MEMORY", "4000000").assert().success();
    let whole = dir.path().join("whole.exr");
    render(&whole, &[]);
    let bits = |p: &Path| -> Vec<u32> {
        image::open(p).unwrap().to_rgba32f().into_raw().into_iter().map(f32::to_bits).collect()
    };
    assert_eq!(bits(&out), bits(&whole));
}

// PNG tiles are streamed row by row: the same frame stitches within a budget of 2 MB, and the
// result is the whole render's file.
#[test]
fn png_stitch_streams_within_a_small_memory_budget() {
    let dir = tempfile::tempdir().unwrap();
    let tiles: Vec<PathBuf> =
        (0..3).map(|i| tile_of(dir.path(), &format!("t_{i}"), "png", i, 3, &[])).collect();
    let out = dir.path().join("out.png");
    phongrt().arg("stitch").arg(&out).args(&tiles).env("PHONGRT_MAX_MEMORY", "2000000").assert().success();
    let whole = dir.path().join("whole.png");
    phongrt()
        .args(["render", "scenes/sphere_lowpoly.obj", "--width", "32", "--height", "24", "-q", "-o"])
        .arg(&whole)
        .current_dir(common::root())
        .assert()
        .success();
    assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&whole).unwrap());
}
