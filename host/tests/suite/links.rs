//! Writing through links (the second round of hostile input, class 1): a
//! symbolic link planted where mbs writes a file of its own in the output
//! directory is refused with exit status 2, naming the file, and the file
//! it points to is left as it was; so is a folder of its own linked
//! elsewhere.

use crate::common::*;

#[cfg(unix)]
#[test]
fn links_planted_in_the_output_directory_are_refused_not_followed() {
    for own in [".mbs-lock", "mbs.log", "cells.jsonl"] {
        let tmp = tempfile::tempdir().unwrap();
        let config = write(tmp.path(), "small.toml", SMALL);
        let victim = write(tmp.path(), "victim.txt", "precious\n");
        let out = tmp.path().join("out");
        std::fs::create_dir(&out).unwrap();
        std::os::unix::fs::symlink(&victim, out.join(own)).unwrap();
        let done = run_into(&config, &out).assert().code(2);
        let stderr = String::from_utf8_lossy(&done.get_output().stderr).into_owned();
        assert!(
            stderr.contains(own) && stderr.contains("symbolic link"),
            "{own}: {stderr}"
        );
        assert_eq!(
            std::fs::read_to_string(&victim).unwrap(),
            "precious\n",
            "{own}"
        );
    }
}

/// A folder of mbs's own linked elsewhere: the checkpoints, the settled
/// beds or the particle frames would be written outside the directory.
#[cfg(unix)]
#[test]
fn linked_folders_of_the_output_directory_are_refused() {
    for own in ["checkpoints", "beds", "frames"] {
        let tmp = tempfile::tempdir().unwrap();
        let config = write(tmp.path(), "small.toml", SMALL);
        let elsewhere = tmp.path().join("elsewhere");
        std::fs::create_dir(&elsewhere).unwrap();
        let out = tmp.path().join("out");
        std::fs::create_dir(&out).unwrap();
        std::os::unix::fs::symlink(&elsewhere, out.join(own)).unwrap();
        let done = run_into(&config, &out).assert().code(2);
        let stderr = String::from_utf8_lossy(&done.get_output().stderr).into_owned();
        assert!(
            stderr.contains(own) && stderr.contains("symbolic link"),
            "{own}: {stderr}"
        );
        assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 0, "{own}");
    }
}
