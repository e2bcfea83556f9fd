//! Reads a recording back: the raw reads for replay and a count of every channel's messages.
//!
//! A recording cut short (the daemon killed, the disk pulled) has no summary or footer and may
//! end inside a chunk. The reader goes through the file from the start, keeps every chunk
//! that is complete and whose CRC checks, and reports the file as truncated when it ends
//! before the footer. A record whose length runs past the end of the file reads the same way,
//! as a file cut inside that record. A damaged header, channel or message record is an
//! error, as are a message on an unknown channel and a channel whose topic changes; the
//! records a replay does not need (schemas, attachments, metadata, indexes, statistics) are
//! passed over unparsed. Before the MCAP library parses a header or a channel, its
//! length-prefixed fields are checked against the record ([`record_fields`]).
//!
//! A recording the recorder went on in further parts ([`super::recorder::part_path`]) reads
//! as one: every part in turn, each checked as above, with the records of all of them in
//! log-time order.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{self, BufReader, Read};
use std::path::{Path, PathBuf};

use mcap::McapError;
use mcap::records::{ChunkHeader, Record, op};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

use super::error::RecordingError;
use super::record_fields;
use super::recorder::{part_path, time_s};
use super::topics::{CAMERA_IMAGE_TOPIC, RAW_TOPIC, RECONNECT_TOPIC, SENT_TOPIC};

/// The longest record (or uncompressed chunk) read, bytes: far above what the recorder
/// writes, and a bound on what a damaged length field can make the reader allocate.
const MAX_RECORD_BYTES: usize = 256 * 1024 * 1024;

/// The most an LZ4 frame can expand: a match's length grows by at most 255 for each byte
/// that encodes it. A chunk that claims more than this many times its compressed size is
/// refused before any memory is reserved for it.
const LZ4_MAX_EXPANSION: usize = 255;

/// One read from the serial port.
#[derive(Debug, Clone, PartialEq)]
pub struct RawRead {
    /// Host time of the read, s (recorded to the nanosecond).
    pub recv_time_s: f64,
    /// The bytes as received.
    pub bytes: Vec<u8>,
}

/// Which way bytes went on the link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkDirection {
    /// Read from the board.
    FromBoard,
    /// Written to the board.
    ToBoard,
    /// The port was reopened (no bytes).
    Reconnect,
}

/// One read, write or reopening of the serial port.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkRecord {
    /// Host time, s (recorded to the nanosecond).
    pub time_s: f64,
    /// Which way.
    pub direction: LinkDirection,
    /// The bytes.
    pub bytes: Vec<u8>,
}

/// One camera frame of a recording.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraImage {
    /// Host time the frame was taken, s (recorded to the nanosecond).
    pub time_s: f64,
    /// Its compressed bytes.
    pub data: Vec<u8>,
    /// Their format as recorded (`jpeg`).
    pub format: String,
}

/// What a recording holds.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Recording {
    /// Every read from the serial port, in log-time order (file order between equal times).
    pub raw_reads: Vec<RawRead>,
    /// Every read, write and reopening of the port, in log-time order (file order between
    /// equal times): what a replay goes through.
    pub link: Vec<LinkRecord>,
    /// The camera's frames, in log-time order ([`read_recording_with_camera`] and
    /// [`read_recording_from`] only).
    pub camera_images: Vec<CameraImage>,
    /// Camera frames whose message could not be decoded (left out).
    pub camera_images_refused: u64,
    /// Messages per topic, the raw reads included.
    pub message_counts: BTreeMap<String, u64>,
    /// Whether the file, or one of its parts, ends before its footer (the recorder did not
    /// finish): the records above are those of the complete chunks.
    pub truncated: bool,
    /// Files read: the first, then its further parts (a part cut before its first bytes
    /// is not one).
    pub parts: u32,
}

/// Reads the recording at `path`, tolerating a file cut short by a kill (see the
/// [module documentation](self)), and its further parts after it in order
/// ([`super::recorder::part_path`]: `run_1.mcap`, `run_2.mcap`, … while they exist).
///
/// # Errors
/// [`RecordingError::Open`] if the file cannot be opened or a read fails,
/// [`RecordingError::NotMcap`] if it is not an MCAP file, [`RecordingError::FieldOverrun`]
/// if a record's field claims more bytes than the record holds, [`RecordingError::Corrupt`]
/// if it is damaged otherwise (other than by being cut short); each naming the part.
pub fn read_recording(path: &Path) -> Result<Recording, RecordingError> {
    read_parts(path, false)
}

/// [`read_recording`] with the camera's frames ([`Recording::camera_images`]), which the
/// other readers leave out: an hour of them is gigabytes.
///
/// # Errors
/// As [`read_recording`].
pub fn read_recording_with_camera(path: &Path) -> Result<Recording, RecordingError> {
    read_parts(path, true)
}

fn read_parts(path: &Path, camera_images: bool) -> Result<Recording, RecordingError> {
    let mut records = Records::new(camera_images);
    for index in 0.. {
        let part = part_path(path, index);
        let file = match File::open(&part) {
            Ok(file) => file,
            // The parts end where the next is missing; the first must be there.
            Err(e) if index > 0 && e.kind() == io::ErrorKind::NotFound => break,
            Err(source) => return Err(RecordingError::Open { path: part, source }),
        };
        if index > 0
            && file
                .metadata()
                .is_ok_and(|m| m.len() < mcap::MAGIC.len() as u64)
        {
            // A part whose recorder was killed before its first bytes reached the disk.
            records.recording.truncated = true;
            break;
        }
        records.read_part(BufReader::new(file), &part)?;
    }
    Ok(records.into_recording())
}

/// Reads a recording from `source` (a file's bytes, a pipe); `path` names it in errors. As
/// [`read_recording`] after opening the file, but for this one file, not its further parts.
///
/// # Errors
/// As [`read_recording`].
pub fn read_recording_from(source: impl Read, path: &Path) -> Result<Recording, RecordingError> {
    let mut records = Records::new(true);
    records.read_part(source, path)?;
    Ok(records.into_recording())
}

/// What the reader keeps of the records it has taken so far.
struct Records {
    /// The part being read, which errors name.
    path: PathBuf,
    recording: Recording,
    /// Whether the camera's frames are kept.
    camera_images: bool,
    /// Each channel's topic, in the part being read.
    topics: HashMap<u16, String>,
    /// The raw reads: log time, bytes.
    reads: Vec<(u64, Vec<u8>)>,
    /// Reads, writes and reopenings: log time, direction, bytes.
    link: Vec<(u64, LinkDirection, Vec<u8>)>,
}

impl Records {
    fn new(camera_images: bool) -> Records {
        Records {
            path: PathBuf::new(),
            recording: Recording::default(),
            camera_images,
            topics: HashMap::new(),
            reads: Vec::new(),
            link: Vec::new(),
        }
    }

    /// Takes the records of one file (the recording's first or a further part), tolerating
    /// its being cut short.
    fn read_part(&mut self, mut source: impl Read, path: &Path) -> Result<(), RecordingError> {
        self.path = path.to_path_buf();
        self.topics.clear();
        self.recording.parts += 1;
        let mut magic = [0u8; 8];
        match source.read_exact(&mut magic) {
            Ok(()) if magic == mcap::MAGIC => {}
            Ok(()) => return Err(not_mcap(path)),
            Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => return Err(not_mcap(path)),
            Err(source) => {
                return Err(RecordingError::Open {
                    path: path.to_path_buf(),
                    source,
                });
            }
        }
        let options = LinearReaderOptions::default()
            // Whole chunks, read here (see `read_chunk`): a chunk is used only once all of it
            // is there.
            .with_emit_chunks(true)
            .with_record_length_limit(MAX_RECORD_BYTES);
        let mut reader = LinearReader::new_with_options(options);
        let mut input = magic.chain(source);
        while let Some(event) = reader.next_event() {
            match event {
                Ok(LinearReadEvent::ReadRequest(need)) => {
                    let read = loop {
                        match input.read(reader.insert(need)) {
                            Ok(n) => break n,
                            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                            Err(source) => {
                                return Err(RecordingError::Open {
                                    path: path.to_path_buf(),
                                    source,
                                });
                            }
                        }
                    };
                    reader.notify_read(read);
                }
                Ok(LinearReadEvent::Record { opcode, data }) => self.take(opcode, data)?,
                Err(McapError::UnexpectedEof) => {
                    self.recording.truncated = true;
                    break;
                }
                Err(error) => return Err(self.corrupt(error)),
            }
        }
        Ok(())
    }

    /// The recording the parts read hold, every record in log-time order.
    fn into_recording(self) -> Recording {
        let Records {
            mut recording,
            mut reads,
            mut link,
            ..
        } = self;
        // Stable: records with equal times stay in file order.
        link.sort_by_key(|&(log_time_ns, _, _)| log_time_ns);
        recording.link = link
            .into_iter()
            .map(|(log_time_ns, direction, bytes)| LinkRecord {
                time_s: time_s(log_time_ns),
                direction,
                bytes,
            })
            .collect();
        recording
            .camera_images
            .sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        reads.sort_by_key(|&(log_time_ns, _)| log_time_ns);
        recording.raw_reads = reads
            .into_iter()
            .map(|(log_time_ns, bytes)| RawRead {
                recv_time_s: time_s(log_time_ns),
                bytes,
            })
            .collect();
        recording
    }

    fn corrupt(&self, error: McapError) -> RecordingError {
        RecordingError::Corrupt {
            path: self.path.clone(),
            source: error,
        }
    }

    /// Takes one record of the file or of a chunk. The replay needs only the header, the
    /// channels (the summary's copies included, which must agree) and the messages, and
    /// parses nothing else.
    fn take(&mut self, opcode: u8, data: &[u8]) -> Result<(), RecordingError> {
        let layout = match opcode {
            op::HEADER => Some(record_fields::HEADER),
            op::CHANNEL => Some(record_fields::CHANNEL),
            op::CHUNK => Some(record_fields::CHUNK),
            // Fixed fields, then the payload: nothing to reserve.
            op::MESSAGE => None,
            _ => return Ok(()),
        };
        if let Some(layout) = layout
            && let Err(overrun) = record_fields::check_fields(data, layout)
        {
            return Err(RecordingError::FieldOverrun {
                path: self.path.clone(),
                opcode,
                overrun,
            });
        }
        match mcap::parse_record(opcode, data).map_err(|e| self.corrupt(e))? {
            Record::Chunk { header, data } => self.take_chunk(&header, &data)?,
            Record::Channel(channel) => match self.topics.get(&channel.id) {
                Some(topic) if *topic != channel.topic => {
                    return Err(self.corrupt(McapError::ConflictingChannels(channel.topic)));
                }
                _ => {
                    self.topics.insert(channel.id, channel.topic);
                }
            },
            Record::Message { header, data } => {
                let Some(topic) = self.topics.get(&header.channel_id) else {
                    return Err(self.corrupt(McapError::UnknownChannel(
                        header.sequence,
                        header.channel_id,
                    )));
                };
                let counts = &mut self.recording.message_counts;
                match counts.get_mut(topic) {
                    Some(count) => *count += 1,
                    None => {
                        counts.insert(topic.clone(), 1);
                    }
                }
                let direction = match topic.as_str() {
                    RAW_TOPIC => Some(LinkDirection::FromBoard),
                    SENT_TOPIC => Some(LinkDirection::ToBoard),
                    RECONNECT_TOPIC => Some(LinkDirection::Reconnect),
                    _ => None,
                };
                if self.camera_images && topic == CAMERA_IMAGE_TOPIC {
                    match <foxglove::messages::CompressedImage as foxglove::Decode>::decode(
                        &data[..],
                    ) {
                        Ok(image) => self.recording.camera_images.push(CameraImage {
                            time_s: time_s(header.log_time),
                            data: image.data.to_vec(),
                            format: image.format,
                        }),
                        Err(_) => self.recording.camera_images_refused += 1,
                    }
                }
                if let Some(direction) = direction {
                    let bytes = data.into_owned();
                    if direction == LinkDirection::FromBoard {
                        self.reads.push((header.log_time, bytes.clone()));
                    }
                    self.link.push((header.log_time, direction, bytes));
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// Decompresses a whole chunk, checks its CRC and takes the records it holds, each
    /// checked to lie within the chunk (the MCAP library's own chunk reader subtracts a
    /// record's claimed length from what is left unchecked).
    fn take_chunk(
        &mut self,
        header: &ChunkHeader,
        compressed: &[u8],
    ) -> Result<(), RecordingError> {
        let too_large = || McapError::ChunkTooLarge(header.uncompressed_size);
        let size =
            usize::try_from(header.uncompressed_size).map_err(|_| self.corrupt(too_large()))?;
        if size > MAX_RECORD_BYTES {
            return Err(self.corrupt(too_large()));
        }
        let decompressed;
        let records = match header.compression.as_str() {
            "" => compressed,
            "lz4" => {
                if size > compressed.len().saturating_mul(LZ4_MAX_EXPANSION) {
                    return Err(self.corrupt(McapError::BadChunkLength {
                        header: header.uncompressed_size,
                        available: compressed.len() as u64,
                    }));
                }
                let mut out = Vec::with_capacity(size);
                lz4::Decoder::new(compressed)
                    .and_then(|decoder| decoder.take(size as u64 + 1).read_to_end(&mut out))
                    .map_err(|e| self.corrupt(McapError::DecompressionError(e.to_string())))?;
                decompressed = out;
                &decompressed[..]
            }
            other => return Err(self.corrupt(McapError::UnsupportedCompression(other.into()))),
        };
        if records.len() != size {
            return Err(self.corrupt(McapError::BadChunkLength {
                header: header.uncompressed_size,
                available: records.len() as u64,
            }));
        }
        let saved = header.uncompressed_crc;
        let calculated = crc32fast::hash(records);
        if saved != 0 && saved != calculated {
            return Err(self.corrupt(McapError::BadChunkCrc { saved, calculated }));
        }
        let mut rest = records;
        while !rest.is_empty() {
            let Some((&[opcode, l0, l1, l2, l3, l4, l5, l6, l7], after)) =
                rest.split_first_chunk::<9>()
            else {
                return Err(self.corrupt(McapError::UnexpectedEoc));
            };
            let length = u64::from_le_bytes([l0, l1, l2, l3, l4, l5, l6, l7]);
            let length = match usize::try_from(length) {
                Ok(n) if n <= after.len() => n,
                _ => return Err(self.corrupt(McapError::UnexpectedEoc)),
            };
            let (body, after) = after.split_at(length);
            if opcode == op::CHUNK {
                // A chunk inside a chunk is not MCAP.
                return Err(self.corrupt(McapError::UnexpectedEoc));
            }
            self.take(opcode, body)?;
            rest = after;
        }
        Ok(())
    }
}

fn not_mcap(path: &Path) -> RecordingError {
    RecordingError::NotMcap {
        path: path.to_path_buf(),
    }
}

#[cfg(test)]
mod tests {
    use std::io::{BufRead, Cursor};
    use std::path::PathBuf;
    use std::process::{Command, Stdio};

    use foxglove::Decode;
    use foxglove::messages::PoseInFrame;
    use protocol::{
        Encoder, FixQuality, FixSource, GpsFixMsg, HeartbeatMsg, MAX_WIRE_LEN, Message, Position,
        RangeUnit, ScanMsg,
    };

    use super::*;
    use crate::PoseView;
    use crate::link::LinkReader;
    use crate::recording::topics::{GPS_LOCATION_TOPIC, POSE_LOCATION_TOPIC, POSE_TOPIC};
    use crate::recording::{
        Recorder, RecorderOptions, RecordingSummary, board_topic, existing_parts,
    };

    /// A fresh path in the temporary folder (removed when dropped).
    struct TempPath(PathBuf);

    impl TempPath {
        fn new(name: &str) -> Self {
            let path = std::env::temp_dir()
                .join(format!("host-recording-{}-{name}.mcap", std::process::id()));
            let _ = std::fs::remove_file(&path);
            TempPath(path)
        }
    }

    impl Drop for TempPath {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
            for index in 1.. {
                if std::fs::remove_file(part_path(&self.0, index)).is_err() {
                    break;
                }
            }
        }
    }

    fn options() -> RecorderOptions {
        RecorderOptions {
            sync_on_flush: false,
            ..Default::default()
        }
    }

    /// The board's message number `i` of a synthetic run: a heartbeat, with a scan every
    /// second message and a GPS fix every fifth.
    fn board_message(i: u32) -> Message {
        if i % 5 == 4 {
            Message::GpsFix(GpsFixMsg {
                stamp_us: u64::from(i) * 10_000,
                source: FixSource::Gga,
                talker: *b"GP",
                date: None,
                time: None,
                quality: FixQuality::Gps,
                position: Some(Position {
                    lat_ndeg: 48_000_000_000 + i64::from(i),
                    lon_ndeg: 11_000_000_000,
                }),
                alt_msl_mm: Some(500_000),
                geoid_sep_mm: None,
                num_sats: Some(8),
                hdop_centi: Some(110),
                speed_mm_s: None,
                course_cdeg: None,
                gst: None,
            })
        } else if i % 2 == 1 {
            let values = (0..181).map(|k| (k * 37 + i as u16) % 8000).collect();
            Message::Scan(ScanMsg {
                stamp_us: u64::from(i) * 10_000,
                scan_counter: i,
                start_angle_cdeg: 0,
                step_angle_cdeg: 100,
                unit: RangeUnit::Mm,
                count_word: 181,
                values,
                status: 0,
                sensor_indices: None,
            })
        } else {
            Message::Heartbeat(HeartbeatMsg {
                uptime_us: u64::from(i) * 10_000,
            })
        }
    }

    /// The wire bytes of `messages` board messages cut into reads of 1 to 300 bytes, so that
    /// frames straddle reads; read `k` arrives at host time `k · 0.01` s.
    fn synthetic_reads(messages: u32) -> Vec<(f64, Vec<u8>)> {
        let mut encoder = Encoder::new();
        let mut wire = Vec::new();
        let mut out = [0u8; MAX_WIRE_LEN];
        for i in 0..messages {
            wire.extend_from_slice(encoder.encode(&board_message(i), &mut out).unwrap());
        }
        let mut reads = Vec::new();
        let mut rest = wire.as_slice();
        let mut k = 0usize;
        while !rest.is_empty() {
            let n = (1 + (k * 131) % 300).min(rest.len());
            reads.push((k as f64 * 0.01, rest[..n].to_vec()));
            rest = &rest[n..];
            k += 1;
        }
        reads
    }

    /// Records `reads` as the daemon would: the raw bytes, then the messages they complete,
    /// then the pose, flushing after every `reads_per_flush` reads. Returns the decoded
    /// messages' topics in order.
    fn record(
        recorder: &mut Recorder,
        reads: &[(f64, Vec<u8>)],
        reads_per_flush: usize,
    ) -> Vec<&'static str> {
        let mut link = LinkReader::new();
        let mut topics = Vec::new();
        for (k, (t, bytes)) in reads.iter().enumerate() {
            recorder.record_bytes(*t, bytes).unwrap();
            for received in link.feed(bytes) {
                recorder
                    .record_message(*t, Some(*t - 0.005), &received)
                    .unwrap();
                topics.push(board_topic(received.message.kind()).unwrap());
                if matches!(received.message, Message::GpsFix(_)) {
                    topics.push(GPS_LOCATION_TOPIC);
                }
            }
            let pose = PoseView {
                x_m: k as f64,
                time_s: *t,
                ..Default::default()
            };
            recorder.record_pose(*t, &pose).unwrap();
            topics.push(POSE_TOPIC);
            if (k + 1) % reads_per_flush == 0 {
                recorder.flush().unwrap();
            }
        }
        topics
    }

    /// Records `reads` at `path` in parts of 0.2 s, flushing every 0.05 s and every 7 reads.
    fn record_in_parts(path: &Path, reads: &[(f64, Vec<u8>)]) -> RecordingSummary {
        let options = RecorderOptions {
            flush_interval_s: 0.05,
            part_length_s: Some(0.2),
            ..options()
        };
        let mut recorder = Recorder::create(path, options).unwrap();
        record(&mut recorder, reads, 7);
        recorder.finish().unwrap()
    }

    fn counts(topics: &[&str], raw_reads: usize) -> BTreeMap<String, u64> {
        let mut counts = BTreeMap::new();
        for topic in topics {
            *counts.entry(topic.to_string()).or_default() += 1;
        }
        counts.insert(RAW_TOPIC.to_string(), raw_reads as u64);
        counts
    }

    #[test]
    fn round_trip_gives_back_every_read_and_message() {
        let path = TempPath::new("round-trip");
        let reads = synthetic_reads(60);
        let mut recorder = Recorder::create(&path.0, options()).unwrap();
        let topics = record(&mut recorder, &reads, 7);
        let summary = recorder.finish().unwrap();

        let recording = read_recording(&path.0).unwrap();
        assert!(!recording.truncated);
        assert_eq!(recording.raw_reads.len(), reads.len());
        for (read, (t, bytes)) in recording.raw_reads.iter().zip(&reads) {
            assert_eq!(&read.bytes, bytes);
            assert!((read.recv_time_s - t).abs() < 1e-9);
        }
        let expected = counts(&topics, reads.len());
        assert_eq!(recording.message_counts, expected);
        assert_eq!(summary.message_counts, expected);
        assert!(summary.chunk_count >= (reads.len() / 7) as u32);
        // 60 messages: 12 fixes, 24 scans, 24 heartbeats.
        assert_eq!(expected["/board/gps_fix"], 12);
        assert_eq!(expected["/board/scan"], 24);

        // Replaying the raw reads decodes the same messages.
        let mut link = LinkReader::new();
        let replayed: usize = recording
            .raw_reads
            .iter()
            .map(|r| link.feed(&r.bytes).len())
            .sum();
        assert_eq!(replayed, 60);
    }

    #[test]
    fn a_recording_in_parts_reads_as_one_and_each_part_opens_alone() {
        let reads = synthetic_reads(60);
        let whole_path = TempPath::new("whole");
        let mut recorder = Recorder::create(
            &whole_path.0,
            RecorderOptions {
                part_length_s: None,
                ..options()
            },
        )
        .unwrap();
        record(&mut recorder, &reads, 7);
        let whole_summary = recorder.finish().unwrap();
        assert_eq!(whole_summary.parts, 1);
        let whole = read_recording(&whole_path.0).unwrap();

        let parts_path = TempPath::new("parts");
        let summary = record_in_parts(&parts_path.0, &reads);
        let span_s = reads.last().unwrap().0 - reads[0].0;
        assert!(
            summary.parts as f64 >= (span_s / 0.2).floor(),
            "{summary:?}"
        );
        assert_eq!(summary.message_counts, whole_summary.message_counts);

        // Read from the first part's path, the parts make the recording written in one file.
        let recording = read_recording(&parts_path.0).unwrap();
        assert_eq!((recording.parts, whole.parts), (summary.parts, 1));
        assert_eq!(
            Recording {
                parts: 1,
                ..recording
            },
            whole
        );
        // Each part is a finished MCAP file of its own, its records in order after the last.
        let mut raw_reads = Vec::new();
        let mut counted = BTreeMap::<String, u64>::new();
        for index in 0..summary.parts {
            let part = part_path(&parts_path.0, index);
            let alone = read_recording_from(File::open(&part).unwrap(), &part).unwrap();
            assert!(!alone.truncated, "{}", part.display());
            assert!(!alone.raw_reads.is_empty(), "{}", part.display());
            raw_reads.extend(alone.raw_reads);
            for (topic, count) in alone.message_counts {
                *counted.entry(topic).or_default() += count;
            }
        }
        assert_eq!(raw_reads, whole.raw_reads);
        assert_eq!(counted, whole.message_counts);
        assert!(!part_path(&parts_path.0, summary.parts).exists());
    }

    #[test]
    fn a_kill_in_a_later_part_keeps_every_part_before_it() {
        let reads = synthetic_reads(60);
        let path = TempPath::new("parts-killed");
        let summary = record_in_parts(&path.0, &reads);
        assert!(summary.parts >= 3, "{summary:?}");
        let earlier: usize = (0..summary.parts - 1)
            .map(|index| {
                let part = part_path(&path.0, index);
                let alone = read_recording_from(File::open(&part).unwrap(), &part).unwrap();
                alone.raw_reads.len()
            })
            .sum();
        // The last part killed right after it was opened, before (nothing on disk) and after
        // its magic reached the disk: the parts before it read whole.
        let last = part_path(&path.0, summary.parts - 1);
        let bytes = std::fs::read(&last).unwrap();
        for kept_bytes in [0, 8] {
            std::fs::write(&last, &bytes[..kept_bytes]).unwrap();
            let recording = read_recording(&path.0).unwrap();
            assert!(recording.truncated);
            // A part with no bytes is not one; one with its magic is, empty.
            assert_eq!(recording.parts, summary.parts - u32::from(kept_bytes == 0));
            assert_eq!(recording.raw_reads.len(), earlier);
            assert!(earlier > 0 && earlier < reads.len());
            for (read, (t, bytes)) in recording.raw_reads.iter().zip(&reads) {
                assert_eq!(&read.bytes, bytes);
                assert!((read.recv_time_s - t).abs() < 1e-9);
            }
        }

        // A part left in the way, whichever, stops a new recording at its start, not when it
        // reaches that part.
        std::fs::remove_file(&path.0).unwrap();
        for index in 0..summary.parts - 1 {
            let _ = std::fs::remove_file(part_path(&path.0, index));
        }
        assert_eq!(existing_parts(&path.0), vec![last.clone()]);
        let refused = Recorder::create(&path.0, RecorderOptions::default()).unwrap_err();
        assert!(
            matches!(&refused, RecordingError::Create { path: p, .. } if *p == last),
            "{refused}"
        );
    }

    #[test]
    fn camera_frames_come_back_in_time_order_beside_the_link() {
        let path = TempPath::new("camera");
        let reads = synthetic_reads(10);
        let mut recorder = Recorder::create(&path.0, options()).unwrap();
        record(&mut recorder, &reads, 4);
        // Frames as a camera thread hands them over: not in step with the link's reads.
        let frames: Vec<(f64, Vec<u8>)> = (0..5u8)
            .map(|i| (0.05 + 0.1 * f64::from(i), vec![0xFF, 0xD8, i, 0xFF, 0xD9]))
            .collect();
        for (t, jpeg) in frames.iter().rev() {
            recorder.record_image(*t, jpeg).unwrap();
        }
        recorder.finish().unwrap();

        let without = read_recording(&path.0).unwrap();
        assert!(without.camera_images.is_empty());
        assert_eq!(without.message_counts["/camera/image"], 5);
        let recording = read_recording_with_camera(&path.0).unwrap();
        assert_eq!(recording.raw_reads.len(), reads.len());
        assert_eq!(recording.camera_images_refused, 0);
        assert_eq!(recording.camera_images.len(), frames.len());
        for (image, (t, jpeg)) in recording.camera_images.iter().zip(&frames) {
            assert!((image.time_s - t).abs() < 1e-9);
            assert_eq!(&image.data, jpeg);
            assert_eq!(image.format, "jpeg");
        }
        assert_eq!(recording.message_counts["/camera/image"], 5);
    }

    #[test]
    fn file_opens_as_standard_mcap_with_json_schemas_and_foxglove_messages() {
        let path = TempPath::new("layout");
        let reads = synthetic_reads(10);
        let mut recorder = Recorder::create(&path.0, options()).unwrap();
        record(&mut recorder, &reads, 3);
        let pose = PoseView {
            x_m: 2.5,
            y_m: -1.0,
            lat_deg: Some(48.1),
            lon_deg: Some(11.5),
            time_s: 9.0,
            ..Default::default()
        };
        recorder.record_pose(9.0, &pose).unwrap();
        recorder.finish().unwrap();

        let bytes = std::fs::read(&path.0).unwrap();
        let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
        let by_topic: BTreeMap<_, _> = summary
            .channels
            .values()
            .map(|c| (c.topic.clone(), c.clone()))
            .collect();
        let scan = &by_topic["/board/scan"];
        assert_eq!(scan.message_encoding, "json");
        let schema = scan.schema.as_ref().unwrap();
        assert_eq!(schema.encoding, "jsonschema");
        let schema: serde_json::Value = serde_json::from_slice(&schema.data).unwrap();
        assert!(schema["properties"]["message"]["properties"]["values"].is_object());
        let pose_channel = &by_topic[POSE_TOPIC];
        assert_eq!(
            pose_channel.schema.as_ref().unwrap().name,
            "foxglove.PoseInFrame"
        );
        assert_eq!(
            by_topic[GPS_LOCATION_TOPIC].schema.as_ref().unwrap().name,
            "foxglove.LocationFix"
        );
        assert!(by_topic[RAW_TOPIC].schema.is_none());

        let mut last_pose = None;
        let mut last_location = None;
        for message in mcap::MessageStream::new(&bytes).unwrap() {
            let message = message.unwrap();
            if message.channel.message_encoding == "json" {
                let json: serde_json::Value = serde_json::from_slice(&message.data).unwrap();
                assert!(json["message"].is_object(), "{json}");
            }
            match message.channel.topic.as_str() {
                POSE_TOPIC => last_pose = Some(PoseInFrame::decode(&message.data[..]).unwrap()),
                POSE_LOCATION_TOPIC => last_location = Some(message.log_time),
                _ => {}
            }
        }
        let position = last_pose.unwrap().pose.unwrap().position.unwrap();
        assert_eq!((position.x, position.y), (2.5, -1.0));
        assert_eq!(last_location, Some(9_000_000_000));
    }

    #[test]
    fn same_calls_write_the_same_bytes() {
        let reads = synthetic_reads(20);
        let files: Vec<Vec<u8>> = ["det-a", "det-b"]
            .iter()
            .map(|name| {
                let path = TempPath::new(name);
                let mut recorder = Recorder::create(&path.0, options()).unwrap();
                record(&mut recorder, &reads, 5);
                recorder.finish().unwrap();
                std::fs::read(&path.0).unwrap()
            })
            .collect();
        assert_eq!(files[0], files[1]);
    }

    #[test]
    fn garbage_is_not_an_mcap_file() {
        let path = TempPath::new("garbage");
        std::fs::write(&path.0, b"time,x,y\n0.0,1.0,2.0\n").unwrap();
        let err = read_recording(&path.0).unwrap_err();
        assert!(matches!(err, RecordingError::NotMcap { .. }), "{err}");
        assert!(err.to_string().contains("not an MCAP file"), "{err}");

        std::fs::write(&path.0, b"").unwrap();
        assert!(matches!(
            read_recording(&path.0),
            Err(RecordingError::NotMcap { .. })
        ));

        // The magic, then a header record whose profile string is longer than the record:
        // damaged, not merely cut short.
        let mut bytes = mcap::MAGIC.to_vec();
        bytes.push(0x01);
        bytes.extend(4u64.to_le_bytes());
        bytes.extend([0xFF; 4]);
        bytes.extend(mcap::MAGIC);
        let err = read_recording_from(Cursor::new(bytes), &path.0).unwrap_err();
        assert!(
            matches!(
                err,
                RecordingError::FieldOverrun {
                    opcode: op::HEADER,
                    ..
                }
            ),
            "{err}"
        );

        // Found by the `recording` fuzz target: a channel record whose strings claim
        // 2³² − 1 bytes each (`host/fuzz/regressions/recording/`), refused before the MCAP
        // library reserves that much.
        let fuzzed = include_bytes!(
            "../../fuzz/regressions/recording/oom-ca07c197882ed31f8767e09228b7a7eb11f5d40c"
        );
        let err = read_recording_from(Cursor::new(&fuzzed[..]), &path.0).unwrap_err();
        assert!(
            matches!(
                err,
                RecordingError::FieldOverrun {
                    opcode: op::CHANNEL,
                    ..
                }
            ),
            "{err}"
        );
        assert!(err.to_string().contains("4294967295 bytes"), "{err}");

        // Found by the fuzz target too: a chunk that runs past the end of the file, whose
        // records claim more bytes than the chunk holds (the MCAP library's own chunk reader
        // underflows on it). Whole chunks only: a file cut inside its first chunk.
        let fuzzed = include_bytes!(
            "../../fuzz/regressions/recording/crash-74181488ac57713475ac160ca2a3e61bb59c4b97"
        );
        let cut = read_recording_from(Cursor::new(&fuzzed[..]), &path.0).unwrap();
        assert!(cut.truncated && cut.link.is_empty(), "{cut:?}");

        let missing = read_recording(Path::new("/nonexistent/run.mcap")).unwrap_err();
        assert!(matches!(missing, RecordingError::Open { .. }), "{missing}");
    }

    #[test]
    fn uncompressed_chunks_read_as_compressed_ones() {
        let reads = synthetic_reads(30);
        let recordings: Vec<Recording> = [true, false]
            .into_iter()
            .map(|compress| {
                let path = TempPath::new(&format!("compress-{compress}"));
                let options = RecorderOptions {
                    compress,
                    ..options()
                };
                let mut recorder = Recorder::create(&path.0, options).unwrap();
                record(&mut recorder, &reads, 4);
                recorder.finish().unwrap();
                read_recording(&path.0).unwrap()
            })
            .collect();
        assert_eq!(recordings[0], recordings[1]);
        assert_eq!(recordings[1].raw_reads.len(), reads.len());
        assert!(!recordings[1].truncated);
    }

    #[test]
    fn a_chunk_whose_records_overrun_it_is_refused() {
        // An uncompressed chunk holding one record that claims 100 bytes of the 9 there are.
        let mut records = vec![op::MESSAGE];
        records.extend(100u64.to_le_bytes());
        let mut chunk = Vec::new();
        chunk.extend(0u64.to_le_bytes()); // message start time
        chunk.extend(0u64.to_le_bytes()); // message end time
        chunk.extend((records.len() as u64).to_le_bytes()); // uncompressed size
        chunk.extend(0u32.to_le_bytes()); // no CRC
        chunk.extend(0u32.to_le_bytes()); // compression ""
        chunk.extend((records.len() as u64).to_le_bytes());
        chunk.extend(&records);
        let mut bytes = mcap::MAGIC.to_vec();
        bytes.push(op::CHUNK);
        bytes.extend((chunk.len() as u64).to_le_bytes());
        bytes.extend(chunk);
        let path = Path::new("overrun.mcap");
        let err = read_recording_from(Cursor::new(bytes), path).unwrap_err();
        assert!(
            matches!(
                err,
                RecordingError::Corrupt {
                    source: McapError::UnexpectedEoc,
                    ..
                }
            ),
            "{err}"
        );
        assert!(err.to_string().contains("overrun.mcap"), "{err}");
    }

    #[test]
    fn an_lz4_chunk_claiming_more_than_lz4_can_expand_is_refused() {
        // Ten compressed bytes that claim to hold 100 MB: no LZ4 frame expands that far.
        let mut chunk = Vec::new();
        chunk.extend(0u64.to_le_bytes()); // message start time
        chunk.extend(0u64.to_le_bytes()); // message end time
        chunk.extend(100_000_000u64.to_le_bytes()); // uncompressed size
        chunk.extend(0u32.to_le_bytes()); // no CRC
        chunk.extend(3u32.to_le_bytes());
        chunk.extend(b"lz4");
        chunk.extend(10u64.to_le_bytes());
        chunk.extend([0u8; 10]);
        let mut bytes = mcap::MAGIC.to_vec();
        bytes.push(op::CHUNK);
        bytes.extend((chunk.len() as u64).to_le_bytes());
        bytes.extend(chunk);
        let err = read_recording_from(Cursor::new(bytes), Path::new("claim.mcap")).unwrap_err();
        assert!(
            matches!(
                err,
                RecordingError::Corrupt {
                    source: McapError::BadChunkLength {
                        header: 100_000_000,
                        available: 10,
                    },
                    ..
                }
            ),
            "{err}"
        );
    }

    #[test]
    fn file_cut_anywhere_keeps_the_complete_chunks() {
        let path = TempPath::new("cut");
        let reads = synthetic_reads(40);
        let per_flush = 4;
        let options = RecorderOptions {
            flush_interval_s: 1e9,
            chunk_size: None,
            ..options()
        };
        let mut recorder = Recorder::create(&path.0, options).unwrap();
        record(&mut recorder, &reads, per_flush);
        recorder.finish().unwrap();
        let bytes = std::fs::read(&path.0).unwrap();
        let full = read_recording_from(Cursor::new(&bytes), &path.0).unwrap();
        assert!(!full.truncated);

        let mut previous = 0;
        for cut in (8..bytes.len()).step_by(13) {
            let part = read_recording_from(Cursor::new(&bytes[..cut]), &path.0)
                .unwrap_or_else(|e| panic!("cut at {cut}: {e}"));
            assert!(part.truncated, "cut at {cut}");
            let n = part.raw_reads.len();
            assert!(n >= previous, "cut at {cut}: {n} < {previous}");
            assert_eq!(part.raw_reads[..], full.raw_reads[..n], "cut at {cut}");
            // Only whole chunks: each holds `per_flush` reads (the last may hold fewer).
            assert!(
                n.is_multiple_of(per_flush) || n == reads.len(),
                "cut at {cut}: {n}"
            );
            previous = n;
        }
        // Cut before the summary, the file still gives back every read.
        assert_eq!(previous, reads.len());
    }

    #[test]
    fn recorder_flushes_by_itself_as_recorded_time_passes() {
        let path = TempPath::new("auto-flush");
        let reads = synthetic_reads(400);
        let duration_s = reads.last().unwrap().0;
        assert!(duration_s > 3.0, "{duration_s}");
        let options = RecorderOptions {
            flush_interval_s: 1.0,
            chunk_size: None,
            ..options()
        };
        let mut recorder = Recorder::create(&path.0, options).unwrap();
        for (t, bytes) in &reads {
            recorder.record_bytes(*t, bytes).unwrap();
        }
        // Die without finishing: nothing buffered reaches the file.
        std::mem::forget(recorder);
        let recording = read_recording(&path.0).unwrap();
        assert!(recording.truncated);
        let last_s = recording.raw_reads.last().unwrap().recv_time_s;
        assert!(last_s >= duration_s - 1.0, "{last_s} of {duration_s}");
        assert!(recording.raw_reads.len() < reads.len());
    }

    /// Set to the recording path, selects the child's part of the kill test.
    const KILL_CHILD_ENV: &str = "HOST_RECORDING_KILL_CHILD";
    /// Reads between two flushes in the child.
    const CHILD_READS_PER_FLUSH: usize = 10;

    /// The child process of [`recording_survives_kill_9`]: records without end and says on
    /// stdout after each flush how many reads are flushed. Without the variable it does
    /// nothing.
    #[test]
    #[ignore = "child process of recording_survives_kill_9"]
    fn kill_child_records_until_killed() {
        let Some(path) = std::env::var_os(KILL_CHILD_ENV) else {
            return;
        };
        let options = RecorderOptions {
            flush_interval_s: 1e9,
            chunk_size: None,
            ..options()
        };
        let mut recorder = Recorder::create(Path::new(&path), options).unwrap();
        let reads = synthetic_reads(2_000);
        let mut link = LinkReader::new();
        let start = std::time::Instant::now();
        // Bounded, should the parent die before killing us.
        for (k, (t, bytes)) in reads.iter().enumerate() {
            recorder.record_bytes(*t, bytes).unwrap();
            for received in link.feed(bytes) {
                recorder.record_message(*t, None, &received).unwrap();
            }
            if (k + 1) % CHILD_READS_PER_FLUSH == 0 {
                recorder.flush().unwrap();
                println!("flushed {}", k + 1);
            }
            std::thread::sleep(std::time::Duration::from_millis(2));
            if start.elapsed().as_secs() > 60 {
                break;
            }
        }
        // Never finish: the parent kills us first, or the file stays unfinished.
        std::mem::forget(recorder);
    }

    #[test]
    fn recording_survives_kill_9() {
        use std::os::unix::process::ExitStatusExt;

        let path = TempPath::new("kill-9");
        let test_name = format!(
            "{}::kill_child_records_until_killed",
            module_path!().trim_start_matches("host::")
        );
        let mut child = Command::new(std::env::current_exe().unwrap())
            .args([&test_name, "--exact", "--ignored", "--nocapture"])
            .env(KILL_CHILD_ENV, &path.0)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        // Kept open until the child is dead: a closed pipe would make its next print fail.
        let mut lines = io::BufReader::new(child.stdout.take().unwrap()).lines();
        let mut flushed = 0;
        for line in lines.by_ref() {
            if let Some(n) = line.unwrap().strip_prefix("flushed ") {
                flushed = n.parse().unwrap();
                if flushed >= 5 * CHILD_READS_PER_FLUSH {
                    break;
                }
            }
        }
        // `Child::kill` sends SIGKILL on Unix.
        child.kill().unwrap();
        let status = child.wait().unwrap();
        assert_eq!(status.signal(), Some(9), "{status:?}");
        drop(lines);
        assert!(
            flushed >= 5 * CHILD_READS_PER_FLUSH,
            "child flushed {flushed}"
        );

        let recording = read_recording(&path.0).unwrap();
        assert!(recording.truncated);
        let n = recording.raw_reads.len();
        assert!(n >= flushed, "{n} < {flushed}");
        assert!(n.is_multiple_of(CHILD_READS_PER_FLUSH), "{n}");
        let expected = synthetic_reads(2_000);
        for (read, (t, bytes)) in recording.raw_reads.iter().zip(&expected) {
            assert_eq!(&read.bytes, bytes);
            assert!((read.recv_time_s - t).abs() < 1e-9);
        }
        // The decoded messages of the flushed reads are all there too.
        let mut link = LinkReader::new();
        let decoded: Vec<_> = recording
            .raw_reads
            .iter()
            .flat_map(|r| link.feed(&r.bytes))
            .collect();
        let scans = decoded
            .iter()
            .filter(|r| matches!(r.message, Message::Scan(_)))
            .count() as u64;
        assert!(scans > 0);
        assert_eq!(recording.message_counts["/board/scan"], scans);
    }
}
