//! Fields of a process's `/proc/PID/status`, as Linux reports its memory and threads.

/// The number that follows `name` (`"VmHWM:"`, `"VmRSS:"`, `"Threads:"`) in the text of a
/// `/proc/PID/status` file; memory fields are in KiB. `None` when the field is missing or not
/// a number.
pub fn status_field(status: &str, name: &str) -> Option<u64> {
    status
        .lines()
        .find_map(|line| line.strip_prefix(name))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_read_by_name() {
        let status = "Name:\thil-sim\nVmHWM:\t  328704 kB\nVmRSS:\t  120000 kB\nThreads:\t9\n";
        assert_eq!(status_field(status, "VmHWM:"), Some(328_704));
        assert_eq!(status_field(status, "VmRSS:"), Some(120_000));
        assert_eq!(status_field(status, "Threads:"), Some(9));
        assert_eq!(status_field(status, "VmSwap:"), None);
        assert_eq!(status_field("Threads:\tmany\n", "Threads:"), None);
    }
}
