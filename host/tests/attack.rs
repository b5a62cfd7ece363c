//! The attack cases of issue 32 as regression tests: closed output streams,
//! crafted checkpoints, two runs in one directory, oversized files, cosmetic
//! edits of a resumed configuration, and values that cannot finish.

mod common;

use common::*;
use std::process::{Command, Stdio};

/// Runs `mbs ARGS` with standard error (and, if `close_stdout`, standard
/// output) a pipe whose reading end is closed before `mbs` writes: returns the
/// exit status, None if killed by a signal.
fn with_closed_streams(args: &[&std::ffi::OsStr], close_stdout: bool) -> Option<i32> {
    let closed = || {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        Stdio::from(writer)
    };
    Command::new(assert_cmd::cargo::cargo_bin("mbs"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(if close_stdout {
            closed()
        } else {
            Stdio::null()
        })
        .stderr(closed())
        .status()
        .unwrap()
        .code()
}

#[test]
fn a_closed_stderr_keeps_the_exit_status_of_a_bad_configuration() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "bad.toml", "[bed]\ncolumns = 0\n");
    let out = dir.path().join("out");
    let code = with_closed_streams(
        &[
            "run".as_ref(),
            cfg.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ],
        true,
    );
    assert_eq!(code, Some(2));
}

#[test]
fn a_closed_stderr_keeps_the_exit_status_of_a_good_run() {
    let dir = tempfile::tempdir().unwrap();
    // A warning (the f32 width) goes to stderr before the work.
    let cfg = write(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    let code = with_closed_streams(
        &[
            "run".as_ref(),
            cfg.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ],
        true,
    );
    assert_eq!(code, Some(0));
    assert!(out.join("transport.csv").is_file());
}

#[test]
fn a_closed_stdout_keeps_the_exit_status_of_config() {
    assert_eq!(with_closed_streams(&["config".as_ref()], true), Some(0));
}
