//! A crate outside the workspace that depends on phongrt by path builds and runs with plain
//! `cargo run`, no LD_LIBRARY_PATH: examples/embree_dropin.rs is copied into a fresh crate in a
//! temporary directory (Cargo.toml with `phongrt = { path = <repo> }` and nothing else, no build
//! script) and run there. The crate's target directory is `target/dropin` of this workspace, kept
//! between runs so only the first run builds phongrt and its dependencies from scratch (a few
//! minutes on two cores; seconds afterwards); it cannot be the workspace's own target directory,
//! whose lock the running `cargo test` holds.
//!
//! Needs the network for nothing: `--offline`, with this workspace's Cargo.lock.
use std::path::Path;
use std::process::Command;

mod common;

fn dependent_crate(dir: &Path) {
    std::fs::create_dir_all(dir.join("src")).unwrap();
    let manifest = format!(
        "[package]\nname = \"dropin-user\"\nversion = \"0.1.0\"\nedition = \"2021\"\n\n\
         [dependencies]\nphongrt = {{ path = {:?} }}\n\n[workspace]\n",
        common::root().display().to_string()
    );
    std::fs::write(dir.join("Cargo.toml"), manifest).unwrap();
    std::fs::copy(common::root().join("examples/embree_dropin.rs"), dir.join("src/main.rs")).unwrap();
    std::fs::copy(common::root().join("Cargo.lock"), dir.join("Cargo.lock")).unwrap();
}

fn cargo(dir: &Path, target: &Path, args: &[&str]) -> std::process::Output {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .args(args)
        .current_dir(dir)
        .env("CARGO_TARGET_DIR", target)
        .env_remove("LD_LIBRARY_PATH")
        .env_remove("RUSTFLAGS")
        .output()
        .expect("cannot run cargo")
}

fn numbers_after(line: &str, key: &str, n: usize) -> Vec<f32> {
    let mut w = line.split_whitespace().skip_while(|&x| x != key).skip(1);
    (0..n).map(|_| w.next().unwrap_or_else(|| panic!("no {key} in {line}")).parse().unwrap()).collect()
}

#[test]
fn dependent_crate_runs_the_dropin_example_with_plain_cargo_run() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("dropin-user");
    dependent_crate(&dir);
    let target = common::target_dir().parent().unwrap().join("dropin");
    let run = cargo(&dir, &target, &["run", "--release", "--offline", "--quiet"]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "cargo run failed ({}):\n{stdout}\n{stderr}", run.status);
    println!("{stdout}");
    let line = |i: usize| stdout.lines().find(|l| l.starts_with(&format!("ray {i} "))).unwrap();

    // The top vertex of the octahedron: t = 5 - 1, normal +y.
    assert!(line(0).contains("hit phong"), "{}", line(0));
    assert!((numbers_after(line(0), "t", 1)[0] - 4.0).abs() < 1e-4, "{}", line(0));
    let n = numbers_after(line(0), "normal", 3);
    assert!((n[1] - 1.0).abs() < 1e-4, "{}", line(0));
    // Beside it, the native floor at y = -2: t = 7, face normal +y.
    assert!(line(1).contains("hit triangles"), "{}", line(1));
    assert!((numbers_after(line(1), "t", 1)[0] - 7.0).abs() < 1e-4, "{}", line(1));
    assert_eq!(numbers_after(line(1), "normal", 3), [0.0, 1.0, 0.0]);
    // A face centre: the Phong surface bulges out of the flat face, not beyond the unit sphere,
    // and its normal there is the diagonal (symmetry).
    assert!(line(2).contains("hit phong"), "{}", line(2));
    let t = numbers_after(line(2), "t", 1)[0];
    let flat = 3.0 * 3f32.sqrt() - 1.0 / 3f32.sqrt();
    assert!(t < flat - 0.1 && t > 3.0 * 3f32.sqrt() - 1.0 - 1e-4, "t {t}, flat face at {flat}");
    let n = numbers_after(line(2), "normal", 3);
    assert!(n.iter().all(|c| (c - 1.0 / 3f32.sqrt()).abs() < 1e-3), "{}", line(2));
    assert!(line(3).ends_with("miss"), "{}", line(3));

    // The dependent builds the library only: no C libraries of the workspace's capi crate.
    let built: Vec<_> =
        std::fs::read_dir(target.join("release")).unwrap().flatten().map(|e| e.file_name()).collect();
    for f in &built {
        let f = f.to_string_lossy();
        assert!(!f.starts_with("libphongrt.so") && f != "libphongrt.a", "a dependent built {f}");
    }
    // And pulls in only the library's dependencies (no clap, image, toml, indicatif, tobj).
    let tree = cargo(&dir, &target, &["tree", "--offline", "--edges", "normal", "--prefix", "none"]);
    let tree = String::from_utf8_lossy(&tree.stdout);
    let mut crates: Vec<&str> = tree.lines().filter_map(|l| l.split_whitespace().next()).collect();
    crates.sort_unstable();
    crates.dedup();
    println!("{} crates in the dependent's normal dependency tree (itself included)", crates.len());
    for heavy in ["clap", "image", "toml", "indicatif", "tobj", "serde_json"] {
        assert!(!crates.contains(&heavy), "a dependent pulls in {heavy}:\n{tree}");
    }
    assert!(crates.contains(&"phongrt") && crates.contains(&"glam"));
}
