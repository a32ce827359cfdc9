//! `phongrt bench`: the measurement over spheres and models, its tables and plots, with a progress bar.

use std::path::Path;

use anyhow::Context;

use crate::cli;
use crate::load::load;
use crate::Usage;
use phongrt::scene::{self, LoadOptions};
use phongrt_render::image_out;

use phongrt_cli::bench::{
    bench_scene, equal_depth_summary, equal_silhouette_summary, mem_total, plot, plot_scaling, to_csv,
    to_markdown, BenchMethod, BenchOptions, BenchRow,
};
use phongrt_cli::profile::Profile;

pub(crate) fn bench_cmd(args: cli::BenchArgs) -> anyhow::Result<()> {
    let (methods, scenes) = resolve(&args)?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("{}: cannot create", args.out.display()))?;
    let bar = if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        indicatif::ProgressBar::new((scenes.len() * (methods.len() + 1)) as u64)
    } else {
        indicatif::ProgressBar::hidden()
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let mut rows = Vec::new();
    for (name, m) in &scenes {
        let opts = BenchOptions {
            width: args.size,
            height: args.size,
            max_pretess_tris: args.max_pretess_tris,
            robust: args.robust,
        };
        rows.extend(bench_scene(name, m, &methods, &opts, |msg| {
            if msg.contains("skipped") {
                bar.suspend(|| eprintln!("phongrt: {msg}"));
            }
            bar.set_message(msg.to_string());
            bar.inc(1);
        })?);
    }
    let mut profiles = Vec::new();
    for (name, m) in &scenes {
        bar.set_message(format!("{name}: profile"));
        for k in [1, 8] {
            profiles.extend(phongrt_cli::profile::profile_scene(name, m, args.size, args.size, k)?);
        }
    }
    bar.finish_and_clear();
    write_report(&args.out, &rows, &profiles)
}

/// A scene of the bench: its name and its mesh.
type NamedMesh = (String, scene::Mesh);

/// The methods and scenes `args` ask for, every value checked.
fn resolve(args: &cli::BenchArgs) -> anyhow::Result<(Vec<BenchMethod>, Vec<NamedMesh>)> {
    if !(8..=4096).contains(&args.size) {
        usage!("--size {} is not in 8..=4096", args.size);
    }
    if let Some(l) = args.levels.iter().find(|&&l| !(1..=4096).contains(&l)) {
        usage!("--levels {l}: each level must be in 1..=4096");
    }
    let mut levels = args.levels.clone();
    levels.sort_unstable();
    levels.dedup();
    let methods: Vec<BenchMethod> = BenchMethod::all_with_levels(&levels)
        .into_iter()
        .filter(|m| !matches!(m, BenchMethod::Pretessellated(l) if *l > args.max_level))
        .collect();
    let mut scenes: Vec<NamedMesh> = Vec::new();
    for &s in &args.spheres {
        if !(3..=4096).contains(&s) {
            usage!("--spheres {s}: segments is not in 3..=4096");
        }
        let m = scene::uv_sphere(s, (s / 2).max(2), 1.0);
        scenes.push((format!("sphere-{}", m.indices.len()), m));
    }
    for p in &args.models {
        let s = load(p, &LoadOptions::default(), true)?;
        let name = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let m = s.meshes.into_iter().next().with_context(|| format!("{}: no mesh", p.display()))?;
        scenes.push((name, m));
    }
    Ok((methods, scenes))
}

/// Write bench.csv, bench.md, bench.png and bench-scaling.png into `out`, and print the tables.
fn write_report(out: &Path, rows: &[BenchRow], profiles: &[Profile]) -> anyhow::Result<()> {
    let mem = mem_total();
    let md = format!(
        "{}\n{}\nPre-tessellation that matches direct Phong's silhouette ({ram} GB of RAM here):\n\n{}\n\
         Pre-tessellation that matches direct Phong's hit distances (median relative error, {ram} GB of RAM here):\n\n{}",
        to_markdown(rows),
        phongrt_cli::profile::to_markdown(profiles),
        equal_silhouette_summary(rows, mem),
        equal_depth_summary(rows, mem),
        ram = mem.map_or("?".to_string(), |m| format!("{:.1}", m as f64 / 1e9)),
    );
    std::fs::write(out.join("bench.csv"), to_csv(rows))?;
    std::fs::write(out.join("bench.md"), &md)?;
    save_plot(&plot(rows)?, &out.join("bench.png"))?;
    save_plot(&plot_scaling(rows)?, &out.join("bench-scaling.png"))?;
    crate::print_stdout(&md)?;
    eprintln!("phongrt: wrote {}/bench.csv, bench.md, bench.png, bench-scaling.png", out.display());
    Ok(())
}

/// A plot saved as PNG through image 0.25's encoder, written with `write_atomically`.
pub(crate) fn save_plot(img: &image::RgbImage, path: &Path) -> anyhow::Result<()> {
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .with_context(|| format!("{}: cannot encode PNG", path.display()))?;
    Ok(image_out::write_atomically(path, &bytes)?)
}
