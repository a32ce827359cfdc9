//! The `phongrt` command.

use std::io::Write;
use std::process::ExitCode;

use anyhow::Context;
use clap::Parser;

use cli::{Cli, Command, StitchArgs};
use phongrt::embree;
use phongrt_render as render;
use phongrt_render::stitch::StitchError;

/// A mistake on the command line (a flag or its value): exit status 2. Everything else (an
/// input that cannot be read or is invalid, an output that cannot be written) is status 1.
#[derive(Debug)]
pub(crate) struct Usage(pub(crate) String);

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// Return early with a usage error (exit status 2).
macro_rules! usage {
    ($($t:tt)*) => { return Err(anyhow::Error::new(Usage(format!($($t)*)))) };
}

/// Exit status for bad input (files read or written).
const EXIT_INPUT: u8 = 1;
/// Exit status for bad usage (flags and their values).
const EXIT_USAGE: u8 = 2;

mod bench_cmd;
mod cli;
mod info;
mod job;
mod load;
mod plan;
mod progress;
mod render_cmd;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                e.exit();
            }
            // One line: clap's first line (it names the flag and the value).
            let text = e.to_string();
            let line = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("bad usage");
            eprintln!("phongrt: error: {}", line.trim_start_matches("error: "));
            return ExitCode::from(EXIT_USAGE);
        }
    };
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of our stdout went away (`phongrt info m.obj | head`): end quietly with
        // the status a SIGPIPE would give.
        Err(e)
            if e.chain().any(|c| {
                c.downcast_ref::<std::io::Error>().is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
            }) =>
        {
            ExitCode::from(128 + 13)
        }
        Err(e) => {
            eprintln!("phongrt: error: {}", one_line(&e));
            if e.chain().any(|c| c.is::<Usage>()) {
                ExitCode::from(EXIT_USAGE)
            } else {
                ExitCode::from(EXIT_INPUT)
            }
        }
    }
}

/// The context chain on one line, most general first, without repeating a cause that an outer
/// message already quotes.
fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for c in e.chain() {
        let s = c.to_string().replace('\n', " ");
        if line.contains(&s) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&s);
    }
    line
}

fn run(cli: Cli) -> anyhow::Result<()> {
    // SIGTERM, SIGINT and SIGHUP remove our temporary files and exit with 128 + the signal.
    phongrt_render::temp_file::remove_on_signals().context("cannot watch for signals")?;
    // Every thread that traces rays runs in the float mode Embree asks for, not only the
    // renderer's own pool: rayon's global pool (the bench's multi-threaded rays) too, and the
    // command itself runs on it (the single-ray paths: the bench's one-thread rays, profiles).
    // Its threads get the main thread's 8 MiB stack.
    embree::thread_pool_builder()
        .stack_size(8 << 20)
        .build_global()
        .context("cannot start the thread pool")?;
    on_global_pool(move || run_command(cli))
}

/// Run `f` on a thread of rayon's global pool and wait for it (`rayon::scope` called from
/// outside the pool runs its closure on one of the pool's threads).
fn on_global_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    rayon::scope(|_| f())
}

fn run_command(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(args) => render_cmd::render_cmd(*args),
        Command::Info(args) => info::info_cmd(args),
        Command::Stitch(args) => stitch_cmd(args),
        Command::Bench(args) => bench_cmd::bench_cmd(args),
        Command::Smoothness(args) => {
            let img = image::open(&args.image)
                .with_context(|| format!("{}: cannot read as an image", args.image.display()))?
                .to_rgb8();
            let s = render::smoothness::shading_steps(
                img.as_raw(),
                img.width(),
                img.height(),
                args.threshold,
                args.margin,
            );
            print_stdout(&format!(
                "{} steps, largest {:.1}/255, {} interior pixels\n",
                s.count, s.largest, s.interior
            ))
        }
        Command::Completions(args) => {
            use clap::CommandFactory;
            let mut out = Vec::new();
            clap_complete::generate(args.shell, &mut Cli::command(), "phongrt", &mut out);
            print_stdout(&String::from_utf8_lossy(&out))
        }
        Command::Accuracy(args) => {
            if args.rays == 0 {
                usage!("--rays 0: must be at least 1");
            }
            print_stdout(&phongrt::phong::accuracy::report(args.rays, args.seed).to_string())
        }
    }
}

/// Write `text` to stdout and flush it: a failure (a closed pipe, a full disk) is an error.
pub(crate) fn print_stdout(text: &str) -> anyhow::Result<()> {
    let mut stdout = std::io::stdout().lock();
    stdout.write_all(text.as_bytes()).and_then(|_| stdout.flush()).context("cannot write to stdout")
}

/// Assemble tiles into one image (see [`phongrt_render::stitch`]).
fn stitch_cmd(args: StitchArgs) -> anyhow::Result<()> {
    match render::stitch::stitch(&args.output, &args.tiles) {
        Ok(s) => {
            eprintln!(
                "phongrt: wrote {} ({}x{} from {} tiles)",
                args.output.display(),
                s.width,
                s.height,
                s.tiles
            );
            Ok(())
        }
        Err(e @ StitchError::Refused(_)) => Err(Usage(e.to_string()).into()),
        Err(StitchError::Image(e)) => Err(e.into()),
    }
}
