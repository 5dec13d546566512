//! Cooperative cancellation. Long loops call [`Cancel::check`] every few
//! thousand steps; the binding layer sets the flag when Python reports a
//! pending signal (Ctrl-C), so a render stops within a fraction of a second.

use crate::error::{FcolError, Result};
use std::sync::atomic::{AtomicBool, Ordering};

#[derive(Debug, Default)]
pub struct Cancel(AtomicBool);

impl Cancel {
    pub fn new() -> Self {
        Cancel(AtomicBool::new(false))
    }
    /// Ask the running computation to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
    /// `Err(Interrupted)` once cancelled.
    #[inline]
    pub fn check(&self) -> Result<()> {
        if self.is_cancelled() {
            Err(FcolError::Interrupted)
        } else {
            Ok(())
        }
    }
}
