//! Byte-level faults on a sensor line: flipped bits, lost bytes and cut-short telegrams.
//!
//! [`ByteFaults`] transforms the bytes one sensor sends, chunk by chunk, in three steps:
//!
//! 1. **Truncate** (only [`ByteFaults::apply_telegram`], or a telegram passed piece by piece
//!    with [`ByteFaults::begin_telegram`]): with probability `truncate` a telegram of at least
//!    two bytes keeps a prefix whose length is uniform in `1..len` and loses the rest, as
//!    when the sensor resets or the cable is pulled mid-telegram.
//! 2. **Drop**: each remaining byte is lost with probability `drop`, as on a UART overrun.
//! 3. **Flip**: each bit of the bytes that are left is inverted with probability `ber`.
//!
//! Drops and flips form Bernoulli processes over the byte and bit streams; rather than one
//! draw per byte or bit, the gap to the next event is drawn from a geometric distribution,
//! so a clean stream costs one draw per fault. Each step has its own ChaCha8 stream derived
//! from the seed, and gaps carry over from one chunk to the next, so:
//!
//! * the same seed and the same calls give the same output;
//! * how bytes passed to [`ByteFaults::apply`] are split into chunks does not matter;
//! * with every rate zero the output equals the input and no random number is drawn.
//!
//! Apply faults to an emulator's bytes before they are queued on a
//! [`TxLine`](crate::emulators::TxLine), so that the line's timing reflects the bytes that
//! were actually sent.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Geometric};
use serde::Serialize;

use super::FaultSpec;

/// ChaCha stream numbers of the three steps; distinct from stream 0, which the emulators
/// use, so that faults stay independent of sensor noise drawn from the same seed.
const FLIP_STREAM: u64 = 0xFA17_0001;
const DROP_STREAM: u64 = 0xFA17_0002;
const TRUNCATE_STREAM: u64 = 0xFA17_0003;

/// What a [`ByteFaults`] has done so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct InjectedFaults {
    /// Bits inverted.
    pub bits_flipped: u64,
    /// Bytes lost on their own (not counting those cut off with a telegram).
    pub bytes_dropped: u64,
    /// Bytes lost because their telegram was cut short.
    pub bytes_cut: u64,
    /// Telegrams passed to [`ByteFaults::apply_telegram`].
    pub telegrams_in: u64,
    /// Telegrams cut short.
    pub telegrams_truncated: u64,
    /// Telegrams with at least one flipped bit, dropped byte or cut.
    pub telegrams_damaged: u64,
    /// Bytes passed in; equals `bytes_out + bytes_dropped + bytes_cut`.
    pub bytes_in: u64,
    /// Bytes handed back.
    pub bytes_out: u64,
}

/// Events of a Bernoulli process with success probability `p`, found by drawing the gap
/// between successive events from `Geometric(p)`.
#[derive(Debug, Clone)]
struct Bernoulli {
    rng: ChaCha8Rng,
    gap: Geometric,
    /// Trials left before the next event.
    to_next: u64,
}

impl Bernoulli {
    /// `None` when `p` is zero, so that a zero rate draws nothing.
    ///
    /// # Panics
    ///
    /// If `p` is NaN or outside `0..=1`.
    fn new(p: f64, name: &str, seed: u64, stream: u64) -> Option<Bernoulli> {
        if p == 0.0 {
            return None;
        }
        let gap = match Geometric::new(p) {
            Ok(gap) => gap,
            Err(err) => panic!("fault rate {name}={p}: {err}"),
        };
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(stream);
        let to_next = gap.sample(&mut rng);
        Some(Bernoulli { rng, gap, to_next })
    }

    /// Runs the next `trials` trials and calls `on_event` with the index (in `0..trials`) of
    /// each one that is an event, in increasing order.
    fn run(&mut self, trials: u64, mut on_event: impl FnMut(u64)) {
        let mut index = 0;
        while self.to_next < trials - index {
            index += self.to_next;
            on_event(index);
            index += 1;
            self.to_next = self.gap.sample(&mut self.rng);
        }
        self.to_next -= trials - index;
    }
}

/// A seeded, deterministic fault injector for the byte stream of one sensor. See the
/// [module documentation](self).
#[derive(Debug, Clone)]
pub struct ByteFaults {
    flips: Option<Bernoulli>,
    drops: Option<Bernoulli>,
    truncate: f64,
    truncate_rng: ChaCha8Rng,
    injected: InjectedFaults,
    /// The telegram being passed piece by piece.
    telegram: Option<Passing>,
}

/// A telegram passed piece by piece: how much of it is kept and what happened to it so far.
#[derive(Debug, Clone, Copy)]
struct Passing {
    /// Bytes kept (the rest is cut).
    kept: usize,
    /// Bytes passed so far.
    seen: usize,
    /// Whether a byte was cut.
    truncated: bool,
    /// Whether a byte was cut, dropped or flipped.
    damaged: bool,
}

impl ByteFaults {
    /// An injector with the `ber`, `drop` and `truncate` rates of `spec`, drawing from
    /// ChaCha8 streams seeded with `seed`.
    ///
    /// # Panics
    ///
    /// If a rate is NaN or outside `0..=1`; a spec parsed with [`FaultSpec::from_str`]
    /// (`str::parse`) never has one.
    ///
    /// [`FaultSpec::from_str`]: std::str::FromStr::from_str
    pub fn new(spec: &FaultSpec, seed: u64) -> ByteFaults {
        assert!(
            (0.0..=1.0).contains(&spec.truncate),
            "fault rate truncate={} is outside 0..=1",
            spec.truncate
        );
        let mut truncate_rng = ChaCha8Rng::seed_from_u64(seed);
        truncate_rng.set_stream(TRUNCATE_STREAM);
        ByteFaults {
            flips: Bernoulli::new(spec.ber, "ber", seed, FLIP_STREAM),
            drops: Bernoulli::new(spec.drop, "drop", seed, DROP_STREAM),
            truncate: spec.truncate,
            truncate_rng,
            injected: InjectedFaults::default(),
            telegram: None,
        }
    }

    /// Whether the injector passes everything through unchanged (every rate is zero).
    pub fn is_identity(&self) -> bool {
        self.flips.is_none() && self.drops.is_none() && self.truncate == 0.0
    }

    /// What has been injected so far.
    pub fn injected(&self) -> &InjectedFaults {
        &self.injected
    }

    /// Drops bytes and flips bits in `bytes`, which are not a telegram (or not one that may
    /// be truncated), and returns what is left.
    pub fn apply(&mut self, bytes: &[u8]) -> Vec<u8> {
        self.injected.bytes_in += bytes.len() as u64;
        let (out, _) = self.drop_and_flip(bytes);
        out
    }

    /// Cuts `telegram`, one complete telegram, short with probability `truncate`, then drops
    /// bytes and flips bits in it like [`Self::apply`], and returns what is left.
    pub fn apply_telegram(&mut self, telegram: &[u8]) -> Vec<u8> {
        self.begin_telegram(telegram.len());
        let out = self.telegram_part(telegram);
        self.end_telegram();
        out
    }

    /// Begins a telegram of `len` bytes whose bytes follow piece by piece, as they leave the
    /// sensor, through [`Self::telegram_part`]: decides now, with the same draws as
    /// [`Self::apply_telegram`], how much of it is kept. Ends the telegram begun before, if any.
    pub fn begin_telegram(&mut self, len: usize) {
        self.end_telegram();
        self.injected.telegrams_in += 1;
        // A telegram of one byte cannot be cut short and costs no draw.
        let kept =
            if self.truncate > 0.0 && len >= 2 && self.truncate_rng.random_bool(self.truncate) {
                self.truncate_rng.random_range(1..len)
            } else {
                len
            };
        self.telegram = Some(Passing {
            kept,
            seen: 0,
            truncated: false,
            damaged: false,
        });
    }

    /// The next bytes of the telegram begun with [`Self::begin_telegram`]: those past the
    /// part it keeps are cut, the others dropped and flipped like [`Self::apply`]. Returns
    /// what is left. Without a telegram begun, the same as [`Self::apply`].
    pub fn telegram_part(&mut self, bytes: &[u8]) -> Vec<u8> {
        let Some(mut telegram) = self.telegram else {
            return self.apply(bytes);
        };
        self.injected.bytes_in += bytes.len() as u64;
        let keep = telegram.kept.saturating_sub(telegram.seen).min(bytes.len());
        let cut = bytes.len() - keep;
        telegram.seen += bytes.len();
        if cut > 0 {
            self.injected.bytes_cut += cut as u64;
            if !telegram.truncated {
                telegram.truncated = true;
                self.injected.telegrams_truncated += 1;
            }
        }
        let (out, damaged) = self.drop_and_flip(&bytes[..keep]);
        telegram.damaged |= damaged || cut > 0;
        self.telegram = Some(telegram);
        out
    }

    /// The telegram begun with [`Self::begin_telegram`] is over: whole, or cut off by its
    /// sender (then only what it sent counts, and it is cut short only if a byte past its
    /// kept part was sent).
    pub fn end_telegram(&mut self) {
        if let Some(telegram) = self.telegram.take()
            && telegram.damaged
        {
            self.injected.telegrams_damaged += 1;
        }
    }

    /// Steps 2 and 3 of the module documentation; also returns whether anything was dropped
    /// or flipped. Counts everything but `bytes_in`.
    fn drop_and_flip(&mut self, bytes: &[u8]) -> (Vec<u8>, bool) {
        let mut out = Vec::with_capacity(bytes.len());
        let mut dropped = 0;
        match &mut self.drops {
            None => out.extend_from_slice(bytes),
            Some(drops) => {
                let mut kept_from = 0;
                drops.run(bytes.len() as u64, |index| {
                    // `index < bytes.len()`, which fits in `usize`.
                    let index = index as usize;
                    out.extend_from_slice(&bytes[kept_from..index]);
                    kept_from = index + 1;
                    dropped += 1;
                });
                out.extend_from_slice(&bytes[kept_from..]);
            }
        }
        let mut flipped = 0;
        if let Some(flips) = &mut self.flips {
            flips.run(out.len() as u64 * 8, |bit| {
                // Bits are numbered in the order they go on the wire: least significant first.
                out[(bit / 8) as usize] ^= 1 << (bit % 8);
                flipped += 1;
            });
        }
        self.injected.bytes_dropped += dropped;
        self.injected.bits_flipped += flipped;
        self.injected.bytes_out += out.len() as u64;
        (out, dropped > 0 || flipped > 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn faults(ber: f64, drop: f64, truncate: f64, seed: u64) -> ByteFaults {
        let spec = FaultSpec {
            ber,
            drop,
            truncate,
            ..FaultSpec::default()
        };
        ByteFaults::new(&spec, seed)
    }

    /// A reproducible byte pattern that is not all zeros.
    fn pattern(len: usize) -> Vec<u8> {
        (0..len).map(|i| (i * 31 + 7) as u8).collect()
    }

    fn bits_differing(a: &[u8], b: &[u8]) -> u64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| u64::from((x ^ y).count_ones()))
            .sum()
    }

    #[test]
    fn zero_rates_pass_everything_through_without_drawing() {
        let mut f = faults(0.0, 0.0, 0.0, 42);
        assert!(f.is_identity());
        let bytes = pattern(1000);
        assert_eq!(f.apply(&bytes), bytes);
        assert_eq!(f.apply_telegram(&bytes), bytes);
        assert_eq!(f.apply_telegram(&[]), Vec::<u8>::new());
        assert!(f.flips.is_none() && f.drops.is_none());
        assert_eq!(f.truncate_rng.get_word_pos(), 0);
        assert_eq!(
            *f.injected(),
            InjectedFaults {
                telegrams_in: 2,
                bytes_in: 2000,
                bytes_out: 2000,
                ..InjectedFaults::default()
            }
        );
    }

    #[test]
    fn same_seed_same_output() {
        let run = |seed| {
            let mut f = faults(1e-2, 1e-2, 0.3, seed);
            let mut out = Vec::new();
            for i in 0..200 {
                out.push(f.apply_telegram(&pattern(50 + i)));
                out.push(f.apply(&pattern(i)));
            }
            (out, *f.injected())
        };
        let first = run(7);
        assert_eq!(first, run(7));
        assert_ne!(first.0, run(8).0);
        assert!(first.1.bits_flipped > 0 && first.1.bytes_dropped > 0);
        assert!(first.1.telegrams_truncated > 0);
    }

    #[test]
    fn chunking_does_not_matter() {
        let bytes = pattern(10_000);
        let mut whole = faults(1e-3, 1e-2, 0.0, 3);
        let expected = whole.apply(&bytes);
        let mut pieces = faults(1e-3, 1e-2, 0.0, 3);
        let mut got = Vec::new();
        for chunk in bytes.chunks(37) {
            got.extend(pieces.apply(chunk));
        }
        assert_eq!(got, expected);
        assert_eq!(pieces.injected(), whole.injected());
    }

    #[test]
    fn bit_error_rate_is_respected() {
        // 10⁶ bits at 10⁻³: 1 000 flips expected, standard deviation ≈ 32.
        let bytes = vec![0u8; 125_000];
        let mut f = faults(1e-3, 0.0, 0.0, 11);
        let out = f.apply(&bytes);
        assert_eq!(out.len(), bytes.len());
        let flipped = f.injected().bits_flipped;
        assert!((850..=1150).contains(&flipped), "{flipped} bits flipped");
        assert_eq!(bits_differing(&bytes, &out), flipped);
        // Every bit position within a byte is hit.
        let hit = out.iter().fold(0u8, |acc, b| acc | b);
        assert_eq!(hit, 0xff);
    }

    #[test]
    fn drop_rate_is_respected() {
        // 10⁵ bytes at 10⁻²: 1 000 drops expected, standard deviation ≈ 31.
        let bytes = pattern(100_000);
        let mut f = faults(0.0, 1e-2, 0.0, 5);
        let out = f.apply(&bytes);
        let dropped = f.injected().bytes_dropped;
        assert!((850..=1150).contains(&dropped), "{dropped} bytes dropped");
        assert_eq!(out.len() as u64, 100_000 - dropped);
    }

    #[test]
    fn rate_one_hits_everything() {
        let bytes = pattern(100);
        let mut flip_all = faults(1.0, 0.0, 0.0, 1);
        let inverted: Vec<u8> = bytes.iter().map(|b| !b).collect();
        assert_eq!(flip_all.apply(&bytes), inverted);
        assert_eq!(flip_all.injected().bits_flipped, 800);
        let mut drop_all = faults(0.0, 1.0, 0.0, 1);
        assert!(drop_all.apply(&bytes).is_empty());
        assert_eq!(drop_all.injected().bytes_dropped, 100);
    }

    #[test]
    fn truncation_always_shortens_to_a_prefix() {
        let mut f = faults(0.0, 0.0, 1.0, 9);
        let mut lengths = Vec::new();
        for len in 2..300 {
            let telegram = pattern(len);
            let out = f.apply_telegram(&telegram);
            assert!((1..len).contains(&out.len()), "{len} → {}", out.len());
            assert_eq!(out, telegram[..out.len()]);
            lengths.push(out.len());
        }
        // Prefix lengths are spread out, not always 1 or len - 1.
        assert!(lengths.iter().any(|&l| l > 1));
        assert!(lengths.iter().enumerate().any(|(i, &l)| l < i + 1));
        // Telegrams too short to cut pass through.
        assert_eq!(f.apply_telegram(&[0x02]), [0x02]);
        assert_eq!(f.apply_telegram(&[]), Vec::<u8>::new());
        let injected = *f.injected();
        assert_eq!(injected.telegrams_in, 300);
        assert_eq!(injected.telegrams_truncated, 298);
        assert_eq!(injected.telegrams_damaged, 298);
        // Bytes not in telegrams are never cut.
        assert_eq!(f.apply(&pattern(500)).len(), 500);
    }

    #[test]
    fn truncate_rate_is_respected() {
        let mut f = faults(0.0, 0.0, 0.1, 2);
        for _ in 0..10_000 {
            f.apply_telegram(&pattern(20));
        }
        let truncated = f.injected().telegrams_truncated;
        // 1 000 expected, standard deviation 30.
        assert!((880..=1120).contains(&truncated), "{truncated} truncated");
    }

    #[test]
    fn counters_add_up() {
        let mut f = faults(2e-3, 5e-3, 0.2, 21);
        let mut bytes_out = 0;
        let mut damaged = 0;
        for i in 0..2_000 {
            let telegram = pattern(10 + i % 700);
            let out = f.apply_telegram(&telegram);
            if out != telegram {
                damaged += 1;
            }
            bytes_out += out.len() as u64;
            bytes_out += f.apply(&pattern(i % 13)).len() as u64;
        }
        let injected = *f.injected();
        assert_eq!(injected.bytes_out, bytes_out);
        assert_eq!(
            injected.bytes_out,
            injected.bytes_in - injected.bytes_dropped - injected.bytes_cut
        );
        assert_eq!(injected.telegrams_in, 2_000);
        assert!(injected.telegrams_truncated > 0);
        assert!(injected.telegrams_truncated <= injected.telegrams_damaged);
        assert!(injected.telegrams_damaged <= injected.telegrams_in);
        // The pattern has no two equal neighbours, so a dropped byte always shows.
        assert_eq!(injected.telegrams_damaged, damaged);
    }

    #[test]
    fn a_telegram_passed_piece_by_piece_is_damaged_as_a_whole_one() {
        let telegrams: Vec<Vec<u8>> = (0..300).map(|i| pattern(10 + i % 700)).collect();
        let mut whole = faults(2e-3, 5e-3, 0.3, 4);
        let mut pieces = whole.clone();
        for (i, telegram) in telegrams.iter().enumerate() {
            let expected = whole.apply_telegram(telegram);
            pieces.begin_telegram(telegram.len());
            let got: Vec<u8> = telegram
                .chunks(1 + i % 37)
                .flat_map(|chunk| pieces.telegram_part(chunk))
                .collect();
            pieces.end_telegram();
            assert_eq!(got, expected, "telegram {i}");
        }
        assert_eq!(pieces.injected(), whole.injected());
        assert!(whole.injected().telegrams_truncated > 0);
        // Cut off by its sender before the part it keeps ends: not truncated by the fault.
        let mut f = faults(0.0, 0.0, 1.0, 9);
        f.begin_telegram(100);
        let kept = f.telegram.map(|t| t.kept).unwrap();
        assert_eq!(f.telegram_part(&pattern(kept)), pattern(kept));
        f.end_telegram();
        assert_eq!(f.injected().telegrams_truncated, 0);
        assert_eq!(f.injected().telegrams_damaged, 0);
    }

    #[test]
    fn counters_serialize() {
        let json = serde_json::to_value(InjectedFaults::default()).unwrap();
        assert_eq!(json["bits_flipped"], 0);
        assert_eq!(json["telegrams_damaged"], 0);
    }

    #[test]
    #[should_panic(expected = "ber=2")]
    fn invalid_rate_panics() {
        faults(2.0, 0.0, 0.0, 0);
    }
}
