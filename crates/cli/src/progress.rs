//! Progress rendering: an indicatif bar on a terminal, periodic log lines otherwise
//! (CI logs), nothing with `--progress none`.

use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use penumbra_math::progress::Progress;
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// `--progress` modes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Default)]
pub enum ProgressMode {
    /// A bar when stderr is a terminal, log lines otherwise.
    #[default]
    Auto,
    /// Always a bar.
    Bar,
    /// Periodic plain log lines on stderr.
    Log,
    /// Nothing.
    None,
}

/// The CLI's progress sink for one stage.
#[derive(Debug)]
pub struct Reporter {
    label: String,
    bar: Option<ProgressBar>,
    log: Option<Mutex<(Instant, String)>>,
    start: Instant,
}

impl Reporter {
    /// A sink for the stage `label` in `mode`.
    pub fn new(label: &str, mode: ProgressMode) -> Self {
        let mode = match mode {
            ProgressMode::Auto if std::io::stderr().is_terminal() => ProgressMode::Bar,
            ProgressMode::Auto => ProgressMode::Log,
            m => m,
        };
        let bar = (mode == ProgressMode::Bar).then(|| {
            let b = ProgressBar::with_draw_target(Some(1), ProgressDrawTarget::stderr());
            b.set_style(
                ProgressStyle::with_template("{prefix:>10} [{bar:30}] {pos}/{len} {msg} ({elapsed})")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            b.set_prefix(label.to_string());
            b
        });
        let start = Instant::now();
        let log = (mode == ProgressMode::Log).then(|| Mutex::new((start, String::new())));
        Self { label: label.to_string(), bar, log, start }
    }

    /// Finishes and clears the bar.
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

impl Progress for Reporter {
    #[allow(clippy::print_stderr)]
    fn update(&self, stage: &str, done: u64, total: u64) {
        if let Some(b) = &self.bar {
            b.set_length(total.max(1));
            b.set_position(done);
            b.set_message(stage.to_string());
        }
        if let Some(log) = &self.log {
            let mut g = log.lock().unwrap_or_else(|e| e.into_inner());
            // Quiet for the first second (short bakes print nothing), then a line on every
            // stage change and otherwise at most every 2 s.
            let due = g.1 != stage || g.0.elapsed() >= Duration::from_secs(2);
            if self.start.elapsed() >= Duration::from_secs(1) && due {
                eprintln!("[{}] {stage} ({done}/{total})", self.label);
                *g = (Instant::now(), stage.to_string());
            } else if g.1 != stage {
                g.1 = stage.to_string();
            }
        }
    }
}
