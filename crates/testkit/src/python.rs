//! The Python peer of the interop tests: the interpreter `PL2MAP_PYTHON` names
//! (scripts/setup-python.sh makes one with the tools the tests compare against), and
//! running commands whose output a test reads.

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

/// The interpreter `PL2MAP_PYTHON` names, once it has run `import <modules>` (or, with
/// no modules, started at all). None after printing `SKIPPED <test>: <why>`
/// ([`crate::skip`]) when the variable is unset or empty, the interpreter does not start
/// or an import fails: the caller returns.
pub fn python(modules: &[&str]) -> Option<PathBuf> {
    let python = match std::env::var_os("PL2MAP_PYTHON") {
        Some(p) if !p.is_empty() => PathBuf::from(p),
        _ => {
            crate::skip("PL2MAP_PYTHON is not set (scripts/setup-python.sh prints one)");
            return None;
        }
    };
    probe(python, modules)
}

/// The interpreter of the LIMAP venv (pylimap 2.0 and pytlsd, in a venv of their own:
/// scripts/setup-python.sh): `PL2MAP_LIMAP_PYTHON`, else
/// `~/.cache/pl2map-rs/limap-venv/bin/python`, once it has run `import <modules>`. None
/// after printing `SKIPPED <test>: <why>` when there is none or an import fails.
pub fn limap_python(modules: &[&str]) -> Option<PathBuf> {
    let python = match std::env::var_os("PL2MAP_LIMAP_PYTHON") {
        Some(p) if !p.is_empty() => PathBuf::from(p),
        _ => match std::env::var_os("HOME") {
            Some(home) => PathBuf::from(home).join(".cache/pl2map-rs/limap-venv/bin/python"),
            None => {
                crate::skip("PL2MAP_LIMAP_PYTHON is not set and there is no HOME");
                return None;
            }
        },
    };
    if !python.exists() {
        crate::skip(format_args!(
            "no LIMAP venv: {} does not exist (scripts/setup-python.sh makes it; or set \
             PL2MAP_LIMAP_PYTHON)",
            python.display()
        ));
        return None;
    }
    probe(python, modules)
}

/// `python -c "import <modules>"`: the interpreter when it succeeds, else None after the
/// skip line.
fn probe(python: PathBuf, modules: &[&str]) -> Option<PathBuf> {
    let probe = if modules.is_empty() {
        "import sys".to_string()
    } else {
        format!("import {}", modules.join(", "))
    };
    match Command::new(&python).args(["-c", &probe]).output() {
        Ok(out) if out.status.success() => Some(python),
        Ok(out) => {
            // The last line of a traceback says what failed; the skip is one line.
            let stderr = String::from_utf8_lossy(&out.stderr);
            let why = stderr.lines().rev().find(|l| !l.trim().is_empty());
            crate::skip(format_args!(
                "{} cannot `{probe}`: {}",
                python.display(),
                why.unwrap_or("no error output").trim()
            ));
            None
        }
        Err(e) => {
            crate::skip(format_args!("cannot run {}: {e}", python.display()));
            None
        }
    }
}

/// The standard output of `cmd`, which must succeed: a failure panics with the command,
/// its exit status and its standard error.
pub fn run(cmd: &mut Command) -> Vec<u8> {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    checked(cmd, out)
}

/// As [`run`], with `input` written to the command's standard input (from another
/// thread, so a command that answers as it reads cannot block on a full pipe).
pub fn run_with_input(cmd: &mut Command, input: Vec<u8>) -> Vec<u8> {
    let mut child = cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    let mut stdin = child.stdin.take().expect("piped stdin");
    let writer = std::thread::spawn(move || stdin.write_all(&input));
    let out = child.wait_with_output().expect("waiting for the command");
    writer
        .join()
        .expect("stdin writer thread")
        .unwrap_or_else(|e| panic!("writing the input of {cmd:?}: {e}"));
    checked(cmd, out)
}

fn checked(cmd: &Command, out: Output) -> Vec<u8> {
    assert!(
        out.status.success(),
        "{cmd:?} failed ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr).trim()
    );
    out.stdout
}
