//! The command line's shading choices: `--shading`, `--terminator`, `--ground` and their scene-file
//! keys, and `phongrt smoothness`.
mod common;

use common::{phongrt, stderr_of};

#[test]
fn unknown_shading_and_terminator_names_are_refused_with_the_value() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    for (flag, value) in [("--shading", "smooth"), ("--terminator", "hack")] {
        let a = phongrt()
            .args(["render", "scenes/sphere_lowpoly.obj", flag, value, "-o"])
            .arg(&out)
            .assert()
            .failure();
        let err = stderr_of(&a);
        assert!(err.contains(value) && err.contains(flag), "{err}");
        assert!(!out.exists());
    }
}

#[test]
fn scene_file_shading_terminator_and_ground_keys_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let obj = std::fs::canonicalize(common::root().join("scenes/sphere_lowpoly.obj")).unwrap();
    let cases = [
        ("[render]\nshading = \"smooth\"\n", "render.shading"),
        ("[render]\nterminator = \"hack\"\n", "render.terminator"),
        ("[ground]\nheight = nan\n", "ground.height"),
        ("[ground]\nkd = [0.5, -1.0, 0.5]\n", "ground.kd"),
        ("[ground]\ncolour = [0.5, 0.5, 0.5]\n", "colour"),
    ];
    for (i, (body, key)) in cases.iter().enumerate() {
        let p = dir.path().join(format!("s{i}.toml"));
        std::fs::write(&p, format!("obj = {:?}\n{body}", obj.display().to_string())).unwrap();
        let a = phongrt().args(["render"]).arg(&p).arg("-o").arg(dir.path().join("o.png")).assert().failure();
        let err = stderr_of(&a);
        let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("phongrt: error")).collect();
        assert_eq!(lines.len(), 1, "{err}");
        assert!(lines[0].contains(key) && lines[0].contains(&format!("s{i}.toml")), "{err}");
    }
}

#[test]
fn smoothness_tells_flat_facets_from_the_smooth_phong_default() {
    let dir = tempfile::tempdir().unwrap();
    let steps = |mode: &str| {
        let img = dir.path().join(format!("{mode}.png"));
        phongrt()
            .args([
                "render",
                "scenes/sphere_lowpoly.obj",
                "--mode",
                mode,
                "--width",
                "400",
                "--height",
                "400",
            ])
            .args(["--spp", "9", "--quiet", "-o"])
            .arg(&img)
            .assert()
            .success();
        let a = phongrt().arg("smoothness").arg(&img).assert().success();
        let out = String::from_utf8_lossy(&a.get_output().stdout).into_owned();
        println!("{mode}: {out}");
        out.split_whitespace().next().unwrap().parse::<usize>().unwrap()
    };
    let (flat, phong) = (steps("flat"), steps("phong"));
    assert!(flat > 100 && phong <= 5, "flat {flat}, phong {phong}");
}

#[test]
fn ground_and_every_rule_render() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("g.png");
    for (shading, terminator) in [("adapted", "lift"), ("paper", "plain"), ("interpolated", "band")] {
        phongrt()
            .args(["render", "scenes/sphere_lowpoly.obj", "--ground", "--width", "64", "--height", "64"])
            .args(["--shading", shading, "--terminator", terminator, "--quiet", "-o"])
            .arg(&out)
            .assert()
            .success();
        assert!(out.exists());
    }
    let a = phongrt().args(["smoothness", "/no/such.png"]).assert().failure();
    assert!(stderr_of(&a).contains("/no/such.png"));
}
