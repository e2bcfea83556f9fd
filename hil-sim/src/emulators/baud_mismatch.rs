//! What a UART hears when the sender runs at another baud rate.
//!
//! A bit-level model of an 8N1 line: the sender's bytes are laid out back to back as start
//! bit, 8 data bits (LSB first), stop bit, with the line idle (high) after them. The
//! receiver waits for a falling edge, then samples the middle of each of its own bit times:
//! 8 data bits and the stop bit. It delivers the byte even when the stop bit reads low (a
//! framing error; most UARTs pass such bytes on with an error flag nobody checks), and then
//! waits for the next falling edge after its stop-bit sample.
//!
//! So a receiver slower than the sender hears a few random-looking bytes per many sent, a
//! faster one hears a `00h`-like byte per low stretch: neither understands a telegram, as
//! with real hardware, and the result is deterministic.

/// The bytes a receiver at `heard_baud` decodes from `bytes` sent back to back at
/// `sent_baud`. Equal rates give the bytes unchanged.
pub fn garble(bytes: &[u8], sent_baud: u32, heard_baud: u32) -> Vec<u8> {
    if sent_baud == heard_baud || bytes.is_empty() {
        return bytes.to_vec();
    }
    let total_bits = bytes.len() * 10;
    // Line level at sent-bit index `i` (idle high outside the transmission).
    let level = |i: usize| -> bool {
        match (bytes.get(i / 10), i % 10) {
            (None, _) | (Some(_), 9) => true,
            (Some(_), 0) => false,
            (Some(byte), bit) => (byte >> (bit - 1)) & 1 == 1,
        }
    };
    let level_at = |t: f64| -> bool { if t < 0.0 { true } else { level(t as usize) } };
    // One receiver bit time, in sent bit times.
    let q = f64::from(sent_baud) / f64::from(heard_baud);
    let mut out = Vec::new();
    let mut from = 0usize;
    while let Some(edge) = (from..total_bits).find(|&i| !level(i) && (i == 0 || level(i - 1))) {
        let start = edge as f64;
        let mut byte = 0u8;
        for bit in 0..8 {
            if level_at(start + (f64::from(bit) + 1.5) * q) {
                byte |= 1 << bit;
            }
        }
        out.push(byte);
        let stop_sample = start + 9.5 * q;
        from = (stop_sample.ceil() as usize).max(edge + 1);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_rate_is_transparent() {
        assert_eq!(
            garble(&[0x02, 0x80, 0x06], 9_600, 9_600),
            [0x02, 0x80, 0x06]
        );
    }

    #[test]
    fn other_rates_are_not_understood() {
        let telegram = [0x06, 0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];
        let slow = garble(&telegram, 500_000, 9_600);
        assert!(slow.len() < 2, "{slow:02X?}");
        let fast = garble(&telegram, 9_600, 500_000);
        assert_ne!(fast, telegram);
        assert!(
            fast.iter()
                .all(|&b| b == 0x00 || b == 0x80 || b & 0x0F == 0),
            "{fast:02X?}"
        );
        // Deterministic.
        assert_eq!(
            garble(&telegram, 38_400, 19_200),
            garble(&telegram, 38_400, 19_200)
        );
    }
}
