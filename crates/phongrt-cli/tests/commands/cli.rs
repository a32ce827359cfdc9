//! The `phongrt` command: render, info, accuracy; every bad input a one-line error and a
//! non-zero exit, never a panic.
use crate::common;
use crate::common::phongrt;

use predicates::prelude::*;

/// `phongrt ARGS` succeeds, and its standard output names both `a` and `b`.
fn prints_both(args: &[&str], a: &str, b: &str) {
    phongrt()
        .args(args)
        .assert()
        .success()
        .stdout(predicate::str::contains(a).and(predicate::str::contains(b)));
}

#[test]
fn help_reads_well() {
    prints_both(&["--help"], "render", "info");
    prints_both(&["render", "--help"], "--mode", "--compare");
}

#[test]
fn info_reports_embree_4_and_counts() {
    phongrt().args(["info", "scenes/sphere_lowpoly.obj"]).assert().success().stdout(
        predicate::str::contains("embree: 4.")
            .and(predicate::str::contains("triangles: 120"))
            .and(predicate::str::contains("0 crease, 0 border")),
    );
}

#[test]
fn renders_png_and_exr_in_both_modes() {
    let dir = tempfile::tempdir().unwrap();
    for (mode, ext) in [("flat", "png"), ("phong", "exr")] {
        let out = dir.path().join(format!("s.{ext}"));
        phongrt()
            .args([
                "render",
                "scenes/sphere_lowpoly.obj",
                "--width",
                "64",
                "--height",
                "48",
                "--mode",
                mode,
                "-o",
            ])
            .arg(&out)
            .assert()
            .success()
            .stderr(predicate::str::contains("primary").and(predicate::str::contains("effects:")));
        let img = image::open(&out).unwrap();
        assert_eq!((img.width(), img.height()), (64, 48));
    }
    let out = dir.path().join("cmp.png");
    phongrt()
        .args([
            "render",
            "scenes/sphere_lowpoly.obj",
            "--width",
            "64",
            "--height",
            "64",
            "-q",
            "--compare",
            "-o",
        ])
        .arg(&out)
        .assert()
        .success();
    assert_eq!(image::open(&out).unwrap().width(), 192);
    let out = dir.path().join("toml.png");
    phongrt()
        .args(["render", "scenes/figure1_sphere.toml", "--width", "32", "--height", "32", "-q", "-o"])
        .arg(&out)
        .assert()
        .success();
}

#[test]
fn same_image_whatever_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = Vec::new();
    for t in ["1", "2", "5"] {
        let out = dir.path().join(format!("t{t}.png"));
        phongrt()
            .args([
                "render",
                "scenes/sphere_lowpoly.obj",
                "--width",
                "80",
                "--height",
                "60",
                "--spp",
                "4",
                "-q",
                "--threads",
                t,
                "-o",
            ])
            .arg(&out)
            .assert()
            .success();
        bytes.push(std::fs::read(&out).unwrap());
    }
    assert_eq!(bytes[0], bytes[1]);
    assert_eq!(bytes[0], bytes[2]);
}

/// Bad input (a file): exit status 1.
fn fails_with(args: &[&str], needle: &str) {
    fails_with_code(args, needle, 1)
}

/// Bad usage (a flag's value): exit status 2.
#[test]
fn info_counts_straightened_edges_and_bulge_limit_inf_keeps_them_curved() {
    phongrt().args(["info", "scenes/sliver_coin.obj"]).assert().success().stdout(
        predicate::str::contains("straightened: 720 smooth edges")
            .and(predicate::str::contains("deviation: largest patch offset from its flat triangle 0.3")),
    );
    phongrt()
        .args(["info", "scenes/sliver_coin.obj", "--bulge-limit", "inf"])
        .assert()
        .success()
        .stdout(predicate::str::contains("straightened").not().and(predicate::str::contains("triangle 3.7")));
    fails_usage(&["info", "scenes/sliver_coin.obj", "--bulge-limit", "0"], "--bulge-limit 0");
}

#[test]
fn nan_normals_render_with_a_warning_naming_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("nan.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn nan 0 1\nf 1//1 2//1 3//1\n").unwrap();
    let out = dir.path().join("nan.png");
    let a = phongrt()
        .args([
            "render",
            obj.to_str().unwrap(),
            "--width",
            "32",
            "--height",
            "24",
            "-o",
            out.to_str().unwrap(),
        ])
        .assert()
        .success();
    let err = String::from_utf8(a.get_output().stderr.clone()).unwrap();
    assert!(err.contains("nan.obj:4: 1 `vn` lines with a coordinate that is not a finite number"), "{err}");
    assert!(out.is_file());
}

fn fails_usage(args: &[&str], needle: &str) {
    fails_with_code(args, needle, 2)
}

fn fails_with_code(args: &[&str], needle: &str, code: i32) {
    let a = phongrt().args(args).assert().failure().code(code);
    let err = String::from_utf8(a.get_output().stderr.clone()).unwrap();
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("phongrt: error")).collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(lines[0].contains(needle), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bad_input_is_one_line_and_nonzero() {
    let dir = tempfile::tempdir().unwrap();
    let bad = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p.to_string_lossy().into_owned()
    };
    let out = dir.path().join("o.png").to_string_lossy().into_owned();
    fails_with(&["info", "/no/such/file.obj"], "file.obj: cannot read");
    fails_with(&["render", &bad("m.obj", "v 0 0 0\nv 1 x 0\n"), "-o", &out], "m.obj:2: malformed");
    fails_with(
        &["render", &bad("i.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"), "-o", &out],
        "i.obj:4: vertex index 9 out of range",
    );
    fails_with(
        &["render", &bad("n.obj", "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), "-o", &out],
        "n.obj:1: coordinate",
    );
    fails_with(&["render", &bad("e.obj", "# empty\n"), "-o", &out], "e.obj: no triangles");
    fails_usage(&["render", "scenes/sphere_lowpoly.obj", "--alpha", "2", "-o", &out], "--alpha 2");
    fails_usage(
        &["render", "scenes/sphere_lowpoly.obj", "--width", "0", "-o", &out],
        "--width 0: image size",
    );
    fails_usage(
        &["render", "scenes/sphere_lowpoly.obj", "--eye", "0,0,0", "--look-at", "0,0,0", "-o", &out],
        "eye and look_at are both [0.0, 0.0, 0.0]: the view direction is undefined (eye from --eye, look_at from --look-at)",
    );
    fails_usage(
        &["render", "scenes/sphere_lowpoly.obj", "--object", "nope=flat", "-o", &out],
        "no such object",
    );
    fails_usage(
        &["render", "scenes/sphere_lowpoly.obj", "-o", &dir.path().join("x.bmp").to_string_lossy()],
        "unknown image extension",
    );
    fails_with(
        &["render", &bad("s.toml", "obj = \"../x.obj\"\n[camera]\nfov = -3.0\n"), "-o", &out],
        "camera.fov",
    );
    // A warning, not an error: a missing MTL.
    let p = bad("w.obj", "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    phongrt()
        .args(["info", &p])
        .assert()
        .success()
        .stderr(predicate::str::contains("warning").and(predicate::str::contains("gone.mtl")));
}

#[test]
fn accuracy_report_prints_a_table() {
    phongrt().args(["accuracy", "--rays", "20"]).assert().success().stdout(
        predicate::str::contains("| analytic+polish | f32 | grazing")
            .and(predicate::str::contains("| newton | f64 |")),
    );
}

#[test]
#[ignore = "needs ../shared/corpus"]
fn every_corpus_model_renders_or_is_refused() {
    let corpus = common::corpus_required();
    let dir = tempfile::tempdir().unwrap();
    for entry in std::fs::read_dir(&corpus).unwrap() {
        let d = entry.unwrap().path();
        if !d.is_dir() {
            continue;
        }
        for f in std::fs::read_dir(&d).unwrap() {
            let f = f.unwrap().path();
            if f.extension().is_some_and(|e| e == "obj") {
                let out = dir.path().join("c.png");
                let a = phongrt()
                    .args(["render", "--width", "48", "--height", "48", "-q", "-o"])
                    .arg(&out)
                    .arg(&f)
                    .assert();
                let o = a.get_output();
                let err = String::from_utf8_lossy(&o.stderr);
                assert!(!err.contains("panicked"), "{}: {err}", f.display());
                if o.status.success() {
                    assert!(out.exists());
                } else {
                    assert!(
                        err.lines().any(|l| l.starts_with("phongrt: error")
                            && l.contains(&*f.file_name().unwrap().to_string_lossy())),
                        "{err}"
                    );
                }
            }
        }
    }
}

#[test]
fn bench_writes_csv_table_and_plot() {
    let dir = tempfile::tempdir().unwrap();
    let a = phongrt()
        .args(["bench", "--spheres", "8", "--size", "24", "--max-level", "2", "--out"])
        .arg(dir.path())
        .assert()
        .success()
        .stdout(
            predicate::str::contains("| direct-f32 |")
                .and(predicate::str::contains("| subdiv-cc |"))
                .and(predicate::str::contains("pretess-2")),
        );
    let _ = a;
    let csv = std::fs::read_to_string(dir.path().join("bench.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 1 + 2 + 7, "{csv}");
    // The f64 direct render is the reference: zero error against itself.
    assert!(csv.lines().any(|l| l.contains(",direct-f64,") && l.contains(",0.000e0,0.000e0,0,")), "{csv}");
    // Every row has a positive shaded-render time (the last column).
    assert!(
        csv.lines().skip(1).all(|l| l
            .rsplit(',')
            .next()
            .and_then(|x| x.parse::<f64>().ok())
            .is_some_and(|x| x > 0.0)),
        "{csv}"
    );
    // Packet rates and packet shaded times beside the single-ray ones, for every method.
    assert!(
        csv.starts_with("scene,")
            && csv.lines().next().unwrap().ends_with(",mrays_1t_packets,shaded_ms_packets")
    );
    assert!(
        csv.lines().skip(1).all(|l| {
            let f: Vec<f64> = l.rsplit(',').take(2).filter_map(|x| x.parse().ok()).collect();
            f.len() == 2 && f.iter().all(|x| *x > 0.0)
        }),
        "{csv}"
    );
    let md = std::fs::read_to_string(dir.path().join("bench.md")).unwrap();
    assert!(md.contains("equal-silhouette pre-tessellation") && md.contains("| sphere-"), "{md}");
    assert!(md.contains("equal-depth pre-tessellation"), "{md}");
    for plot in ["bench.png", "bench-scaling.png"] {
        let img = image::open(dir.path().join(plot)).unwrap().to_rgb8();
        assert_eq!(img.width(), 960, "{plot}");
        // Anti-aliased DejaVu text and lines (plotters): many grey levels, where a bitmap font
        // draws only black on white.
        let greys: std::collections::HashSet<u8> = img
            .pixels()
            .filter(|p| p[0] == p[1] && p[1] == p[2] && p[0] > 0 && p[0] < 255)
            .map(|p| p[0])
            .collect();
        assert!(greys.len() > 40, "{plot}: {} grey levels", greys.len());
    }
}

/// The --compare labels are anti-aliased DejaVu Sans on a dark box.
#[test]
fn compare_labels_are_drawn_in_a_real_font() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("c.png");
    phongrt()
        .args([
            "render",
            "scenes/sphere_lowpoly.obj",
            "--compare",
            "-q",
            "--width",
            "240",
            "--height",
            "180",
            "-o",
        ])
        .arg(&out)
        .assert()
        .success();
    let img = image::open(&out).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (720, 180));
    let levels: std::collections::HashSet<u8> =
        (0..30).flat_map(|y| (0..120).map(move |x| (x, y))).map(|(x, y)| img.get_pixel(x, y)[0]).collect();
    assert!(levels.len() > 20, "{} levels in the label", levels.len());
}

#[test]
fn bench_builds_the_levels_asked_for_within_the_triangle_budget() {
    let dir = tempfile::tempdir().unwrap();
    // The 8-segment sphere has 48 triangles: level 3 is 432 of them, over the budget of 200.
    phongrt()
        .args([
            "bench",
            "--spheres",
            "8",
            "--size",
            "16",
            "--levels",
            "3,1",
            "--max-pretess-tris",
            "200",
            "--out",
        ])
        .arg(dir.path())
        .assert()
        .success()
        .stdout(predicate::str::contains("| pretess-1 |").and(predicate::str::contains("pretess-3").not()))
        .stderr(predicate::str::contains("pretess-3 skipped: 432 triangles exceed the budget of 200"));
    let csv = std::fs::read_to_string(dir.path().join("bench.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 1 + 1 + 7, "{csv}");
    phongrt()
        .args(["bench", "--spheres", "8", "--levels", "0", "--out"])
        .arg(dir.path())
        .assert()
        .failure()
        .stderr(predicate::str::contains("--levels"));
}

#[test]
fn bench_robust_mode_builds_and_measures() {
    let dir = tempfile::tempdir().unwrap();
    phongrt()
        .args(["bench", "--spheres", "8", "--size", "16", "--levels", "2", "--robust", "--out"])
        .arg(dir.path())
        .assert()
        .success()
        .stdout(predicate::str::contains("| pretess-2 |").and(predicate::str::contains("| direct-f32 |")));
}

/// The output is checked before anything is loaded or traced: no `effects:` line (printed just
/// before rendering) and no OBJ error, since the OBJ is not even opened.
#[test]
fn a_bad_output_fails_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    for (out, code, needle) in [
        ("/no/such/dir/x.png", 1, "directory /no/such/dir does not exist"),
        ("x.bmp", 2, "-o x.bmp: x.bmp: unknown image extension"),
        ("x", 2, "unknown image extension"),
    ] {
        let a = phongrt().args(["render", "/no/such/mesh.obj", "-o", out]).assert().failure().code(code);
        let err = String::from_utf8(a.get_output().stderr.clone()).unwrap();
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(needle), "{err}");
        assert!(!err.contains("mesh.obj"), "{err}");
    }
    // A directory the process cannot write to (root can write anywhere, so only as non-root).
    let ro = dir.path().join("ro");
    std::fs::create_dir(&ro).unwrap();
    let mut perm = std::fs::metadata(&ro).unwrap().permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut perm, 0o555);
    std::fs::set_permissions(&ro, perm).unwrap();
    if std::fs::write(ro.join("probe"), b"x").is_err() {
        let a = phongrt()
            .args(["render", "scenes/sphere_lowpoly.obj", "-o"])
            .arg(ro.join("x.png"))
            .assert()
            .failure()
            .code(1);
        let err = String::from_utf8(a.get_output().stderr.clone()).unwrap();
        assert!(err.contains("is not writable") && !err.contains("effects:"), "{err}");
    }
}

#[test]
fn a_missing_file_says_its_cause_once_and_a_wrong_type_says_so() {
    let a = phongrt().args(["info", "/no/such/file.obj"]).assert().failure().code(1);
    let err = String::from_utf8(a.get_output().stderr.clone()).unwrap();
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
    let dir = tempfile::tempdir().unwrap();
    let stl = dir.path().join("x.stl");
    std::fs::write(&stl, "solid x\nendsolid x\n").unwrap();
    fails_with(&["info", &stl.to_string_lossy()], "x.stl: not an OBJ file (.stl)");
}

#[test]
fn png_to_stdout_decodes() {
    let a = phongrt()
        .args(["render", "scenes/sphere_lowpoly.obj", "-q", "--width", "24", "--height", "16", "-o", "-"])
        .assert()
        .success();
    let img = image::load_from_memory_with_format(&a.get_output().stdout, image::ImageFormat::Png).unwrap();
    assert_eq!((img.width(), img.height()), (24, 16));
}

/// A full device: non-zero exit and one error line, never "wrote".
#[test]
fn a_full_device_is_an_error_not_a_success() {
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("x.png");
    std::os::unix::fs::symlink("/dev/full", &link).unwrap();
    let a = phongrt()
        .args(["render", "scenes/sphere_lowpoly.obj", "-q", "--width", "24", "--height", "16", "-o"])
        .arg(&link)
        .assert()
        .failure()
        .code(1);
    let err = String::from_utf8(a.get_output().stderr.clone()).unwrap();
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("phongrt: error")).collect();
    assert_eq!(errors.len(), 1, "{err}");
    assert!(errors[0].contains("x.png: cannot write"), "{err}");
}

/// A file-size limit: an error naming it, and the PNG already there still decodes.
#[test]
fn a_file_size_limit_is_an_error_and_keeps_the_old_image() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let bin = assert_cmd::cargo::cargo_bin("phongrt");
    let render = |limit: &str| {
        std::process::Command::new("sh")
            .arg("-c")
            .arg(format!(
                "{limit} exec \"$0\" render scenes/sphere_lowpoly.obj -q --width 200 --height 150 -o \"$1\""
            ))
            .arg(&bin)
            .arg(&out)
            .current_dir(common::root())
            .output()
            .unwrap()
    };
    assert!(render("").status.success());
    let before = std::fs::read(&out).unwrap();
    // One block (512 bytes, or 1024 in some shells): less than the PNG.
    assert!(before.len() > 1024, "{} bytes", before.len());
    let o = render("ulimit -f 1;");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("phongrt: error")).collect();
    assert_eq!(errors.len(), 1, "{err}");
    assert!(errors[0].contains("x.png") && errors[0].contains("file-size limit"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(std::fs::read(&out).unwrap(), before);
    image::open(&out).unwrap();
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "a temporary file was left");
}

#[test]
fn huge_sizes_are_refused_with_the_memory_they_need() {
    let a = phongrt()
        .env("PHONGRT_MAX_MEMORY", "1000000000")
        .args(["render", "/no/such/mesh.obj", "--width", "32768", "--height", "32768", "-o", "x.png"])
        .assert()
        .failure()
        .code(2);
    let err = String::from_utf8(a.get_output().stderr.clone()).unwrap();
    assert!(err.contains("--width 32768 --height 32768: needs about 38.7 GB"), "{err}");
    assert!(err.contains("1.0 GB available") && err.contains("--tile"), "{err}");
}

#[test]
fn threads_beyond_the_machine_start_what_it_has_and_say_so() {
    let cores = std::thread::available_parallelism().unwrap().get();
    let dir = tempfile::tempdir().unwrap();
    phongrt()
        .args(["render", "scenes/sphere_lowpoly.obj", "-q", "--width", "16", "--height", "16", "--threads"])
        .arg("100000")
        .arg("-o")
        .arg(dir.path().join("t.png"))
        .assert()
        .success()
        .stderr(predicate::str::contains(format!(
            "warning: --threads 100000: this machine has {cores} cores; using {cores}"
        )));
}

fn scene_with(dir: &std::path::Path, extra: &str) -> String {
    let p = dir.join("s.toml");
    let obj = common::root().join("scenes/sphere_lowpoly.obj");
    std::fs::write(&p, format!("obj = {obj:?}\n{extra}")).unwrap();
    p.to_string_lossy().into_owned()
}

/// A light too bright for f32 makes inf and NaN radiance: clamped and said, never in the image.
#[test]
fn a_light_too_bright_for_f32_puts_no_nan_or_inf_in_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene_with(
        dir.path(),
        "[[light]]\ntype = \"point\"\nposition = [0.0, 0.0, 1.2]\nintensity = [3e38, 3e38, 3e38]\n",
    );
    let out = dir.path().join("b.exr");
    phongrt()
        .args(["render", &s, "-q", "--width", "48", "--height", "36", "-o"])
        .arg(&out)
        .assert()
        .success()
        .stderr(predicate::str::contains("not a finite f32 number"));
    let img = image::open(&out).unwrap().to_rgb32f();
    assert!(img.as_raw().iter().all(|v| v.is_finite()));
    assert!(img.as_raw().iter().any(|&v| v > 1e20), "the light shows");
}

#[test]
fn max_depth_is_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let s = scene_with(dir.path(), "[render]\nmax_depth = 24\n");
    fails_with(&["render", &s, "-o", "x.png"], "render.max_depth: 24 is more than 16");
}

#[test]
fn help_shows_every_default_examples_and_exit_codes() {
    let a = phongrt().args(["render", "--help"]).assert().success();
    let help = String::from_utf8(a.get_output().stdout.clone()).unwrap();
    // The size and sample defaults are the library's, which the help writes out as text.
    let lib = phongrt_render::RenderSettings::default();
    for needle in [lib.width, lib.height, lib.spp].map(|d| format!("[default: {d}]")) {
        assert!(help.contains(&needle), "{needle:?} missing from render --help:\n{help}");
    }
    for needle in [
        "[default: 35]",
        "[default: phong]",
        "[default: out.png]",
        "[default: all cores]",
        "[default: 0; with --frames: 360]",
        "[default: 0]",
        "[default: 30]",
        "[default: detected: +z for a",
        "Examples:",
        "--tile 3/8",
        "Exit status:",
        "2  bad usage",
    ] {
        assert!(help.contains(needle), "{needle:?} missing from render --help:\n{help}");
    }
    phongrt().arg("--help").assert().success().stdout(predicate::str::contains("1  bad input"));
}

#[test]
fn exr_is_compressed_and_alpha_is_coverage() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a.exr");
    phongrt()
        .args(["render", "scenes/sphere_lowpoly.obj", "-q", "--alpha-channel", "-o"])
        .arg(&out)
        .assert()
        .success();
    // 800x600 RGBA f32 uncompressed is 7.7 MB.
    let size = std::fs::metadata(&out).unwrap().len();
    assert!(size < 2_000_000, "{size} bytes");
    let img = image::open(&out).unwrap().to_rgba32f();
    assert_eq!(img.dimensions(), (800, 600));
    assert_eq!(img.get_pixel(0, 0).0, [0.0; 4], "background: no coverage, premultiplied");
    assert_eq!(img.get_pixel(400, 300).0[3], 1.0, "the sphere covers the centre");
    let png = dir.path().join("a.png");
    phongrt()
        .args([
            "render",
            "scenes/sphere_lowpoly.obj",
            "-q",
            "--alpha-channel",
            "--width",
            "80",
            "--height",
            "60",
            "-o",
        ])
        .arg(&png)
        .assert()
        .success();
    let img = image::open(&png).unwrap();
    assert_eq!(img.color(), image::ColorType::Rgba8);
    let img = img.to_rgba8();
    assert_eq!(img.get_pixel(0, 0).0[3], 0);
    assert_eq!(img.get_pixel(40, 30).0[3], 255);
}

#[test]
fn info_json_parses() {
    let a = phongrt().args(["info", "--json", "scenes/sphere_lowpoly.obj"]).assert().success();
    let v: serde_json::Value = serde_json::from_slice(&a.get_output().stdout).unwrap();
    assert_eq!(v["triangles"], 120);
    assert!(v["embree"]["version"].as_str().unwrap().starts_with("4."));
    assert_eq!(v["meshes"].as_array().unwrap().len(), 1);
}

#[test]
fn completions_name_the_farm_flags() {
    prints_both(&["completions", "bash"], "--tile", "stitch");
}

// Issue 24: `phongrt render ... -o - >&-` exited 0 and printed the success line, but the image
// went nowhere (std reopens a closed fd 1 on /dev/null). Now it is exit 1 with one line, before
// rendering; `> /dev/null`, asked for, still succeeds.
#[test]
fn closed_stdout_is_exit_1() {
    let exe = common::target_dir().join("phongrt");
    let scene = common::root().join("scenes/sphere_lowpoly.obj");
    let render = format!("exec '{}' render '{}' --width 16 --height 16 -o -", exe.display(), scene.display());
    let o = std::process::Command::new("sh").arg("-c").arg(format!("{render} >&-")).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("stdout is closed") && !err.contains("16x16 in"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    let o = std::process::Command::new("sh").arg("-c").arg(format!("{render} > /dev/null")).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

// Issue 24: `-q` still printed the up-axis and effects lines (and the timing line). Quiet
// means warnings and errors only.
#[test]
fn quiet_render_prints_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("q.png");
    let args = ["render", "scenes/sphere_lowpoly.obj", "--width", "16", "--height", "16", "-o"];
    let o = phongrt().args(args).arg(&out).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.contains("up +") && err.contains("effects"), "{err}");
    for flag in ["-q", "--quiet"] {
        let o = phongrt().args(args).arg(&out).arg(flag).output().unwrap();
        assert!(o.status.success());
        assert_eq!(String::from_utf8_lossy(&o.stderr), "", "{flag}");
    }
    let o = phongrt()
        .args(["render", "--compare", "-q", "--width", "16", "--height", "16", "-o"])
        .arg(dir.path().join("c.png"))
        .arg("scenes/sphere_lowpoly.obj")
        .output()
        .unwrap();
    assert!(o.status.success());
    assert_eq!(String::from_utf8_lossy(&o.stderr), "", "--compare -q");
}

// `phongrt info m.obj | head` panicked ("failed printing to stdout: Broken pipe") when the reader
// went away first: now it ends quietly with the status a SIGPIPE gives (128 + 13).
#[test]
fn info_to_a_closed_pipe_ends_quietly_without_a_panic() {
    use std::process::{Command as Std, Stdio};
    let mut child = Std::new(common::target_dir().join("phongrt"))
        .args(["info", "scenes/sphere_lowpoly.obj"])
        .current_dir(common::root())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader is gone before phongrt has loaded the file
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(out.status.code(), Some(141), "{err}");
}

#[test]
fn naming_phong_without_alpha_keeps_the_alpha_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let toml = scene_with(dir.path(), "[[object]]\nname = \"*\"\nmode = \"phong\"\n");
    let render = |args: &[&str]| {
        let out = dir.path().join("out.png");
        phongrt()
            .args(["render", "--width", "32", "--height", "32", "--spp", "1", "-q"])
            .args(args)
            .arg("-o")
            .arg(&out)
            .assert()
            .success();
        std::fs::read(&out).unwrap()
    };
    let at_one = render(&["scenes/sphere_lowpoly.obj", "--object", "*=phong:1"]);
    // The scene file's mode, and --object's, keep --alpha; from flat, --object takes --alpha.
    assert_eq!(render(&[&toml, "--alpha", "1"]), at_one);
    assert_eq!(render(&["scenes/sphere_lowpoly.obj", "--alpha", "1", "--object", "*=phong"]), at_one);
    assert_eq!(
        render(&["scenes/sphere_lowpoly.obj", "--mode", "flat", "--alpha", "1", "--object", "*=phong"]),
        at_one
    );
    // And the alpha does change the image.
    assert_ne!(render(&[&toml]), at_one);
}
