//! A child process that is killed (and reaped) when dropped, so a benchmark that fails half way
//! leaves no server, recorder or peer running behind it.

use std::ops::{Deref, DerefMut};
use std::process::{Child, ExitStatus};
use std::time::{Duration, Instant};

use anyhow::{Result, ensure};

/// A child process, killed if still running when dropped; derefs to the [`Child`].
pub struct KillOnDrop(pub Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            let _ = self.0.kill();
        }
        let _ = self.0.wait();
    }
}

impl Deref for KillOnDrop {
    type Target = Child;

    fn deref(&self) -> &Child {
        &self.0
    }
}

impl DerefMut for KillOnDrop {
    fn deref_mut(&mut self) -> &mut Child {
        &mut self.0
    }
}

impl KillOnDrop {
    /// Waits up to `timeout` for the process to exit, looking every `poll`.
    ///
    /// # Errors
    /// When it is still running after `timeout` (named `what` in the message), or waiting fails.
    pub fn wait_for(
        &mut self,
        what: &str,
        timeout: Duration,
        poll: Duration,
    ) -> Result<ExitStatus> {
        let t0 = Instant::now();
        loop {
            if let Some(status) = self.0.try_wait()? {
                return Ok(status);
            }
            ensure!(
                t0.elapsed() < timeout,
                "{what} still running after {timeout:?}"
            );
            std::thread::sleep(poll);
        }
    }
}
