//! What a long job shows while it runs (issue 24, deliverable 4): a warning with the estimated
//! cost before a long render starts, a spinner for a load beyond a second, and a render bar that
//! moves with the samples traced, not with finished blocks. Terminal output is captured through
//! a pseudo-terminal made by util-linux `script`.
mod common;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn phongrt() -> PathBuf {
    common::target_dir().join("phongrt")
}

/// A scene file over the demo sphere with `n` shadow-casting directional lights.
fn many_lights(dir: &Path, n: usize) -> PathBuf {
    let mut text = format!("obj = {:?}\n", common::root().join("scenes/sphere_lowpoly.obj"));
    for i in 0..n {
        let a = i as f32 * 2.4;
        text += &format!(
            "[[light]]\ntype = \"directional\"\ndirection = [{}, 1.0, {}]\nradiance = [0.0001, 0.0001, 0.0001]\nshadows = true\n",
            a.cos(),
            a.sin()
        );
    }
    let p = dir.join("many_lights.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// Run `command` (a shell command line) on a pseudo-terminal for at most `limit`, then kill
/// it: everything it wrote to the terminal.
fn on_terminal(command: &str, limit: Duration) -> String {
    let mut child = Command::new("script")
        .args(["-qfec", command, "/dev/null"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("util-linux script (a pseudo-terminal for the test)");
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() && start.elapsed() < limit {
        std::thread::sleep(Duration::from_millis(50));
    }
    let _ = child.kill();
    // `script` leaves its child running on the terminal's hang-up; end it too.
    let _ = Command::new("pkill").args(["-f", "--", command]).status();
    let out = child.wait_with_output().unwrap();
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn a_long_render_is_warned_with_its_estimate_before_it_starts() {
    let dir = tempfile::tempdir().unwrap();
    let scene = many_lights(dir.path(), 2000);
    let out = dir.path().join("never.png");
    let mut child = Command::new(phongrt())
        .args(["render", scene.to_str().unwrap(), "--width", "64", "--height", "64", "--spp", "65536", "-q"])
        .arg("-o")
        .arg(&out)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Read stderr on a thread, so that a render that never warns fails the test in time.
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            if line.contains("should take about") {
                let _ = tx.send(line);
                return;
            }
        }
    });
    let warning = rx.recv_timeout(Duration::from_secs(60));
    child.kill().unwrap();
    child.wait().unwrap();
    let warning = warning.expect("no cost warning within 60 s of the start");
    // 4096 pixels x 65536 samples x about 2000 shadow rays: hours on any machine.
    assert!(warning.contains("phongrt: warning: ") && warning.contains("268435456 samples"), "{warning}");
    assert!(warning.contains(" h ") || warning.contains(" days "), "{warning}");
    assert!(!out.exists(), "the killed render wrote its output");
}

#[test]
fn a_short_render_is_not_warned() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(phongrt())
        .args(["render", common::root().join("scenes/sphere_lowpoly.obj").to_str().unwrap()])
        .args(["--width", "64", "--height", "64", "-o"])
        .arg(dir.path().join("s.png"))
        .output()
        .unwrap();
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("should take"), "{err}");
}

#[test]
fn a_load_beyond_a_second_shows_a_spinner_on_a_terminal() {
    let dir = tempfile::tempdir().unwrap();
    // A 400 x 400 grid, 320k triangles: about 3 s to load and prepare.
    let n = 400;
    let mut text = String::new();
    for j in 0..=n {
        for i in 0..=n {
            text += &format!("v {i} {j} 0\n");
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            let (b, c) = (a + 1, a + n + 1);
            text += &format!("f {a} {b} {}\nf {a} {} {c}\n", c + 1, c + 1);
        }
    }
    let obj = dir.path().join("grid.obj");
    std::fs::write(&obj, text).unwrap();
    let shown =
        on_terminal(&format!("{} info {}", phongrt().display(), obj.display()), Duration::from_secs(60));
    assert!(shown.contains("loading grid.obj"), "no spinner in: {shown:?}");
    // The same load with stderr not a terminal shows nothing.
    let out = Command::new(phongrt()).arg("info").arg(&obj).output().unwrap();
    assert!(!String::from_utf8_lossy(&out.stderr).contains("loading grid.obj"));
}

#[test]
fn the_render_bar_moves_with_samples_inside_one_block() {
    // One 16x16 block of 65536 samples a pixel: a bar driven by finished blocks would stay at
    // 0% until the end, minutes away.
    let dir = tempfile::tempdir().unwrap();
    let cmd = format!(
        "{} render {} --width 16 --height 16 --spp 65536 --threads 1 -o {}",
        phongrt().display(),
        common::root().join("scenes/sphere_lowpoly.obj").display(),
        dir.path().join("b.png").display()
    );
    let shown = on_terminal(&cmd, Duration::from_secs(6));
    let percents: Vec<u32> =
        shown.split("] ").skip(1).filter_map(|s| s.split('%').next()?.trim().parse().ok()).collect();
    assert!(percents.iter().any(|&p| (1..100).contains(&p)), "no moving bar in: {shown:?}");
}
