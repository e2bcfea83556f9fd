//! A buffered file whose `flush` can also push the data to the storage device.

use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};

/// A buffered file. [`Write::flush`] hands the buffered bytes to the operating system, which
/// is enough to survive the process being killed, and with `sync` also waits until they are
/// on the storage device, which survives a power cut.
#[derive(Debug)]
pub(crate) struct DurableFile {
    inner: BufWriter<File>,
    sync: bool,
}

impl DurableFile {
    /// Wraps `file`; `sync` says whether each flush also syncs the file's data.
    pub(crate) fn new(file: File, sync: bool) -> Self {
        DurableFile {
            inner: BufWriter::with_capacity(64 * 1024, file),
            sync,
        }
    }
}

impl Write for DurableFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.inner.write(buf)
    }

    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.inner.write_all(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()?;
        if self.sync {
            self.inner.get_ref().sync_data()?;
        }
        Ok(())
    }
}

impl Seek for DurableFile {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.inner.seek(pos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flush_hands_the_bytes_to_the_file() {
        let path = std::env::temp_dir().join(format!("durable-file-{}", std::process::id()));
        let mut file = DurableFile::new(File::create(&path).unwrap(), true);
        file.write_all(b"abc").unwrap();
        // Still buffered.
        assert_eq!(std::fs::read(&path).unwrap(), b"");
        file.flush().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"abc");
        assert_eq!(file.stream_position().unwrap(), 3);
        std::fs::remove_file(&path).unwrap();
    }
}
