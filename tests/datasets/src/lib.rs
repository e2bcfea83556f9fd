//! Where the real recordings live, for tests, benchmarks and evaluation commands.
//!
//! The recordings are not part of this repository. They are looked up in the directory named by
//! the `ROBOT_DATASETS` environment variable, or else in `../shared/datasets` beside the
//! workspace root.
//!
//! Policy for tests: when a recording is missing, a test prints that it skipped and why; when the
//! `CI` environment variable is set it fails instead, so that CI can never pass on a skipped test.

use std::path::{Path, PathBuf};

/// The environment variable that overrides the dataset directory.
pub const ENV_VAR: &str = "ROBOT_DATASETS";

/// The dataset root: `$ROBOT_DATASETS`, or `<workspace>/../shared/datasets`.
pub fn root() -> PathBuf {
    match std::env::var_os(ENV_VAR) {
        Some(dir) => PathBuf::from(dir),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/datasets"),
    }
}

/// The path of `relative` under the dataset root, whether or not it exists.
pub fn path(relative: &str) -> PathBuf {
    root().join(relative)
}

/// Whether the CI environment variable is set (to anything but an empty string or `false`).
pub fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0")
}

/// Returns the path of `relative` under the dataset root if it exists.
///
/// When it does not exist, prints a skip notice naming `test` and returns `None`, so the caller
/// returns early.
///
/// # Panics
/// When the recording is missing and `CI` is set: CI must not pass on a skipped test.
pub fn require(relative: &str, test: &str) -> Option<PathBuf> {
    let p = path(relative);
    if p.exists() {
        return Some(p);
    }
    let why = format!(
        "{test}: dataset {} not found (set {ENV_VAR} to the folder holding the shared datasets)",
        p.display()
    );
    if in_ci() {
        panic!("{why}; failing because CI is set");
    }
    eprintln!("SKIPPED {why}");
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_dataset_is_none_outside_ci() {
        if in_ci() {
            return;
        }
        assert!(require("no/such/recording", "missing_dataset_is_none_outside_ci").is_none());
    }

    #[test]
    fn root_ends_in_datasets_or_env() {
        let r = root();
        assert!(std::env::var_os(ENV_VAR).is_some() || r.ends_with("shared/datasets"));
    }
}
