//! A test hook: `LIDARSIM_TEST_HOLD_AT_PULSE=N` makes a run wait, once N
//! pulse slots are done, until it is stopped (Ctrl-C, a stream closed) or
//! the file `LIDARSIM_TEST_HOLD_UNTIL` names appears, after printing
//! "holding after K pulses" to standard error — so that tests interrupt a
//! run, kill its worker or look at other threads at a known point instead
//! of after a guessed time, as the command line's tests do. A hold lasts
//! at most `LIDARSIM_TEST_HOLD_SECONDS` (120 by default), and a hold that
//! no one ended stops the run with an error: a test that fails to end it
//! (another Python thread that should release it but never gets the GIL,
//! say) fails rather than hangs or passes.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Where and how long a run is held.
#[derive(Debug)]
pub struct Hold {
    at: u64,
    until: Option<PathBuf>,
    longest: Duration,
    /// Set once the run has been held (a run is held once).
    held: AtomicBool,
}

impl Hold {
    /// The hold the environment asks for, if any.
    pub fn from_env() -> Option<Self> {
        let at = std::env::var("LIDARSIM_TEST_HOLD_AT_PULSE")
            .ok()?
            .parse()
            .ok()?;
        let seconds = std::env::var("LIDARSIM_TEST_HOLD_SECONDS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(120.0);
        Some(Self {
            at,
            until: std::env::var_os("LIDARSIM_TEST_HOLD_UNTIL").map(PathBuf::from),
            longest: Duration::from_secs_f64(seconds),
            held: AtomicBool::new(false),
        })
    }

    /// Whether `done` pulse slots reach the hold and the run was not held
    /// yet.
    pub fn due(&self, done: u64) -> bool {
        done >= self.at && !self.held.load(Ordering::SeqCst)
    }

    /// Holds the run once `done` pulse slots are done (the first time
    /// only), until `released()` says so or the release file appears;
    /// `look` is called every 2 ms meanwhile (to look at Python's
    /// signals). Returns the error of a hold that lasted its longest
    /// without being ended.
    pub fn wait(
        &self,
        done: u64,
        released: impl Fn() -> bool,
        look: impl Fn(),
    ) -> Result<(), HoldTimedOut> {
        if !self.due(done) || self.held.swap(true, Ordering::SeqCst) {
            return Ok(());
        }
        eprintln!("holding after {done} pulses");
        let start = Instant::now();
        while !released() && !self.until.as_ref().is_some_and(|f| f.exists()) {
            if start.elapsed() >= self.longest {
                return Err(HoldTimedOut {
                    done,
                    seconds: self.longest.as_secs_f64(),
                });
            }
            look();
            std::thread::sleep(Duration::from_millis(2));
        }
        Ok(())
    }
}

/// A test's hold that no one ended.
#[derive(Debug)]
pub struct HoldTimedOut {
    done: u64,
    seconds: f64,
}

impl std::fmt::Display for HoldTimedOut {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the test hold after {} pulses was not ended within {} s \
             (LIDARSIM_TEST_HOLD_SECONDS)",
            self.done, self.seconds
        )
    }
}
