//! `stitch` refuses what would give a wrong image or lose work (issue 24).
mod common;

use std::path::{Path, PathBuf};

use assert_cmd::Command;

fn phongrt() -> Command {
    Command::new(common::target_dir().join("phongrt"))
}

/// Render tile `i` of `n` of a small frame into `dir/t_i.png`.
fn tile(dir: &Path, i: u32, n: u32) -> PathBuf {
    let out = dir.join(format!("t_{i}.png"));
    phongrt()
        .args(["render", "scenes/sphere_lowpoly.obj", "--width", "32", "--height", "24", "-q"])
        .args(["--tile", &format!("{i}/{n}"), "-o"])
        .arg(&out)
        .current_dir(common::root())
        .assert()
        .success();
    out
}

// `phongrt stitch tiles/t_0.png tiles/t_*.png` overwrote the first tile.
#[test]
fn stitch_refuses_an_output_that_is_one_of_its_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let tiles: Vec<PathBuf> = (0..2).map(|i| tile(dir.path(), i, 2)).collect();
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
    let tiles: Vec<PathBuf> = (0..2).map(|i| tile(dir.path(), i, 2)).collect();
    let link = dir.path().join("out.png");
    std::os::unix::fs::symlink(&tiles[1], &link).unwrap();
    let before = std::fs::read(&tiles[1]).unwrap();
    let out = phongrt().arg("stitch").arg(&link).args(&tiles).assert().failure().get_output().clone();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("t_1.png") && err.contains("same file"), "{err}");
    assert_eq!(std::fs::read(&tiles[1]).unwrap(), before, "the tile was changed");
}
