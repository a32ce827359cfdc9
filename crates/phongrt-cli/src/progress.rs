//! What the terminal shows while the command works: a spinner for a stage (loading, building)
//! that lasts beyond a second, the render's bar from the renderer's sample counts, and the
//! warning when a render's estimated cost is long. Nothing is drawn with `--quiet` or when
//! stderr is not a terminal; the warning is printed always (it is a warning).

use std::io::IsTerminal;
use std::sync::mpsc::{self, RecvTimeoutError};
use std::thread::JoinHandle;
use std::time::Duration;

use phongrt_render::cost::{human_duration, CostEstimate};

/// How long a stage runs before its spinner appears.
pub(crate) const SPINNER_DELAY: Duration = Duration::from_secs(1);

/// The render time beyond which the estimate is printed as a warning before rendering.
pub(crate) const LONG_RENDER: Duration = Duration::from_secs(600);

/// A stage of work with a spinner on stderr that appears once it has run for
/// [`SPINNER_DELAY`], and goes when the stage is dropped.
pub(crate) struct Stage {
    done: Option<mpsc::Sender<()>>,
    drawer: Option<JoinHandle<()>>,
}

impl Stage {
    /// Start `what` ("loading bunny.obj"); `show` is false for `--quiet`. A terminal is checked
    /// here, so callers need not.
    pub(crate) fn start(what: String, show: bool) -> Stage {
        if !show || !std::io::stderr().is_terminal() {
            return Stage { done: None, drawer: None };
        }
        let (tx, rx) = mpsc::channel::<()>();
        let drawer = std::thread::spawn(move || {
            // Wait out the delay: a stage that ends in time shows nothing.
            if rx.recv_timeout(SPINNER_DELAY) != Err(RecvTimeoutError::Timeout) {
                return;
            }
            let bar = indicatif::ProgressBar::new_spinner();
            bar.set_style(
                indicatif::ProgressStyle::with_template("{spinner} {msg} {elapsed}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
            );
            bar.set_message(what);
            bar.enable_steady_tick(Duration::from_millis(200));
            let _ = rx.recv();
            bar.finish_and_clear();
        });
        Stage { done: Some(tx), drawer: Some(drawer) }
    }
}

impl Drop for Stage {
    fn drop(&mut self) {
        drop(self.done.take());
        if let Some(d) = self.drawer.take() {
            let _ = d.join();
        }
    }
}

/// The warning for a render of `estimates` (one per world rendered) that should take `time` on
/// `threads` threads, when that is longer than [`LONG_RENDER`]; else `None`.
pub(crate) fn long_render_warning(
    what: &str,
    time: Duration,
    estimates: &[CostEstimate],
    threads: usize,
) -> Option<String> {
    let detail: Vec<String> = estimates.iter().map(|e| e.to_string()).collect();
    (time > LONG_RENDER).then(|| {
        format!(
            "{what}: this render should take about {} on {threads} threads: {}; lower --spp, the size or the \
             lights' samples to shorten it",
            human_duration(time),
            detail.join("; then ")
        )
    })
}
