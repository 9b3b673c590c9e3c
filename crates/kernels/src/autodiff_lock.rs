//! One autodiff computation at a time per process, between independent users.
//!
//! burn-autodiff 0.21 is not safe for two threads that build and differentiate unrelated
//! graphs at once: every `backward()` ends with a sweep over every autodiff graph of the
//! process (`GraphCleaner::cleanup_orphaned_entries`), and while another thread is
//! between taking an operation's inputs and registering its output, the sweep can judge
//! that thread's graph unused and free its steps. The other thread's backward pass then
//! stops short and a gradient comes out missing or wrong, without an error (burn issue
//! #5573, fixed upstream after 0.21 by keeping an operation's inputs referenced until it
//! is registered). Here it showed as a training step whose weights changed when an
//! unrelated step ran on another thread of the same process (the tests run
//! side by side: test `concurrent_trainers_do_not_change_each_others_steps`).
//!
//! So every training step (`train::step::TrainState`, crates/train/src/step/mod.rs) and every test that differentiates
//! holds [`exclusive`] while it builds and differentiates its graphs. Inside one step the
//! gradient groups build their graphs side by side and only start their backward passes
//! once every group has finished building (crates/train/src/step/mod.rs, `step_grouped`).

use std::sync::{Mutex, MutexGuard, PoisonError};

static AUTODIFF: Mutex<()> = Mutex::new(());

/// Holds the process's autodiff lock until dropped. Not reentrant: a holder must not
/// call a training step.
pub fn exclusive() -> MutexGuard<'static, ()> {
    // A panic while holding it left no state behind that the next holder depends on.
    AUTODIFF.lock().unwrap_or_else(PoisonError::into_inner)
}
