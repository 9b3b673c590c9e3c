//! Standard output that a closed pipe cannot stop: `pl2map run ... | head` must not kill a
//! pipeline half way, and `pl2map colmap info ... | true` must not panic (Rust's
//! `println!` panics on EPIPE). [`outln!`] and [`out!`] write to stdout and, once the
//! reader is gone, drop what follows silently: the command finishes its work and exits
//! with its own status, as if nobody had been reading. Any other write error is reported
//! once on stderr.

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

static CLOSED: AtomicBool = AtomicBool::new(false);

/// Writes `args` to stdout unless its reader went away.
pub fn write(args: std::fmt::Arguments<'_>) {
    if CLOSED.load(Ordering::Relaxed) {
        return;
    }
    let mut out = std::io::stdout().lock();
    let result = out.write_fmt(args).and_then(|()| out.flush());
    if let Err(e) = result {
        CLOSED.store(true, Ordering::Relaxed);
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            eprintln!("warning: writing to standard output: {e}; the rest is not printed");
        }
    }
}

/// `println!` that survives a closed stdout.
#[macro_export]
macro_rules! outln {
    () => { $crate::out::write(format_args!("\n")) };
    ($($arg:tt)*) => { $crate::out::write(format_args!("{}\n", format_args!($($arg)*))) };
}

/// `print!` that survives a closed stdout.
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => { $crate::out::write(format_args!($($arg)*)) };
}
