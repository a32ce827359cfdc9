//! The command line's camera and material choices: `--up`, `--orbit`, `--compare` with a scene
//! file's per-object settings, material warnings.
use crate::common;
use crate::common::{phongrt, stderr_of};

#[test]
fn compare_honours_the_scene_files_per_object_mode() {
    let dir = tempfile::tempdir().unwrap();
    let obj = std::fs::canonicalize(common::root().join("scenes/sphere_lowpoly.obj")).unwrap();
    let toml = dir.path().join("s.toml");
    let body = format!("obj = {:?}\n[[object]]\nname = \"*\"\nmode = \"flat\"\n", obj.display().to_string());
    std::fs::write(&toml, body).unwrap();
    let out = dir.path().join("c.png");
    phongrt()
        .args(["render", "--compare", "-q", "--width", "64", "--height", "64", "-o"])
        .arg(&out)
        .arg(&toml)
        .assert()
        .success();
    let img = image::open(&out).unwrap().to_rgb8();
    // The difference panel (right third) below its label is black: both panels are flat.
    let lit = (2 * 64..3 * 64)
        .flat_map(|x| (24..64).map(move |y| (x, y)))
        .filter(|&(x, y)| img.get_pixel(x, y).0.iter().any(|&c| c > 0))
        .count();
    assert_eq!(lit, 0, "the right panel ignored the scene file's mode = \"flat\"");
}

#[test]
fn up_axis_names_and_orbit_are_accepted_and_a_zero_up_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    for up in ["z", "-y", "0,0,1"] {
        phongrt()
            .args(["render", "scenes/sphere_lowpoly.obj", "-q", "--width", "32", "--height", "32"])
            .args(["--up", up, "--orbit", "45", "-o"])
            .arg(&out)
            .assert()
            .success();
    }
    let a = phongrt()
        .args(["render", "scenes/sphere_lowpoly.obj", "--up", "0,0,0", "-o"])
        .arg(&out)
        .assert()
        .failure();
    assert!(stderr_of(&a).contains("--up"), "{}", stderr_of(&a));
    // Without --up the detection is reported.
    let a = phongrt()
        .args(["render", "scenes/mug/mug.obj", "--width", "32", "--height", "32", "-o"])
        .arg(&out)
        .assert()
        .success();
    assert!(stderr_of(&a).contains("up +z"), "{}", stderr_of(&a));
}
