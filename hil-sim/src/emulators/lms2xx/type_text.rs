//! The emulated LMS2xx's type string (`BAh`, `90h`): where it may be cut to fit a telegram,
//! and the firmware version `B1h` reports from it.

/// The 7-byte firmware version of `B1h`: the type string after its last `;`, padded with
/// spaces.
pub(super) fn version_of(type_text: &str) -> [u8; 7] {
    let version = type_text.rsplit(';').next().unwrap_or("");
    let mut out = [b' '; 7];
    for (slot, byte) in out.iter_mut().zip(version.bytes()) {
        *slot = byte;
    }
    out
}

/// The largest index `<= max` that is a character boundary of `text`.
pub(super) fn floor_char_boundary(text: &str, max: usize) -> usize {
    (0..=max.min(text.len()))
        .rev()
        .find(|&i| text.is_char_boundary(i))
        .unwrap_or(0)
}
