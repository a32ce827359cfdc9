//! Renders that share an output path never collide (issue 24): temporary files get a random
//! name created with `O_EXCL`, so tasks with the same process ID (PID 1 in every container's
//! PID namespace) neither fail on each other's temp file nor delete it.
use crate::common;

use std::path::Path;
use std::process::{Command, Stdio};

fn phongrt_path() -> std::path::PathBuf {
    common::target_dir().join("phongrt")
}

fn render_args(seed: u32, out: &Path) -> Vec<String> {
    let scene = common::root().join("scenes/sphere_lowpoly.obj");
    let mut a: Vec<String> = ["render", scene.to_str().unwrap(), "--width", "48", "--height", "48", "-q"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    a.extend(["--seed".into(), seed.to_string(), "-o".into(), out.to_str().unwrap().into()]);
    a
}

/// Temporary files (`.NAME.*.tmp`) left in `dir`.
fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

/// Whether this process may make PID namespaces (`unshare -pf`; root or user namespaces).
fn unshare_permitted() -> bool {
    let st = Command::new("unshare").args(["-pf", "--mount-proc", "true"]).stderr(Stdio::null()).status();
    st.is_ok_and(|s| s.success())
}

#[test]
fn eight_renders_to_one_output_in_separate_pid_namespaces() {
    if !unshare_permitted() {
        println!("skipped: `unshare -pf` is not permitted here");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("same.png");
    let children: Vec<_> = (0..8)
        .map(|i| {
            Command::new("unshare")
                .args(["-pf", "--mount-proc"])
                .arg(phongrt_path())
                .args(render_args(i, &out))
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for c in children {
        let o = c.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "a render failed: {err}");
    }
    let img = image::open(&out).expect("the output is one complete image");
    assert_eq!((img.width(), img.height()), (48, 48));
    assert!(leftovers(dir.path()).is_empty(), "temp files left: {:?}", leftovers(dir.path()));
}

// A temp file of the old name scheme (`.NAME.PID.tmp`) left by a killed run in another PID
// namespace must neither make the render fail nor be deleted by it.
#[test]
fn leftover_temp_file_of_another_process_is_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.png");
    let mut names = vec![".out.png.1.tmp".to_string()];
    names.push(format!(".out.png.{}.tmp", std::process::id()));
    for n in &names {
        std::fs::write(dir.path().join(n), b"someone else's").unwrap();
    }
    // As PID 1 of a new PID namespace where permitted (the name the old scheme would pick).
    let mut cmd = if unshare_permitted() {
        let mut c = Command::new("unshare");
        c.args(["-pf", "--mount-proc"]).arg(phongrt_path());
        c
    } else {
        Command::new(phongrt_path())
    };
    let st = cmd.args(render_args(1, &out)).status().unwrap();
    assert!(st.success());
    assert!(image::open(&out).is_ok());
    for n in &names {
        assert_eq!(std::fs::read(dir.path().join(n)).unwrap(), b"someone else's", "{n} was touched");
    }
}

/// Render a 768² EXR (written for some tens of milliseconds) and send `sig` as soon as its
/// temporary file appears: `(whether the signal was sent, the exit code)`.
fn signal_during_write(dir: &Path, sig: &str) -> (bool, Option<i32>) {
    let out = dir.join("big.exr");
    let scene = common::root().join("scenes/sphere_lowpoly.obj");
    let mut child = Command::new(phongrt_path())
        .args(["render", scene.to_str().unwrap(), "--width", "768", "--height", "768", "-q", "-o"])
        .arg(&out)
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut sent = false;
    while child.try_wait().unwrap().is_none() {
        if !leftovers(dir).is_empty() {
            let st = Command::new("kill").args([&format!("-{sig}"), &child.id().to_string()]).status();
            sent = st.unwrap().success();
            break;
        }
    }
    (sent, child.wait().unwrap().code())
}

// Issue 24: SIGTERM or SIGINT during the write left a hidden `.NAME.PID.tmp` behind (16 of 20
// aimed SIGTERMs, 10 of 10 SIGINTs). Now the temp file is removed and the exit status is
// 128 + the signal; a signal that comes after the rename finds the render done (status 0).
#[test]
fn sigterm_and_sigint_during_the_write_leave_no_temp_file() {
    for (sig, status) in [("TERM", 143), ("INT", 130)] {
        let dir = tempfile::tempdir().unwrap();
        let mut interrupted = 0;
        for _ in 0..8 {
            let (sent, code) = signal_during_write(dir.path(), sig);
            assert!(code == Some(0) || (sent && code == Some(status)), "SIG{sig}: exit {code:?}");
            assert!(leftovers(dir.path()).is_empty(), "SIG{sig}: left {:?}", leftovers(dir.path()));
            interrupted += usize::from(code == Some(status));
            if interrupted > 0 {
                break;
            }
        }
        assert!(interrupted > 0, "SIG{sig} never arrived during a write in 8 tries");
    }
}
