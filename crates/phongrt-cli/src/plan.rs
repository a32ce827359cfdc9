//! Every render option that needs no mesh, resolved and checked once before any work: size, samples, window, frames, threads, output and stats.

use std::path::{Path, PathBuf};

use crate::cli::{self, RenderArgs};
use crate::Usage;
use phongrt_render::image_out::{self, ImageFormat};
use phongrt_render::scene_file::SceneFile;
use phongrt_render::{self as render, Window};

/// Where the image goes.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Output {
    /// `-o -`: PNG on stdout.
    Stdout,
    File(PathBuf),
}

impl Output {
    pub(crate) fn name(&self) -> String {
        match self {
            Output::Stdout => "-".to_string(),
            Output::File(p) => p.display().to_string(),
        }
    }
}

/// Where `--stats` goes.
#[derive(Clone, Debug)]
pub(crate) enum StatsTarget {
    /// `--stats json`: stdout, or stderr when the image goes to stdout.
    Print,
    File(PathBuf),
}

/// The frames to render: `count` frames of an orbit of `orbit_deg`, of which `only` (or all).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Frames {
    pub(crate) count: u32,
    pub(crate) only: Option<u32>,
    pub(crate) orbit_deg: f32,
}

/// Every render option, resolved and checked once before any work.
#[derive(Clone, Debug)]
pub(crate) struct RenderPlan {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) spp: u32,
    pub(crate) seed: u64,
    pub(crate) threads: Option<usize>,
    /// The window of the frame to render (`None` = all of it).
    pub(crate) crop: Option<Window>,
    pub(crate) frames: Option<Frames>,
    pub(crate) output: Output,
    pub(crate) format: ImageFormat,
    pub(crate) stats: Option<StatsTarget>,
    pub(crate) alpha: bool,
}

impl RenderPlan {
    /// (frame index, output) for every frame to render; index `None` without `--frames`.
    pub(crate) fn outputs(&self) -> Vec<(Option<u32>, Output)> {
        let Some(f) = self.frames else {
            return vec![(None, self.output.clone())];
        };
        let ks: Vec<u32> = match f.only {
            Some(k) => vec![k],
            None => (0..f.count).collect(),
        };
        ks.into_iter()
            .map(|k| {
                let out = match &self.output {
                    Output::Stdout => Output::Stdout,
                    Output::File(p) => Output::File(frame_path(p, k)),
                };
                (Some(k), out)
            })
            .collect()
    }
}

/// `out.png` -> `out_0007.png`.
pub(crate) fn frame_path(p: &Path, k: u32) -> PathBuf {
    let stem = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = p.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    p.with_file_name(format!("{stem}_{k:04}{ext}"))
}

/// `X0,Y0,X1,Y1` inside a `w x h` frame.
pub(crate) fn parse_crop(s: &str, w: u32, h: u32) -> anyhow::Result<Window> {
    let v: Option<Vec<u32>> = s.split(',').map(|t| t.trim().parse().ok()).collect();
    let Some(v) = v.filter(|v| v.len() == 4) else {
        usage!("--crop {s:?}: expected four pixel bounds X0,Y0,X1,Y1 (whole numbers)");
    };
    let (x0, y0, x1, y1) = (v[0], v[1], v[2], v[3]);
    if !(x0 < x1 && x1 <= w && y0 < y1 && y1 <= h) {
        usage!("--crop {s}: not a window of the {w}x{h} image (need 0 <= X0 < X1 <= {w} and 0 <= Y0 < Y1 <= {h})");
    }
    Ok(Window { x0, y0, x1, y1, full_width: w, full_height: h })
}

/// `I/N`: the I-th of N bands of whole rows of a `w x h` frame.
pub(crate) fn parse_tile(s: &str, w: u32, h: u32) -> anyhow::Result<Window> {
    let parsed = s
        .split_once('/')
        .and_then(|(i, n)| Some((i.trim().parse::<u32>().ok()?, n.trim().parse::<u32>().ok()?)));
    let Some((i, n)) = parsed else {
        usage!("--tile {s:?}: expected I/N with whole numbers, 0 <= I < N");
    };
    if n == 0 {
        usage!("--tile {s}: N must be at least 1");
    }
    if i >= n {
        usage!("--tile {s}: index {i} is out of range (0..={} for {n} tiles)", n - 1);
    }
    if n > h {
        usage!("--tile {s}: {n} tiles is more than the image's {h} rows");
    }
    let band = |k: u32| (k as u64 * h as u64 / n as u64) as u32;
    Ok(Window { x0: 0, y0: band(i), x1: w, y1: band(i + 1), full_width: w, full_height: h })
}

/// The memory this machine (or `PHONGRT_MAX_MEMORY`, in bytes) lets a render use: the same
/// budget as a stitch's.
pub(crate) use phongrt_render::stitch::memory_budget;

pub(crate) fn gb(bytes: u64) -> String {
    format!("{:.1} GB", bytes as f64 / 1e9)
}

/// Resolve and check every option that needs no mesh: all of it happens before loading.
pub(crate) fn plan(args: &RenderArgs, sf: Option<&SceneFile>) -> anyhow::Result<RenderPlan> {
    check_flag_ranges(args)?;
    let default = render::RenderSettings::default();
    let width = args.width.or(sf.and_then(|s| s.render.width)).unwrap_or(default.width);
    let height = args.height.or(sf.and_then(|s| s.render.height)).unwrap_or(default.height);
    let spp = args.spp.or(sf.and_then(|s| s.render.spp)).unwrap_or(default.spp);
    let f = &args.farm;

    // Compute the window: a crop, a tile, or the whole frame.
    let crop = match (&f.crop, &f.tile) {
        (Some(_), Some(_)) => usage!("--crop and --tile: give one or the other"),
        (Some(c), None) => Some(parse_crop(c, width, height)?),
        (None, Some(t)) => Some(parse_tile(t, width, height)?),
        (None, None) => None,
    };
    if args.compare && (crop.is_some() || f.frames.is_some() || f.alpha_channel) {
        usage!("--compare renders one whole frame: it does not combine with --crop, --tile, --frames or --alpha-channel");
    }

    // Compute the frames and the threads.
    let frames = plan_frames(f)?;
    let threads = plan_threads(args.threads)?;

    // Check the output (and the stats file) before any work.
    let output =
        if args.output.as_os_str() == "-" { Output::Stdout } else { Output::File(args.output.clone()) };
    let format = check_output(&output, frames)?;
    let stats = plan_stats(f.stats.as_deref())?;

    // Estimate the memory before starting.
    let pixels = crop.map_or(width as u64 * height as u64, |c| c.width() as u64 * c.height() as u64)
        * if args.compare { 3 } else { 1 };
    let need = render::memory_estimate(pixels);
    if let Some(budget) = memory_budget() {
        if need > budget {
            usage!(
                "--width {width} --height {height}: needs about {} of memory, more than the {} available; \
                 render it in tiles (--tile I/N) and stitch them",
                gb(need),
                gb(budget)
            );
        }
    }
    Ok(RenderPlan {
        width,
        height,
        spp,
        seed: f.seed,
        threads,
        crop,
        frames,
        output,
        format,
        stats,
        alpha: f.alpha_channel,
    })
}

/// The ranges of --alpha, --width, --height, --spp, --fov and --up (the scene file's values
/// are checked when it is read).
pub(crate) fn check_flag_ranges(args: &RenderArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        (0.0..=1.0).contains(&args.alpha),
        Usage(format!("--alpha {} is not in [0, 1]", args.alpha))
    );
    for (flag, v) in [("--width", args.width), ("--height", args.height)] {
        if let Some(v) = v {
            if v == 0 || v > 1 << 15 {
                usage!("{flag} {v}: image size is out of range (1..=32768 per side)");
            }
        }
    }
    if let Some(s) = args.spp {
        if s == 0 || s > 1 << 16 {
            usage!("--spp {s}: samples per pixel is out of range (1..=65536)");
        }
    }
    if let Some(f) = args.camera.fov {
        if !(f > 0.0 && f < 180.0) {
            usage!("--fov {f}: the field of view is not in (0, 180) degrees");
        }
    }
    if let Some(u) = args.camera.up {
        if u.length_squared() == 0.0 {
            usage!("--up 0,0,0: the up vector must not be zero");
        }
    }
    Ok(())
}

/// --frames, --frame and --orbit.
pub(crate) fn plan_frames(f: &cli::FarmArgs) -> anyhow::Result<Option<Frames>> {
    if let Some(deg) = f.orbit.filter(|d| !d.is_finite()) {
        usage!("--orbit {deg}: not a finite number of degrees");
    }
    match f.frames {
        None => Ok(None),
        Some(0) => usage!("--frames 0: must be at least 1"),
        Some(n) => {
            if let Some(k) = f.frame {
                if k >= n {
                    usage!("--frame {k}: out of range for --frames {n} (0..={})", n - 1);
                }
            }
            Ok(Some(Frames { count: n, only: f.frame, orbit_deg: f.orbit.unwrap_or(360.0) }))
        }
    }
}

/// --threads: at least 1, at most what the machine has (more is a warning).
pub(crate) fn plan_threads(threads: Option<usize>) -> anyhow::Result<Option<usize>> {
    match threads {
        Some(0) => usage!("--threads 0: must be at least 1 (leave it out to use every core)"),
        Some(t) => {
            let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
            if t > cores {
                eprintln!("phongrt: warning: --threads {t}: this machine has {cores} cores; using {cores}");
                Ok(Some(cores))
            } else {
                Ok(Some(t))
            }
        }
        None => Ok(None),
    }
}

/// The output's format, once it is known to be writable (the first frame's file, with
/// --frames); stdout takes one PNG and must not be a terminal.
pub(crate) fn check_output(output: &Output, frames: Option<Frames>) -> anyhow::Result<ImageFormat> {
    match output {
        Output::Stdout => {
            if std::io::IsTerminal::is_terminal(&std::io::stdout()) {
                usage!("-o -: stdout is a terminal; redirect it to a file or a pipe");
            }
            if image_out::stdout_is_closed() {
                // Bad input (exit 1), found before any work.
                return Err(image_out::ImageError::StdoutClosed.into());
            }
            if frames.is_some_and(|f| f.only.is_none() && f.count > 1) {
                usage!(
                    "-o -: {} frames cannot all go to stdout; pick one with --frame I",
                    frames.map_or(0, |f| f.count)
                );
            }
            Ok(ImageFormat::Png)
        }
        Output::File(p) => {
            let fmt = ImageFormat::from_path(p).map_err(|e| Usage(format!("-o {}: {e}", p.display())))?;
            let first = match frames {
                Some(fr) => frame_path(p, fr.only.unwrap_or(0)),
                None => p.clone(),
            };
            image_out::check_writable(&first)?;
            Ok(fmt)
        }
    }
}

/// --stats: `json` (printed) or a file in an existing directory.
pub(crate) fn plan_stats(stats: Option<&str>) -> anyhow::Result<Option<StatsTarget>> {
    match stats {
        None => Ok(None),
        Some("json") => Ok(Some(StatsTarget::Print)),
        Some(file) => {
            let p = PathBuf::from(file);
            let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
            if !dir.is_dir() {
                usage!("--stats {file}: directory {} does not exist", dir.display());
            }
            Ok(Some(StatsTarget::File(p)))
        }
    }
}
