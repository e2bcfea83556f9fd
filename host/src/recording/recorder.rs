//! Writes a run to an MCAP file as it happens, so that it opens in Foxglove and replays.
//!
//! Three kinds of channel:
//!
//! * [`RAW_TOPIC`]: every read from the serial port, byte for byte, schemaless. Replay feeds
//!   these to a [`crate::link::LinkReader`] again and gets the run back exactly.
//! * one channel per board message kind ([`super::board_topic`]): the decoded message as JSON
//!   with a JSON schema derived from the protocol's types;
//! * the host's outputs as Foxglove's well-known messages: the pose estimate
//!   (`foxglove.PoseInFrame` on [`POSE_TOPIC`], `foxglove.LocationFix` on
//!   [`POSE_LOCATION_TOPIC`] once geo-referenced) and each GPS fix (`foxglove.LocationFix`
//!   on [`GPS_LOCATION_TOPIC`]).
//!
//! Every message's log time is the host time the caller gives, `round(time_s · 10⁹)` ns; the
//! recorder reads no clock, so the same calls write the same bytes.
//!
//! **Surviving a kill.** Chunks are built in memory and written whole, then indexed. A flush
//! ([`Recorder::flush`], and by itself once `flush_interval_s` of recorded time has passed)
//! ends the chunk and hands it to the operating system, optionally syncing it to the storage
//! device. If the process dies, the file holds every flushed chunk and
//! [`super::read_recording`] reads them back; only the summary and footer, which
//! [`Recorder::finish`] writes, are missing.
//!
//! **Parts.** An MCAP writer keeps an index entry for every chunk it has written until it
//! writes the file's summary, so one file recorded for a day would grow the recorder's memory
//! with the day. After [`RecorderOptions::part_length_s`] of recorded time the recorder
//! finishes the file, summary and all, and goes on in the next part: `run.mcap`, then
//! `run_1.mcap`, `run_2.mcap`, … ([`part_path`]), each a whole MCAP file that opens on its
//! own. [`super::read_recording`] reads the parts in order as one recording.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use foxglove::Encode;
use mcap::records::MessageHeader;
use protocol::{Message, PROTOCOL_VERSION, Received};

use super::board_message::{BoardChannel, board_channel, board_json};
use super::durable_file::DurableFile;
use super::error::RecordingError;
use super::foxglove_messages::{camera_image, gps_location, pose_in_frame, pose_location};
use super::topics::{
    CAMERA_IMAGE_TOPIC, GPS_LOCATION_TOPIC, POSE_LOCATION_TOPIC, POSE_TOPIC, RAW_ENCODING,
    RAW_TOPIC, RECONNECT_TOPIC, SENT_TOPIC,
};
use crate::PoseView;

/// Options of [`Recorder`].
#[derive(Debug, Clone, PartialEq)]
pub struct RecorderOptions {
    /// Recorded time after which the recorder flushes by itself, s. A kill loses at most the
    /// messages of this last stretch (plus what arrived since the caller's last flush).
    pub flush_interval_s: f64,
    /// Uncompressed size at which a chunk ends before the next flush, bytes; `None`: chunks
    /// end only at flushes.
    pub chunk_size: Option<u64>,
    /// Compress chunks with LZ4 (JSON scans shrink several times).
    pub compress: bool,
    /// Make each flush wait until the data is on the storage device, so that flushed chunks
    /// survive a power cut too, not only a killed process.
    pub sync_on_flush: bool,
    /// Recorded time after which the recording goes on in its next part, s (see the
    /// [module documentation](self)); `None`: one file, whose index grows with the time
    /// recorded.
    pub part_length_s: Option<f64>,
}

impl Default for RecorderOptions {
    fn default() -> Self {
        RecorderOptions {
            flush_interval_s: 1.0,
            chunk_size: Some(1024 * 1024),
            compress: true,
            sync_on_flush: true,
            part_length_s: Some(600.0),
        }
    }
}

/// What a finished recording holds.
#[derive(Debug, Clone, PartialEq, Eq, Default, serde::Serialize)]
pub struct RecordingSummary {
    /// Messages per topic (topics without messages are left out).
    pub message_counts: BTreeMap<String, u64>,
    /// Chunks written, over every part.
    pub chunk_count: u32,
    /// Files written: the first, then its parts ([`part_path`]).
    pub parts: u32,
}

/// The file of part `index` of the recording at `path`: `path` itself for part 0, else
/// `path` with `_<index>` after its stem (`run.mcap`: `run_1.mcap`, `run_2.mcap`, …).
pub fn part_path(path: &Path, index: u32) -> PathBuf {
    if index == 0 {
        return path.to_path_buf();
    }
    let mut name = path.file_stem().unwrap_or_default().to_os_string();
    name.push(format!("_{index}"));
    if let Some(extension) = path.extension() {
        name.push(".");
        name.push(extension);
    }
    path.with_file_name(name)
}

/// The files beside `path` named as its further parts ([`part_path`] of any index from 1),
/// in no particular order.
pub fn existing_parts(path: &Path) -> Vec<PathBuf> {
    let folder = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    let Ok(entries) = std::fs::read_dir(folder) else {
        return Vec::new();
    };
    // A name is a part's when `part_path` gives it back from the index after its last `_`.
    let is_part = |candidate: &Path| {
        let name = candidate.file_stem().unwrap_or_default().to_string_lossy();
        name.rsplit_once('_')
            .and_then(|(_, index)| index.parse::<u32>().ok())
            .is_some_and(|index| {
                index >= 1 && part_path(path, index).file_name() == candidate.file_name()
            })
    };
    entries
        .filter_map(Result::ok)
        .map(|entry| entry.path())
        .filter(|candidate| is_part(candidate))
        .collect()
}

/// A channel of the current part and the sequence number of its next message (which carries
/// on from one part to the next).
#[derive(Debug, Clone, Copy)]
struct ChannelState {
    id: u16,
    next_sequence: u32,
}

/// Records a run into an MCAP file. See the [module documentation](self).
///
/// Dropping a recorder finishes the file as [`Recorder::finish`] does but ignores errors.
pub struct Recorder {
    writer: mcap::Writer<DurableFile>,
    write_options: mcap::WriteOptions,
    sync_on_flush: bool,
    /// The first part's file, which names the recording.
    first_path: PathBuf,
    /// The current part's file, and its index.
    path: PathBuf,
    part: u32,
    flush_interval_s: f64,
    part_length_s: Option<f64>,
    /// The current part's channels (each part adds its own).
    channels: HashMap<&'static str, ChannelState>,
    /// Sequence numbers of the channels of the parts finished.
    next_sequences: HashMap<&'static str, u32>,
    /// What the finished parts hold.
    finished: RecordingSummary,
    /// Recorded time of the last flush, s (`None` before the first record).
    last_flush_s: Option<f64>,
    /// Recorded time of the current part's first record, s.
    part_start_s: Option<f64>,
    /// Latest time recorded, s (`None` before the first record).
    latest_s: Option<f64>,
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder")
            .field("path", &self.path)
            .field("channels", &self.channels.keys())
            .finish_non_exhaustive()
    }
}

impl Recorder {
    /// Creates the recording at `path`, which must not exist yet (nor any file named as one
    /// of its further parts, [`existing_parts`]), and writes its header and the raw channel
    /// to disk.
    ///
    /// # Errors
    /// [`RecordingError::InvalidOptions`] for a flush interval or a part length that is not
    /// a positive number, [`RecordingError::Create`] if the file or a file named as one of
    /// its further parts exists or the file cannot be created, [`RecordingError::Write`] if the header cannot
    /// be written.
    pub fn create(path: &Path, options: RecorderOptions) -> Result<Recorder, RecordingError> {
        for (name, value) in [
            ("flush_interval_s", Some(options.flush_interval_s)),
            ("part_length_s", options.part_length_s),
        ] {
            // NaN is refused too.
            if let Some(value) = value
                && value.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            {
                return Err(RecordingError::InvalidOptions(format!(
                    "{name} must be a positive number of seconds, got {value}"
                )));
            }
        }
        // A part left from an earlier recording would stop this one when it reaches it, and
        // would be read as part of it.
        if let Some(in_the_way) = existing_parts(path).into_iter().next() {
            return Err(RecordingError::Create {
                path: in_the_way,
                source: std::io::Error::new(
                    std::io::ErrorKind::AlreadyExists,
                    "a part of an earlier recording is in the way",
                ),
            });
        }
        let write_options = mcap::WriteOptions::new()
            // Profile "": no ROS conventions; Foxglove reads the schemas as given.
            .profile("")
            .compression(options.compress.then_some(mcap::Compression::Lz4))
            .chunk_size(options.chunk_size)
            // Build each chunk in memory and write it whole: the file never holds a chunk
            // whose header is still to be patched.
            .disable_seeking(true);
        let writer = create_part(path, &write_options, options.sync_on_flush)?;
        let mut recorder = Recorder {
            writer,
            write_options,
            sync_on_flush: options.sync_on_flush,
            first_path: path.to_path_buf(),
            path: path.to_path_buf(),
            part: 0,
            flush_interval_s: options.flush_interval_s,
            part_length_s: options.part_length_s,
            channels: HashMap::new(),
            next_sequences: HashMap::new(),
            finished: RecordingSummary::default(),
            last_flush_s: None,
            part_start_s: None,
            latest_s: None,
        };
        recorder.ensure_raw_channel()?;
        recorder.flush_part()?;
        Ok(recorder)
    }

    /// The file being written: the recording's first, or the part it has reached.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Records one read from the serial port: `bytes` exactly as received, at host time
    /// `recv_time_s`.
    ///
    /// # Errors
    /// [`RecordingError::InvalidTime`] for a negative or non-finite time,
    /// [`RecordingError::Write`] if the file cannot be written.
    pub fn record_bytes(&mut self, recv_time_s: f64, bytes: &[u8]) -> Result<(), RecordingError> {
        let log_time_ns = time_ns(recv_time_s)?;
        self.ensure_raw_channel()?;
        self.write(RAW_TOPIC, log_time_ns, log_time_ns, bytes)?;
        self.after_record(recv_time_s)
    }

    /// Records one write to the serial port: `bytes` exactly as sent, at host time
    /// `sent_time_s`.
    ///
    /// # Errors
    /// As [`Self::record_bytes`].
    pub fn record_sent(&mut self, sent_time_s: f64, bytes: &[u8]) -> Result<(), RecordingError> {
        let log_time_ns = time_ns(sent_time_s)?;
        self.ensure_schemaless_channel(SENT_TOPIC)?;
        self.write(SENT_TOPIC, log_time_ns, log_time_ns, bytes)?;
        self.after_record(sent_time_s)
    }

    /// Records that the serial port was reopened at host time `time_s`.
    ///
    /// # Errors
    /// As [`Self::record_bytes`].
    pub fn record_reconnect(&mut self, time_s: f64) -> Result<(), RecordingError> {
        let log_time_ns = time_ns(time_s)?;
        self.ensure_schemaless_channel(RECONNECT_TOPIC)?;
        self.write(RECONNECT_TOPIC, log_time_ns, log_time_ns, &[])?;
        self.after_record(time_s)
    }

    /// Records one decoded message on its kind's channel, at host time `recv_time_s` (the log
    /// time), with its board stamp mapped to host time `host_time_s` when the clock is
    /// synchronised (the publish time; the receive time otherwise). A GPS fix with a position
    /// is also recorded as a `foxglove.LocationFix`.
    ///
    /// # Errors
    /// [`RecordingError::InvalidTime`] for a negative or non-finite `recv_time_s`,
    /// [`RecordingError::Write`] if the file cannot be written.
    pub fn record_message(
        &mut self,
        recv_time_s: f64,
        host_time_s: Option<f64>,
        received: &Received,
    ) -> Result<(), RecordingError> {
        let log_time_ns = time_ns(recv_time_s)?;
        let publish_time_ns = host_time_s
            .and_then(|t| time_ns(t).ok())
            .unwrap_or(log_time_ns);
        let channel = board_channel(&received.message);
        self.ensure_json_channel(channel)?;
        let data =
            board_json(received, recv_time_s, host_time_s).map_err(|e| RecordingError::Encode {
                topic: channel.topic,
                reason: e.to_string(),
            })?;
        self.write(channel.topic, log_time_ns, publish_time_ns, &data)?;
        if let Message::GpsFix(fix) = &received.message
            && let Some(location) = gps_location(host_time_s.unwrap_or(recv_time_s), fix)
        {
            self.write_foxglove(GPS_LOCATION_TOPIC, log_time_ns, publish_time_ns, &location)?;
        }
        self.after_record(recv_time_s)
    }

    /// Records the pose estimate at host time `time_s`: in the map frame, and in WGS84 once
    /// the map is geo-referenced.
    ///
    /// # Errors
    /// [`RecordingError::InvalidTime`] for a negative or non-finite time,
    /// [`RecordingError::Write`] if the file cannot be written.
    pub fn record_pose(&mut self, time_s: f64, pose: &PoseView) -> Result<(), RecordingError> {
        let time_ns = time_ns(time_s)?;
        self.write_foxglove(POSE_TOPIC, time_ns, time_ns, &pose_in_frame(pose))?;
        if let Some(location) = pose_location(pose) {
            self.write_foxglove(POSE_LOCATION_TOPIC, time_ns, time_ns, &location)?;
        }
        self.after_record(time_s)
    }

    /// Records a camera frame taken at host time `time_s`, as JPEG
    /// (`foxglove.CompressedImage` on [`CAMERA_IMAGE_TOPIC`]).
    ///
    /// # Errors
    /// [`RecordingError::InvalidTime`] for a negative or non-finite time,
    /// [`RecordingError::Write`] if the file cannot be written.
    pub fn record_image(&mut self, time_s: f64, jpeg: &[u8]) -> Result<(), RecordingError> {
        let time_ns = time_ns(time_s)?;
        self.write_foxglove(
            CAMERA_IMAGE_TOPIC,
            time_ns,
            time_ns,
            &camera_image(time_s, jpeg),
        )?;
        self.after_record(time_s)
    }

    /// Ends the current chunk and writes it to the file (and to the storage device with
    /// [`RecorderOptions::sync_on_flush`]). Everything recorded so far then survives a kill.
    /// Once the current part holds [`RecorderOptions::part_length_s`], it is finished
    /// instead and the recording goes on in the next one.
    ///
    /// # Errors
    /// [`RecordingError::Write`] if the file cannot be written, [`RecordingError::Create`]
    /// if the next part cannot be created (the current one is flushed and stays in use).
    pub fn flush(&mut self) -> Result<(), RecordingError> {
        let part_is_due = match (self.part_length_s, self.part_start_s, self.latest_s) {
            (Some(length_s), Some(start_s), Some(latest_s)) => latest_s - start_s >= length_s,
            _ => false,
        };
        if part_is_due {
            self.start_next_part()
        } else {
            self.flush_part()
        }
    }

    /// Ends the current chunk and writes it to the current part's file.
    fn flush_part(&mut self) -> Result<(), RecordingError> {
        self.writer
            .flush()
            .map_err(|source| RecordingError::Write {
                path: self.path.clone(),
                source,
            })?;
        self.last_flush_s = self.latest_s;
        Ok(())
    }

    /// Ends the last chunk and writes the summary (statistics, indexes) and the footer.
    ///
    /// # Errors
    /// [`RecordingError::Write`] if the file cannot be written.
    pub fn finish(self) -> Result<RecordingSummary, RecordingError> {
        let Recorder {
            writer,
            path,
            channels,
            mut finished,
            ..
        } = self;
        finish_part(writer, &path, &channels, &mut finished)?;
        Ok(finished)
    }

    /// Finishes the current part and goes on in the next one. The next part's header and
    /// raw channel are on disk before the current part is finished, so a kill at any moment
    /// leaves every part readable.
    fn start_next_part(&mut self) -> Result<(), RecordingError> {
        let next_path = part_path(&self.first_path, self.part + 1);
        let next = match create_part(&next_path, &self.write_options, self.sync_on_flush) {
            Ok(next) => next,
            Err(error) => {
                // Keep recording into the current part.
                self.flush_part()?;
                return Err(error);
            }
        };
        let writer = std::mem::replace(&mut self.writer, next);
        let channels = std::mem::take(&mut self.channels);
        for (topic, state) in &channels {
            self.next_sequences.insert(topic, state.next_sequence);
        }
        let finished_path = std::mem::replace(&mut self.path, next_path);
        self.part += 1;
        self.part_start_s = None;
        self.ensure_raw_channel()?;
        self.flush_part()?;
        finish_part(writer, &finished_path, &channels, &mut self.finished)
    }

    /// Flushes once `flush_interval_s` of recorded time has passed since the last flush (which
    /// goes on in the next part once the current one holds `part_length_s`).
    fn after_record(&mut self, time_s: f64) -> Result<(), RecordingError> {
        self.latest_s = Some(
            self.latest_s
                .map_or(time_s, |latest_s| latest_s.max(time_s)),
        );
        self.part_start_s.get_or_insert(time_s);
        match self.last_flush_s {
            None => self.last_flush_s = Some(time_s),
            Some(last_s) if time_s - last_s >= self.flush_interval_s => self.flush()?,
            Some(_) => {}
        }
        Ok(())
    }

    fn ensure_raw_channel(&mut self) -> Result<(), RecordingError> {
        self.ensure_channel(RAW_TOPIC, |writer| {
            let metadata =
                BTreeMap::from([("protocol_version".to_string(), PROTOCOL_VERSION.to_string())]);
            writer.add_channel(0, RAW_TOPIC, RAW_ENCODING, &metadata)
        })
    }

    fn ensure_schemaless_channel(&mut self, topic: &'static str) -> Result<(), RecordingError> {
        self.ensure_channel(topic, |writer| {
            writer.add_channel(0, topic, RAW_ENCODING, &BTreeMap::new())
        })
    }

    fn ensure_json_channel(&mut self, channel: BoardChannel) -> Result<(), RecordingError> {
        self.ensure_channel(channel.topic, |writer| {
            let schema_id =
                writer.add_schema(channel.schema_name, "jsonschema", &(channel.schema)())?;
            writer.add_channel(schema_id, channel.topic, "json", &BTreeMap::new())
        })
    }

    /// Adds the channel `topic` with `add` unless the file has it already.
    fn ensure_channel(
        &mut self,
        topic: &'static str,
        add: impl FnOnce(&mut mcap::Writer<DurableFile>) -> mcap::McapResult<u16>,
    ) -> Result<(), RecordingError> {
        if !self.channels.contains_key(topic) {
            let id = add(&mut self.writer).map_err(|source| RecordingError::Write {
                path: self.path.clone(),
                source,
            })?;
            self.channels.insert(
                topic,
                ChannelState {
                    id,
                    next_sequence: self.next_sequences.get(topic).copied().unwrap_or(0),
                },
            );
        }
        Ok(())
    }

    /// Writes a Foxglove message on `topic`, adding the channel with the message's own schema.
    fn write_foxglove<T: Encode>(
        &mut self,
        topic: &'static str,
        log_time_ns: u64,
        publish_time_ns: u64,
        message: &T,
    ) -> Result<(), RecordingError> {
        self.ensure_channel(topic, |writer| {
            let schema_id = match T::get_schema() {
                Some(schema) => writer.add_schema(&schema.name, &schema.encoding, &schema.data)?,
                None => 0,
            };
            writer.add_channel(
                schema_id,
                topic,
                &T::get_message_encoding(),
                &BTreeMap::new(),
            )
        })?;
        let mut data = Vec::with_capacity(message.encoded_len().unwrap_or(256));
        message
            .encode(&mut data)
            .map_err(|e| RecordingError::Encode {
                topic,
                reason: e.to_string(),
            })?;
        self.write(topic, log_time_ns, publish_time_ns, &data)
    }

    /// Writes one message on the (already added) channel `topic`.
    fn write(
        &mut self,
        topic: &'static str,
        log_time_ns: u64,
        publish_time_ns: u64,
        data: &[u8],
    ) -> Result<(), RecordingError> {
        let Some(channel) = self.channels.get_mut(topic) else {
            // Every caller adds the channel first.
            return Err(RecordingError::Encode {
                topic,
                reason: "channel not added".into(),
            });
        };
        let header = MessageHeader {
            channel_id: channel.id,
            sequence: channel.next_sequence,
            log_time: log_time_ns,
            publish_time: publish_time_ns,
        };
        channel.next_sequence = channel.next_sequence.wrapping_add(1);
        self.writer
            .write_to_known_channel(&header, data)
            .map_err(|source| RecordingError::Write {
                path: self.path.clone(),
                source,
            })
    }
}

/// Writes the summary and footer of the part at `path` whose channels are `channels`, and
/// adds what it holds to `finished`.
fn finish_part(
    mut writer: mcap::Writer<DurableFile>,
    path: &Path,
    channels: &HashMap<&'static str, ChannelState>,
    finished: &mut RecordingSummary,
) -> Result<(), RecordingError> {
    let write_error = |source| RecordingError::Write {
        path: path.to_path_buf(),
        source,
    };
    let summary = writer.finish().map_err(write_error)?;
    writer
        .into_inner()
        .flush()
        .map_err(|e| write_error(e.into()))?;
    let topic_of: HashMap<u16, &str> = channels
        .iter()
        .map(|(topic, state)| (state.id, *topic))
        .collect();
    let stats = summary.stats.unwrap_or_default();
    for (id, &count) in &stats.channel_message_counts {
        let topic = topic_of.get(id).copied().unwrap_or("?");
        *finished
            .message_counts
            .entry(topic.to_string())
            .or_default() += count;
    }
    finished.chunk_count += stats.chunk_count;
    finished.parts += 1;
    Ok(())
}

/// Creates the file of a part, which must not exist yet, and an MCAP writer on it.
fn create_part(
    path: &Path,
    write_options: &mcap::WriteOptions,
    sync_on_flush: bool,
) -> Result<mcap::Writer<DurableFile>, RecordingError> {
    let file = File::create_new(path).map_err(|source| RecordingError::Create {
        path: path.to_path_buf(),
        source,
    })?;
    write_options
        .clone()
        .create(DurableFile::new(file, sync_on_flush))
        .map_err(|source| RecordingError::Write {
            path: path.to_path_buf(),
            source,
        })
}

/// Host time `time_s` as MCAP nanoseconds, `round(time_s · 10⁹)`.
///
/// # Errors
/// [`RecordingError::InvalidTime`] for a negative, non-finite or too large time.
pub(crate) fn time_ns(time_s: f64) -> Result<u64, RecordingError> {
    let ns = (time_s * 1e9).round();
    // 2⁶⁴ is exactly representable; every float below it fits in a u64. NaN is outside.
    if (0.0..18_446_744_073_709_551_616.0).contains(&ns) {
        Ok(ns as u64)
    } else {
        Err(RecordingError::InvalidTime { time_s })
    }
}

/// MCAP nanoseconds as host time, s.
pub(crate) fn time_s(time_ns: u64) -> f64 {
    time_ns as f64 / 1e9
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_names_part_path_gives_are_parts() {
        let folder =
            std::env::temp_dir().join(format!("host-recording-parts-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&folder);
        std::fs::create_dir_all(&folder).unwrap();
        let names = [
            "run.mcap",
            "run_1.mcap",
            "run_12.mcap",
            "run_01.mcap",
            "run_0.mcap",
            "run_x.mcap",
            "run_2.txt",
            "other_3.mcap",
            "run_run_4.mcap",
        ];
        for name in names {
            std::fs::write(folder.join(name), b"").unwrap();
        }
        let path = folder.join("run.mcap");
        assert_eq!(part_path(&path, 12), folder.join("run_12.mcap"));
        let mut parts = existing_parts(&path);
        parts.sort();
        assert_eq!(
            parts,
            vec![folder.join("run_1.mcap"), folder.join("run_12.mcap")]
        );
        std::fs::remove_dir_all(&folder).unwrap();
    }

    #[test]
    fn times_round_to_nanoseconds() {
        assert_eq!(time_ns(1.5).unwrap(), 1_500_000_000);
        assert_eq!(time_ns(0.000_000_000_6).unwrap(), 1);
        assert_eq!(time_ns(0.0).unwrap(), 0);
        for bad in [-1e-3, f64::NAN, f64::INFINITY, 1e11] {
            assert!(
                matches!(time_ns(bad), Err(RecordingError::InvalidTime { .. })),
                "{bad}"
            );
        }
        let t = 1_234.567_891_234;
        assert!((time_s(time_ns(t).unwrap()) - t).abs() < 1e-9);
    }

    #[test]
    fn refuses_bad_options_and_existing_files() {
        let path =
            std::env::temp_dir().join(format!("recorder-options-{}.mcap", std::process::id()));
        let bad = RecorderOptions {
            flush_interval_s: f64::NAN,
            ..Default::default()
        };
        assert!(matches!(
            Recorder::create(&path, bad),
            Err(RecordingError::InvalidOptions(_))
        ));
        let recorder = Recorder::create(&path, RecorderOptions::default()).unwrap();
        let again = Recorder::create(&path, RecorderOptions::default());
        assert!(
            matches!(again, Err(RecordingError::Create { .. })),
            "{again:?}"
        );
        recorder.finish().unwrap();
        std::fs::remove_file(&path).unwrap();
        let bad = RecorderOptions {
            part_length_s: Some(0.0),
            ..Default::default()
        };
        assert!(matches!(
            Recorder::create(&path, bad),
            Err(RecordingError::InvalidOptions(_))
        ));
    }

    #[test]
    fn parts_are_named_after_the_first() {
        let first = Path::new("/data/run.mcap");
        assert_eq!(part_path(first, 0), first);
        assert_eq!(part_path(first, 1), Path::new("/data/run_1.mcap"));
        assert_eq!(part_path(first, 12), Path::new("/data/run_12.mcap"));
        assert_eq!(part_path(Path::new("run"), 2), Path::new("run_2"));
    }
}
