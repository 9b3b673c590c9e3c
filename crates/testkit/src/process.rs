//! Child processes the way a shell pipeline treats them.

use std::process::Stdio;

/// A standard output whose reader is already gone (`pl2map ... | true` after `true`
/// exited): every write the child makes fails with EPIPE.
pub fn closed_stdout() -> Stdio {
    let (reader, writer) = std::io::pipe().expect("creating a pipe");
    drop(reader);
    Stdio::from(writer)
}
