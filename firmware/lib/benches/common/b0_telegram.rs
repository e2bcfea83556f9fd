//! The 732-byte `B0h` telegram that the `sick_parse` bench and the `parse_b0_callgrind`
//! example measure: the real capture `sick-real/dtu-usick-b0-361-mm.bin` when the datasets are
//! present, otherwise a 361-value scan built with `ScanRepr::emit`. Included by both with
//! `#[path]`.

use firmware::sick::{ScanRepr, Telegram};
use protocol::RangeUnit;

/// The telegram bytes.
pub fn telegram_bytes() -> Vec<u8> {
    let path = datasets::path("sick-real/dtu-usick-b0-361-mm.bin");
    if let Ok(bytes) = std::fs::read(&path) {
        return bytes;
    }
    eprintln!("{} not found; using a synthetic scan", path.display());
    let scan = ScanRepr {
        unit: RangeUnit::Mm,
        partial_raster: None,
        values: (0..361u16).map(|i| 1000 + i * 7).collect(),
        indices: None,
        status: 0x10,
    };
    let mut bytes = vec![0u8; scan.buffer_len()];
    scan.emit(&mut Telegram::new_unchecked(&mut bytes[..]))
        .expect("buffer_len bytes");
    bytes
}
