//! The `phongrt` command: render, info, accuracy; every bad input a one-line error and a
//! non-zero exit, never a panic.
use assert_cmd::Command;
use predicates::prelude::*;

fn phongrt() -> Command {
    Command::cargo_bin("phongrt").unwrap()
}

#[test]
fn help_reads_well() {
    phongrt()
        .arg("--help")
        .assert()
        .success()
        .stdout(predicate::str::contains("render").and(predicate::str::contains("info")));
    phongrt()
        .args(["render", "--help"])
        .assert()
        .success()
        .stdout(predicate::str::contains("--mode").and(predicate::str::contains("--compare")));
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
                "--quiet",
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

fn fails_with(args: &[&str], needle: &str) {
    let a = phongrt().args(args).assert().failure().code(1);
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
    fails_with(&["render", "scenes/sphere_lowpoly.obj", "--alpha", "2", "-o", &out], "--alpha 2");
    fails_with(&["render", "scenes/sphere_lowpoly.obj", "--width", "0", "-o", &out], "image size");
    fails_with(
        &["render", "scenes/sphere_lowpoly.obj", "--eye", "0,0,0", "--look-at", "0,0,0", "-o", &out],
        "eye and look_at are both [0.0, 0.0, 0.0]: the view direction is undefined (eye from --eye, look_at from --look-at)",
    );
    fails_with(
        &["render", "scenes/sphere_lowpoly.obj", "--object", "nope=flat", "-o", &out],
        "no such object",
    );
    fails_with(
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
fn every_corpus_model_renders_or_is_refused() {
    let corpus = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/corpus");
    if !corpus.is_dir() {
        println!("skipped: ../shared/corpus is absent");
        return;
    }
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
    assert_eq!(csv.lines().count(), 1 + 1 + 2 + 6, "{csv}");
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
    let md = std::fs::read_to_string(dir.path().join("bench.md")).unwrap();
    assert!(md.contains("equal-silhouette pre-tessellation") && md.contains("| sphere-"), "{md}");
    assert!(md.contains("equal-depth pre-tessellation"), "{md}");
    assert!(image::open(dir.path().join("bench.png")).is_ok());
    assert!(image::open(dir.path().join("bench-scaling.png")).is_ok());
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
    assert_eq!(csv.lines().count(), 1 + 1 + 1 + 6, "{csv}");
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
