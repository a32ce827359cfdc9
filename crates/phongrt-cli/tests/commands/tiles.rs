//! Crop, tiles and stitch: the stitched image is bit-identical to the single-machine render,
//! whatever the tile count and thread count; frames, seeds and stats; bad farm flags are one
//! line naming the flag and the value, with exit status 2; image read/write errors are typed
//! and name the file.
use crate::common;

use std::path::{Path, PathBuf};

use assert_cmd::Command;

fn phongrt() -> Command {
    Command::cargo_bin("phongrt").unwrap()
}

fn sphere() -> String {
    common::root().join("scenes/sphere_lowpoly.obj").to_string_lossy().into_owned()
}

/// A scene whose pixels use every random stream: jittered samples, an area light, AO, a mirror.
fn noisy_scene(dir: &Path) -> PathBuf {
    let p = dir.join("noisy.toml");
    std::fs::write(
        &p,
        format!(
            "obj = {:?}\n[render]\nwidth = 61\nheight = 47\nspp = 4\n\
             [[light]]\ntype = \"sphere\"\ncenter = [2.0, 3.0, 2.0]\nradius = 0.8\nintensity = [8.0, 8.0, 8.0]\nsamples = 2\n\
             [ambient_occlusion]\nsamples = 2\ndistance = 0.5\n\
             [[object]]\nname = \"*\"\nmirror = [0.3, 0.3, 0.3]\n",
            sphere()
        ),
    )
    .unwrap();
    p
}

fn render(args: &[&str], out: &Path) {
    phongrt().args(["render", "-q"]).args(args).arg("-o").arg(out).assert().success();
}

/// Decoded RGB(A) bytes of a PNG, or the f32 bits of an EXR.
fn pixels(p: &Path) -> Vec<u32> {
    let img = image::open(p).unwrap();
    if p.extension().unwrap() == "exr" {
        img.to_rgba32f().into_raw().into_iter().map(f32::to_bits).collect()
    } else {
        img.to_rgba8().into_raw().into_iter().map(u32::from).collect()
    }
}

fn stitched_tiles_equal_the_whole_render(ext: &str, extra: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let scene = noisy_scene(dir.path());
    let scene = scene.to_str().unwrap();
    let whole = dir.path().join(format!("whole.{ext}"));
    let mut a = vec![scene, "--threads", "1"];
    a.extend_from_slice(extra);
    render(&a, &whole);
    let reference = pixels(&whole);
    for n in [1u32, 4, 7] {
        let mut tiles = Vec::new();
        for i in 0..n {
            let t = dir.path().join(format!("t{n}_{i}.{ext}"));
            let spec = format!("{i}/{n}");
            let mut a = vec![scene, "--tile", &spec, "--threads", "2"];
            a.extend_from_slice(extra);
            render(&a, &t);
            tiles.push(t);
        }
        // Any order.
        tiles.reverse();
        let out = dir.path().join(format!("s{n}.{ext}"));
        phongrt().arg("stitch").arg(&out).args(&tiles).assert().success();
        assert_eq!(pixels(&out), reference, "{n} tiles, {ext}");
    }
}

#[test]
fn stitched_png_tiles_are_bit_identical_to_the_single_render_at_1_4_and_7_tiles() {
    stitched_tiles_equal_the_whole_render("png", &[]);
}

#[test]
fn stitched_exr_tiles_with_alpha_are_bit_identical_to_the_single_render() {
    stitched_tiles_equal_the_whole_render("exr", &["--alpha-channel"]);
}

#[test]
fn a_crop_is_the_same_window_of_the_whole_frame() {
    let dir = tempfile::tempdir().unwrap();
    let scene = noisy_scene(dir.path());
    let whole = dir.path().join("whole.png");
    let crop = dir.path().join("crop.png");
    render(&[scene.to_str().unwrap()], &whole);
    render(&[scene.to_str().unwrap(), "--crop", "10,5,43,40", "--threads", "2"], &crop);
    let w = image::open(&whole).unwrap().to_rgb8();
    let c = image::open(&crop).unwrap().to_rgb8();
    assert_eq!(c.dimensions(), (33, 35));
    for (x, y, p) in c.enumerate_pixels() {
        assert_eq!(p, w.get_pixel(x + 10, y + 5), "({x}, {y})");
    }
}

/// One `phongrt: error` line containing every needle, exit status `code`, no panic.
fn fails(args: &[&str], code: i32, needles: &[&str]) -> String {
    let a = phongrt().args(args).assert().failure().code(code);
    let err = String::from_utf8(a.get_output().stderr.clone()).unwrap();
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("phongrt: error")).collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert_eq!(err.lines().filter(|l| !l.starts_with("phongrt: warning")).count(), 1, "{err}");
    for n in needles {
        assert!(lines[0].contains(n), "{n:?} not in {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    err
}

#[test]
fn bad_farm_flags_name_the_flag_and_value_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    let out = out.to_str().unwrap();
    let s = sphere();
    let r = |extra: &[&str]| {
        let mut a = vec!["render", s.as_str(), "-q", "--width", "40", "--height", "30", "-o", out];
        a.extend_from_slice(extra);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let run = |extra: &[&str], needles: &[&str]| {
        let a = r(extra);
        fails(&a.iter().map(String::as_str).collect::<Vec<_>>(), 2, needles)
    };
    run(&["--tile", "4/4"], &["--tile 4/4", "out of range"]);
    run(&["--tile", "x/4"], &["--tile", "x/4"]);
    run(&["--tile", "0/31"], &["--tile 0/31", "30 rows"]);
    run(&["--crop", "0,0,41,10"], &["--crop 0,0,41,10", "40x30"]);
    run(&["--crop", "5,5,5,10"], &["--crop 5,5,5,10"]);
    run(&["--frames", "0"], &["--frames 0"]);
    run(&["--frames", "3", "--frame", "3"], &["--frame 3"]);
    run(&["--seed", "abc"], &["--seed", "abc"]);
    run(&["--threads", "0"], &["--threads 0"]);
    run(&["--fov", "200"], &["--fov 200", "(0, 180)"]);
    // Tiles given to stitch that overlap, or leave a gap, or come from different frames.
    let tile = |spec: &str, name: &str, size: &str| {
        let p = dir.path().join(name);
        phongrt()
            .args(["render", &s, "-q", "--width", size, "--height", "30", "--tile", spec, "-o"])
            .arg(&p)
            .assert()
            .success();
        p.to_string_lossy().into_owned()
    };
    let a = tile("0/3", "a.png", "40");
    let b = tile("1/3", "b.png", "40");
    let c = tile("2/3", "c.png", "40");
    let b2 = tile("1/2", "b2.png", "40");
    let other = tile("2/3", "other.png", "42");
    let st = dir.path().join("st.png");
    let st = st.to_str().unwrap();
    fails(&["stitch", st, &a, &b, &b2, &c], 2, &["stitch", "overlaps", "b2.png"]);
    fails(&["stitch", st, &a, &c], 2, &["stitch", "cover", "40x30"]);
    fails(&["stitch", st, &a, &b, &other], 2, &["stitch", "other.png", "42x30"]);
    fails(&["stitch", st, &a, &b, &c, &a], 2, &["stitch", "overlaps"]);
    assert!(!Path::new(st).exists());
    phongrt().args(["stitch", st, &a, &b, &c]).assert().success();
}

#[test]
fn frames_orbit_and_one_frame_is_the_same_as_in_the_sequence() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("orbit.png");
    let s = sphere();
    let base = ["--width", "32", "--height", "24", "--frames", "3", "--orbit", "90"];
    let mut a = vec![s.as_str()];
    a.extend_from_slice(&base);
    render(&a, &out);
    let f: Vec<Vec<u32>> = (0..3).map(|k| pixels(&dir.path().join(format!("orbit_{k:04}.png")))).collect();
    assert_ne!(f[0], f[1]);
    assert_ne!(f[1], f[2]);
    assert!(!out.exists());
    let one = dir.path().join("one.png");
    a.extend_from_slice(&["--frame", "1"]);
    render(&a, &one);
    assert_eq!(pixels(&dir.path().join("one_0001.png")), f[1]);
    assert!(!dir.path().join("one_0000.png").exists());
}

#[test]
fn the_seed_changes_the_samples_and_only_the_seed_does() {
    let dir = tempfile::tempdir().unwrap();
    let scene = noisy_scene(dir.path());
    let scene = scene.to_str().unwrap();
    let img = |seed: &str, name: &str| {
        let p = dir.path().join(name);
        render(&[scene, "--seed", seed], &p);
        pixels(&p)
    };
    let a = img("1", "a.png");
    assert_eq!(a, img("1", "b.png"));
    assert_ne!(a, img("2", "c.png"));
}

#[test]
fn stats_json_counts_rays_by_kind_with_stage_times_and_effects() {
    let dir = tempfile::tempdir().unwrap();
    let scene = noisy_scene(dir.path());
    let out = dir.path().join("o.png");
    let a = phongrt()
        .args(["render", "-q", scene.to_str().unwrap(), "--stats", "json", "-o"])
        .arg(&out)
        .assert()
        .success();
    let v: serde_json::Value = serde_json::from_slice(&a.get_output().stdout).unwrap();
    let f = &v["frames"][0];
    assert_eq!(f["rays"]["primary"], 61 * 47 * 4);
    assert!(f["rays"]["shadow"].as_u64().unwrap() > 0);
    assert!(f["rays"]["ambient_occlusion"].as_u64().unwrap() > 0);
    assert!(f["rays"]["reflection"].as_u64().unwrap() > 0);
    assert!(f["mrays_per_s"].as_f64().unwrap() > 0.0);
    assert!(f["seconds"]["render"].as_f64().unwrap() > 0.0);
    assert!(v["seconds"]["load"].as_f64().unwrap() > 0.0);
    assert!(v["seconds"]["build"].as_f64().is_some());
    assert!(v["effects"]["summary"].as_str().unwrap().contains("ambient occlusion"));
    assert_eq!(v["effects"]["reflective"].as_array().unwrap().len(), 1);
    // To a file, with the image on stdout.
    let stats = dir.path().join("stats.json");
    let a = phongrt()
        .args(["render", "-q", &sphere(), "--width", "20", "--height", "10", "--stats"])
        .arg(&stats)
        .args(["-o", "-"])
        .assert()
        .success();
    let img = image::load_from_memory_with_format(&a.get_output().stdout, image::ImageFormat::Png).unwrap();
    assert_eq!((img.width(), img.height()), (20, 10));
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(v["frames"][0]["rays"]["primary"], 200);
    assert_eq!(v["frames"][0]["output"], "-");
}

#[test]
fn image_errors_are_typed_one_line_and_name_the_file() {
    use phongrt_render::image_out::{
        check_writable, encode, read_tile, write_atomically, EncodeOptions, ImageError, ImageFormat,
    };
    use phongrt_render::Image;
    use std::error::Error;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();

    // Compute each failure and its message.
    let is_dir = write_atomically(d, b"x").unwrap_err();
    assert!(matches!(is_dir, ImageError::IsDirectory { .. }), "{is_dir:?}");
    assert_eq!(is_dir.to_string(), format!("{}: is a directory", d.display()));

    let no_dir = check_writable(&d.join("none/x.png")).unwrap_err();
    assert!(matches!(no_dir, ImageError::NoDirectory { .. }), "{no_dir:?}");
    assert_eq!(
        no_dir.to_string(),
        format!("{}: directory {} does not exist", d.join("none/x.png").display(), d.join("none").display())
    );

    let ext = ImageFormat::from_path(Path::new("x.bmp")).unwrap_err();
    assert!(matches!(ext, ImageError::UnknownExtension { .. }), "{ext:?}");
    assert_eq!(ext.to_string(), "x.bmp: unknown image extension (use .png or .exr)");

    // An I/O or codec cause is the source, not repeated in the message.
    let missing = read_tile(&d.join("missing.png")).unwrap_err();
    assert!(matches!(missing, ImageError::Read { .. }), "{missing:?}");
    assert_eq!(missing.to_string(), format!("{}: cannot read", d.join("missing.png").display()));
    assert!(missing.source().is_some_and(|s| s.to_string().contains("No such file")), "{missing:?}");

    let text = d.join("text.png");
    std::fs::write(&text, "hello").unwrap();
    let bad = read_tile(&text).unwrap_err();
    assert!(matches!(bad, ImageError::DecodePng { .. }), "{bad:?}");
    assert_eq!(bad.to_string(), format!("{}: not a readable PNG", text.display()));
    assert!(bad.source().is_some(), "{bad:?}");

    let alpha = [1.0f32; 3];
    let short = encode(
        &Image::new(2, 2),
        ImageFormat::Png,
        &EncodeOptions { alpha: Some(&alpha), ..Default::default() },
    )
    .unwrap_err();
    assert!(matches!(short, ImageError::AlphaLength { alpha: 3, pixels: 4 }), "{short:?}");
    assert_eq!(short.to_string(), "alpha has 3 values for 4 pixels");
}
