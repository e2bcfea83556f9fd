//! Where a process's resident memory lies, from its `/proc/PID/smaps`: its own code and
//! data pages, its libraries', its heap, and the rest of its anonymous memory (blocks the
//! allocator mapped on their own, thread stacks).

use serde::Serialize;

/// A process's resident memory by kind, KiB. The four add up to its resident memory.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct ResidentByKind {
    /// Pages of the process's executable file: its code and read-only data.
    pub executable_kib: u64,
    /// Pages of every other file it mapped: shared libraries, mostly.
    pub libraries_kib: u64,
    /// The heap the allocator grows by `brk` (`[heap]`).
    pub heap_kib: u64,
    /// Every other anonymous mapping: blocks the allocator mapped on their own, other heaps,
    /// thread stacks and the main stack.
    pub other_anonymous_kib: u64,
}

impl ResidentByKind {
    /// The text of `/proc/PID/smaps` of a process whose executable is `executable` (the
    /// path `/proc/PID/exe` links to) summed by kind.
    pub fn from_smaps(smaps: &str, executable: &str) -> Self {
        let mut by_kind = ResidentByKind::default();
        // The kind of the mapping whose fields follow.
        let mut kind: Option<Kind> = None;
        for line in smaps.lines() {
            if let Some(rss) = line.strip_prefix("Rss:") {
                let kib = rss
                    .split_whitespace()
                    .next()
                    .and_then(|v| v.parse::<u64>().ok());
                if let (Some(kind), Some(kib)) = (kind, kib) {
                    *by_kind.field(kind) += kib;
                }
            } else if let Some(mapping) = mapping_kind(line, executable) {
                kind = Some(mapping);
            }
        }
        by_kind
    }

    /// The resident memory of a running process `pid`, by kind.
    ///
    /// # Errors
    /// The process is gone, or its maps cannot be read.
    pub fn of_process(pid: u32) -> std::io::Result<Self> {
        let executable = std::fs::read_link(format!("/proc/{pid}/exe"))?;
        let smaps = std::fs::read_to_string(format!("/proc/{pid}/smaps"))?;
        Ok(Self::from_smaps(&smaps, &executable.to_string_lossy()))
    }

    /// The sum of the four, KiB.
    pub fn total_kib(&self) -> u64 {
        self.executable_kib + self.libraries_kib + self.heap_kib + self.other_anonymous_kib
    }

    fn field(&mut self, kind: Kind) -> &mut u64 {
        match kind {
            Kind::Executable => &mut self.executable_kib,
            Kind::Library => &mut self.libraries_kib,
            Kind::Heap => &mut self.heap_kib,
            Kind::OtherAnonymous => &mut self.other_anonymous_kib,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Executable,
    Library,
    Heap,
    OtherAnonymous,
}

/// The kind of the mapping a header line of smaps (`start-end perms offset dev inode [path]`)
/// describes; `None` when `line` is not a header (a field line such as `Rss:` is not: its
/// first word has no `-` range).
fn mapping_kind(line: &str, executable: &str) -> Option<Kind> {
    let mut words = line.split_whitespace();
    let range = words.next()?;
    let (start, end) = range.split_once('-')?;
    if u64::from_str_radix(start, 16).is_err() || u64::from_str_radix(end, 16).is_err() {
        return None;
    }
    // perms, offset, dev, inode; then the path, which may hold spaces, or nothing.
    let path = words.skip(4).collect::<Vec<_>>().join(" ");
    Some(if path == "[heap]" {
        Kind::Heap
    } else if path == executable {
        Kind::Executable
    } else if path.starts_with('/') {
        Kind::Library
    } else {
        Kind::OtherAnonymous
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMAPS: &str = "\
55d0c0000000-55d0c0700000 r-xp 00000000 08:01 1234 /opt/robot-host
Size:               7168 kB
Rss:                7100 kB
55d0c1000000-55d0c1300000 rw-p 00000000 00:00 0 [heap]
Size:               3072 kB
Rss:                2400 kB
7f0000000000-7f0000200000 rw-p 00000000 00:00 0 
Size:               2048 kB
Rss:                 900 kB
7f0000400000-7f0000500000 r-xp 00000000 08:01 99 /usr/lib/x86_64-linux-gnu/libc.so.6
Size:               1024 kB
Rss:                 800 kB
Swap:                  0 kB
7ffd00000000-7ffd00021000 rw-p 00000000 00:00 0 [stack]
Rss:                  40 kB
7f0000600000-7f0000601000 r--p 00000000 08:01 77 /tmp/a file (deleted)
Rss:                   4 kB
";

    #[test]
    fn resident_memory_is_summed_by_kind() {
        let by_kind = ResidentByKind::from_smaps(SMAPS, "/opt/robot-host");
        assert_eq!(
            by_kind,
            ResidentByKind {
                executable_kib: 7100,
                libraries_kib: 804,
                heap_kib: 2400,
                other_anonymous_kib: 940,
            }
        );
        assert_eq!(by_kind.total_kib(), 11_244);
    }

    #[test]
    fn the_process_itself_reads() {
        let by_kind = ResidentByKind::of_process(std::process::id()).unwrap();
        assert!(by_kind.executable_kib > 0, "{by_kind:?}");
        assert!(by_kind.total_kib() > by_kind.executable_kib);
    }
}
