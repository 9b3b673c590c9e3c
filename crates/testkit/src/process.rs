//! Child processes the way a shell pipeline treats them, and their outcomes.

use std::process::{Command, Output, Stdio};

/// A standard output whose reader is already gone (`pl2map ... | true` after `true`
/// exited): every write the child makes fails with EPIPE.
pub fn closed_stdout() -> Stdio {
    let (reader, writer) = std::io::pipe().expect("creating a pipe");
    drop(reader);
    Stdio::from(writer)
}

/// The standard output of a command that must have succeeded; else panics with `what`,
/// the status and both outputs.
pub fn ok(out: Output, what: &str) -> String {
    assert!(
        out.status.success(),
        "{what} failed ({}):\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs `cmd` with a closed standard output and checks the conventional quiet exit:
/// status 0, no panic and no broken-pipe message.
pub fn assert_quiet_exit_on_closed_stdout(cmd: &mut Command) {
    let out = cmd
        .stdout(closed_stdout())
        .stderr(Stdio::piped())
        .output()
        .expect("running the command");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{cmd:?}: {} {stderr}", out.status);
    assert!(
        !stderr.contains("panicked") && !stderr.contains("Broken pipe"),
        "{cmd:?}: {stderr}"
    );
}
