//! A seeded, count-bounded fuzz run over mutated real files (issue 19): OBJ files from scenes/
//! and ../shared/corpus (when present), their MTL files and the scene TOML files, mutated by
//! byte flips, truncations, line deletions and duplications, hostile numbers and indices,
//! hostile lines (`f 1`, `l`, `p`, BOM, huge faces, `vn 0 0 0`, 1e38 coordinates, ...) and
//! splices. Every input goes through the loader (or the MTL / scene-file parser); every 16th OBJ
//! that loads is rendered at 12x12, flat and Phong. The run fails on any panic, any input that
//! takes more than 10 s (a hang), or any non-finite pixel, and prints the counts.
//!
//! `PHONGRT_FUZZ_SEED` and `PHONGRT_FUZZ_CASES` (default 10000 OBJ inputs) change the run; a
//! failing input is written to target/fuzz-failures/ with its seed and index.
mod common;

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use phongrt::embree::Device;
use phongrt::scene::{load_obj, load_obj_text, LoadOptions};
use phongrt_render::scene_file::SceneFile;
use phongrt_render::{render, Camera, ObjectMode, ObjectSettings, RenderSettings, World};

/// splitmix64: small, seeded, the same sequence everywhere.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn pick<'a, T>(&mut self, v: &'a [T]) -> &'a T {
        &v[self.below(v.len())]
    }
}

const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "-2",
    "3",
    "-4",
    "7",
    "1000000",
    "-1000000",
    "99999999999",
    "4294967296",
    "1e38",
    "-1e38",
    "3.4e38",
    "-3.4e38",
    "1e39",
    "1e-45",
    "1e-38",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "0x10",
    "1.5",
    "",
    "1/2/3/4",
    "//",
    "1//",
    "/1/",
    "-0.0",
    "+5",
    "1e6",
    "1e-6",
];

const LINES: &[&str] = &[
    "f 1",
    "f",
    "f 1 2",
    "l 1 2 3",
    "p 1 2",
    "s off",
    "s 99999999999",
    "s 1",
    "g",
    "o",
    "g a b c",
    "usemtl",
    "usemtl nothere",
    "mtllib nothere.mtl",
    "mtllib",
    "\u{feff}v 0 0 0",
    "v 1e38 1e38 1e38",
    "v -3.4e38 0 3.4e38",
    "v 1e6 0 0",
    "v 0 0 0",
    "v 1 2 3 4 5",
    "vn 0 0 0",
    "vn nan 0 0",
    "vt",
    "vt 0.5",
    "f -1 -2 -3",
    "f 1/1/1 2/2/2 3/3/3",
    "f 1//1 2//1 3//1",
    "f 1 1 1",
    "f 1 2 1 2",
    "f -1 -1 -1 -1",
    "\\",
    "# comment \\",
    "curv 0 1 1 2",
    "v 0 0 0\nv 0 0 0\nv 0 0 0\nf -1 -2 -3",
    "v 1e-30 0 0\nv 0 1e-30 0\nv 0 0 0\nf -1 -2 -3",
];

/// A scene file using every section and key, as a seed beside scenes/*.toml.
const FULL_TOML: &str = r#"obj = "sphere_lowpoly.obj"
crease_angle = 40.0
[camera]
eye = [0.0, 0.5, 3.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 35.0
[render]
width = 64
height = 48
spp = 4
max_depth = 3
background = [0.02, 0.02, 0.03]
ambient = [0.1, 0.1, 0.1]
[ambient_occlusion]
samples = 4
distance = 0.5
[[light]]
type = "directional"
direction = [-0.5, 0.7, 0.6]
radiance = [0.9, 0.9, 0.9]
shadows = true
[[light]]
type = "point"
position = [1.0, 2.0, 3.0]
intensity = [5.0, 5.0, 5.0]
[[light]]
type = "sphere"
center = [0.0, 3.0, 0.0]
radius = 0.5
intensity = [4.0, 4.0, 4.0]
samples = 8
[[object]]
name = "*"
mode = "phong"
alpha = 0.75
kd = [0.5, 0.5, 0.5]
mirror = [0.1, 0.1, 0.1]
transmission = 0.2
ior = 1.5
"#;

/// One mutation of `text`, described in `what`.
fn mutate(rng: &mut Rng, text: &[u8], what: &mut String) -> Vec<u8> {
    let mut t = text.to_vec();
    let rounds = 1 + rng.below(3);
    for _ in 0..rounds {
        let k = rng.below(10);
        what.push_str(&format!("m{k} "));
        match k {
            0 if !t.is_empty() => {
                // Flip bytes.
                for _ in 0..1 + rng.below(4) {
                    let i = rng.below(t.len());
                    t[i] ^= 1 << rng.below(8);
                }
            }
            1 if !t.is_empty() => {
                let n = rng.below(t.len());
                t.truncate(n);
            }
            2..=4 => {
                // Line-level: delete, duplicate or replace a number token, insert a line.
                let mut lines: Vec<Vec<u8>> = t.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
                let i = rng.below(lines.len());
                match k {
                    2 if lines.len() > 1 => {
                        if rng.below(2) == 0 {
                            lines.remove(i);
                        } else {
                            let l = lines[i].clone();
                            lines.insert(rng.below(lines.len()), l);
                        }
                    }
                    3 => {
                        let s = String::from_utf8_lossy(&lines[i]).into_owned();
                        let mut words: Vec<String> = s.split(' ').map(str::to_string).collect();
                        let j = rng.below(words.len());
                        words[j] = (*rng.pick(NUMBERS)).to_string();
                        lines[i] = words.join(" ").into_bytes();
                    }
                    _ => lines.insert(i, rng.pick(LINES).as_bytes().to_vec()),
                }
                t = lines.join(&b'\n');
            }
            5 => {
                // A huge face over the vertices so far (up to 3000 corners).
                let n = 3 + rng.below(3000);
                let mut f = String::from("\nf");
                for _ in 0..n {
                    f += &format!(" {}", 1 + rng.below(64));
                }
                t.extend_from_slice(f.as_bytes());
            }
            6 => {
                let mut b = "\u{feff}".as_bytes().to_vec();
                b.extend_from_slice(&t);
                t = b;
            }
            7 if t.len() > 2 => {
                // Splice: copy a range over another place.
                let (a, b) = (rng.below(t.len()), rng.below(t.len()));
                let len = rng.below(t.len() - a.max(b)).min(4096);
                let chunk = t[a..a + len].to_vec();
                t.splice(b..b, chunk);
            }
            8 => {
                // A far-away vertex, used or not.
                t.extend_from_slice(b"\nv 1e6 -1e6 1e6\n");
                if rng.below(2) == 0 {
                    t.extend_from_slice(b"f -1 -2 -3\n");
                }
            }
            _ => {
                // A long token.
                let n = 1 + rng.below(100_000);
                let at = rng.below(t.len() + 1);
                t.splice(at..at, std::iter::repeat_n(b'7', n));
            }
        }
    }
    t
}

fn inputs(ext: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let root = common::root();
    let mut dirs = vec![root.join("scenes")];
    for d in [root.join("scenes"), common::corpus_quiet().unwrap_or_default()] {
        if let Ok(rd) = std::fs::read_dir(&d) {
            dirs.extend(rd.flatten().map(|e| e.path()).filter(|p| p.is_dir()));
        }
    }
    let mut out = Vec::new();
    for d in dirs {
        let Ok(rd) = std::fs::read_dir(&d) else { continue };
        let mut files: Vec<PathBuf> = rd.flatten().map(|e| e.path()).collect();
        files.sort();
        for f in files {
            // Small and medium files: the run is count-bounded, each input must be quick.
            let small = std::fs::metadata(&f).is_ok_and(|m| m.is_file() && m.len() <= 60_000);
            if small && f.extension().is_some_and(|e| e == ext) {
                out.push((f.clone(), std::fs::read(&f).unwrap()));
            }
        }
    }
    out
}

fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|s| s.parse().ok()).unwrap_or(default)
}

#[derive(Default, Debug)]
struct Counts {
    obj: usize,
    obj_loaded: usize,
    obj_refused: usize,
    via_file: usize,
    mtl: usize,
    toml: usize,
    toml_ok: usize,
    rendered: usize,
    render_refused: usize,
    pixels: usize,
    panics: Vec<String>,
    nan_pixels: usize,
    load_secs: f64,
    render_secs: f64,
}

fn save_failure(seed: u64, i: usize, kind: &str, bytes: &[u8]) -> PathBuf {
    let dir = common::root().join("target/fuzz-failures");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("seed{seed}-{kind}{i}"));
    std::fs::write(&p, bytes).unwrap();
    p
}

fn render_checked(device: &Device, scene: &phongrt::scene::Model, c: &mut Counts) {
    for mode in [ObjectMode::Flat, ObjectMode::Phong { alpha: 0.75 }] {
        let world = match World::from_scene(device, scene, |_, _| ObjectSettings::new(mode)) {
            Ok(w) => w,
            Err(_) => {
                c.render_refused += 1;
                continue;
            }
        };
        let camera = Camera::frame_bounds(world.bounds().0, world.bounds().1, 1.0);
        let settings = RenderSettings { width: 12, height: 12, spp: 1, seed: 0, packets: true };
        match render(&world, &camera, &settings) {
            Ok(out) => {
                c.rendered += 1;
                c.pixels += out.image.pixels.len();
                c.nan_pixels += out.image.pixels.iter().filter(|p| !p.is_finite()).count();
            }
            Err(_) => c.render_refused += 1,
        }
    }
}

fn run(seed: u64, cases: usize, progress: &AtomicU64, stop: &AtomicBool) -> Counts {
    let objs = inputs("obj");
    let mtls = inputs("mtl");
    let mut tomls = inputs("toml");
    tomls.push((PathBuf::from("full.toml"), FULL_TOML.as_bytes().to_vec()));
    assert!(!objs.is_empty() && !tomls.is_empty(), "no seed files found");
    println!("seed files: {} OBJ, {} MTL, {} scene files", objs.len(), mtls.len(), tomls.len());
    let device = Device::new().unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let mut rng = Rng(seed);
    let mut c = Counts::default();
    let opts = LoadOptions::default();
    for i in 0..cases {
        if stop.load(Ordering::Relaxed) {
            break;
        }
        progress.store(i as u64, Ordering::Relaxed);
        let mut what = String::new();
        // An OBJ through the loader (as if at its own path, so its mtllib is found and read).
        // Small files two times in three: the run is count-bounded, each input must be quick.
        let small: Vec<&(PathBuf, Vec<u8>)> = objs.iter().filter(|(_, b)| b.len() <= 20_000).collect();
        let (path, base) =
            if !small.is_empty() && rng.below(3) != 0 { *rng.pick(&small) } else { rng.pick(&objs) };
        let bytes = mutate(&mut rng, base, &mut what);
        let via_file = rng.below(10) == 0;
        let render_this = rng.below(16) == 0;
        let t0 = Instant::now();
        let r = std::panic::catch_unwind(|| {
            if via_file {
                let p = tmp.path().join("fuzz.obj");
                std::fs::write(&p, &bytes).unwrap();
                load_obj(&p, &opts)
            } else {
                load_obj_text(&String::from_utf8_lossy(&bytes), path, &opts)
            }
        });
        c.load_secs += t0.elapsed().as_secs_f64();
        c.obj += 1;
        c.via_file += via_file as usize;
        match r {
            Ok(Ok(scene)) => {
                c.obj_loaded += 1;
                if render_this {
                    let t1 = Instant::now();
                    let before = c.nan_pixels;
                    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        let mut cc = Counts::default();
                        render_checked(&device, &scene, &mut cc);
                        cc
                    }));
                    match r {
                        Ok(cc) => {
                            c.rendered += cc.rendered;
                            c.render_refused += cc.render_refused;
                            c.pixels += cc.pixels;
                            c.nan_pixels += cc.nan_pixels;
                        }
                        Err(_) => c.panics.push(format!("render of obj {i} ({what})")),
                    }
                    c.render_secs += t1.elapsed().as_secs_f64();
                    if c.nan_pixels > before {
                        let p = save_failure(seed, i, "nan-obj", &bytes);
                        eprintln!("non-finite pixels from {} ({what})", p.display());
                    }
                }
            }
            Ok(Err(e)) => {
                c.obj_refused += 1;
                let s = e.to_string();
                assert!(!s.contains('\n') && s.len() < 1000, "obj {i} ({what}): bad message {s:?}");
            }
            Err(_) => {
                let p = save_failure(seed, i, "panic-obj", &bytes);
                c.panics.push(format!("obj {i} ({what}): {}", p.display()));
            }
        }
        // Every 4th round: an MTL and a scene file.
        if i % 4 == 0 {
            if !mtls.is_empty() {
                let (path, base) = rng.pick(&mtls);
                let bytes = mutate(&mut rng, base, &mut what);
                c.mtl += 1;
                let r = std::panic::catch_unwind(|| {
                    phongrt::scene::mtl::parse(&String::from_utf8_lossy(&bytes), path)
                });
                if r.is_err() {
                    let p = save_failure(seed, i, "panic-mtl", &bytes);
                    c.panics.push(format!("mtl {i}: {}", p.display()));
                }
            }
            let (path, base) = rng.pick(&tomls);
            let bytes = mutate(&mut rng, base, &mut what);
            c.toml += 1;
            let r = std::panic::catch_unwind(|| SceneFile::parse(&String::from_utf8_lossy(&bytes), path));
            match r {
                Ok(Ok(_)) => c.toml_ok += 1,
                Ok(Err(e)) => {
                    let s = e.to_string();
                    assert!(!s.contains('\n') && s.len() < 1000, "toml {i}: bad message {s:?}");
                }
                Err(_) => {
                    let p = save_failure(seed, i, "panic-toml", &bytes);
                    c.panics.push(format!("toml {i}: {}", p.display()));
                }
            }
        }
    }
    c
}

#[test]
fn mutated_corpus_files_never_panic_hang_or_give_nan_pixels() {
    let seed = env_or("PHONGRT_FUZZ_SEED", 19);
    let cases = env_or("PHONGRT_FUZZ_CASES", 10_000) as usize;
    // Quiet the default hook: a panic is counted and reported below, not printed per input.
    std::panic::set_hook(Box::new(|_| {}));
    let progress = Arc::new(AtomicU64::new(0));
    let stop = Arc::new(AtomicBool::new(false));
    let done = Arc::new(AtomicUsize::new(0));
    let (p, s, d) = (progress.clone(), stop.clone(), done.clone());
    let worker = std::thread::spawn(move || {
        let c = run(seed, cases, &p, &s);
        d.store(1, Ordering::SeqCst);
        c
    });
    // Watch for a hang: one input taking more than 10 s.
    let limit = Duration::from_secs(10);
    let (mut last, mut since) = (u64::MAX, Instant::now());
    let start = Instant::now();
    while done.load(Ordering::SeqCst) == 0 && !worker.is_finished() {
        std::thread::sleep(Duration::from_millis(50));
        let now = progress.load(Ordering::Relaxed);
        if now != last {
            (last, since) = (now, Instant::now());
        } else if since.elapsed() > limit {
            stop.store(true, Ordering::Relaxed);
            panic!("seed {seed}: input {now} has run for more than {limit:?} (a hang)");
        }
    }
    let c = match worker.join() {
        Ok(c) => c,
        Err(_) => {
            let _ = std::panic::take_hook();
            panic!("seed {seed}: the fuzz run itself panicked (a bad message assertion?)");
        }
    };
    let _ = std::panic::take_hook();
    println!(
        "fuzz seed {seed}: {} OBJ inputs ({} loaded, {} refused with a one-line error, {} read from a file), \
         {} MTL, {} scene files ({} accepted); {} renders ({} refused) of {} pixels; {} panics, 0 hangs, \
         {} non-finite pixels; {:.1} s ({:.1} s loading OBJ, {:.1} s rendering)",
        c.obj,
        c.obj_loaded,
        c.obj_refused,
        c.via_file,
        c.mtl,
        c.toml,
        c.toml_ok,
        c.rendered,
        c.render_refused,
        c.pixels,
        c.panics.len(),
        c.nan_pixels,
        start.elapsed().as_secs_f64(),
        c.load_secs,
        c.render_secs
    );
    assert!(c.panics.is_empty(), "panics: {:?}", c.panics);
    assert_eq!(c.nan_pixels, 0, "non-finite pixels (inputs in target/fuzz-failures/)");
    assert!(c.obj >= 10_000.min(cases) && c.rendered > 0, "{c:?}");
}
