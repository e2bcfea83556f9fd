//! (to be written)

/// Runs the command on `file`.
///
/// # Errors
/// When the file cannot be read.
pub fn run(file: &std::path::Path) -> Result<(), Box<dyn std::error::Error>> {
    let _ = file;
    Err("not implemented".into())
}
