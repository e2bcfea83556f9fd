//! Every pose of a run that has no set end, in memory bounded however long it runs.
//!
//! The daemon places a pose per scan, tens a second, for hours. The history keeps the newest
//! poses in memory and moves older ones, in blocks, to an unnamed temporary file (removed by
//! the operating system when the history is dropped), so its memory stays flat. The file goes
//! to [`PoseHistoryOptions::folder`], else to the temporary folder (`TMPDIR`, else `/tmp`,
//! which may be a RAM disk). What the
//! live view draws comes from a thinned copy of at most
//! [`PoseHistoryOptions::max_shown`] poses, evenly spaced in index, kept up to date as poses
//! arrive; the whole history is read back only at the end, for the exported trajectory.
//!
//! Should the temporary file fail (no temporary folder, a full disk), poses stay in memory:
//! nothing is lost, the history only stops being bounded.

use std::fs::File;
use std::io::{self, BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::PathBuf;

use super::StampedPose;
use super::frames::compose_pose;
use crate::geometry::Pose2;

/// Bytes a pose takes in the file: time, x, y and heading as little-endian `f64`.
const ROW_BYTES: usize = 32;

/// How much the history keeps in memory, and where the rest goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PoseHistoryOptions {
    /// Newest poses kept in memory; a full block moves to the file. Default 1 024 (half a
    /// minute of scans at 37.5 Hz, 32 KiB).
    pub block_rows: usize,
    /// Most poses in the thinned copy the live view draws.
    pub max_shown: usize,
    /// The folder of the file; the temporary folder when `None`.
    pub folder: Option<PathBuf>,
}

impl Default for PoseHistoryOptions {
    fn default() -> Self {
        PoseHistoryOptions {
            block_rows: 1_024,
            max_shown: 2_000,
            folder: None,
        }
    }
}

/// The poses of a run, oldest first. See the [module documentation](self).
#[derive(Debug)]
pub struct PoseHistory {
    options: PoseHistoryOptions,
    /// Poses moved to the file, and the file (created with the first full block).
    spilled_rows: usize,
    file: Option<File>,
    /// Whether writing a block failed once: poses then stay in memory.
    file_failed: bool,
    /// Why re-expressing the file's poses failed, if it did: they cannot be read back right.
    transform_failure: Option<String>,
    /// The poses not in the file, oldest first.
    tail: Vec<StampedPose>,
    /// The newest pose (the tail is empty right after a block moved to the file).
    newest: Option<StampedPose>,
    /// Every `shown_stride`-th pose, by index.
    shown: Vec<StampedPose>,
    shown_stride: usize,
}

impl PoseHistory {
    /// An empty history.
    pub fn new(options: PoseHistoryOptions) -> PoseHistory {
        PoseHistory {
            options: PoseHistoryOptions {
                block_rows: options.block_rows.max(1),
                max_shown: options.max_shown.max(2),
                folder: options.folder,
            },
            spilled_rows: 0,
            file: None,
            file_failed: false,
            transform_failure: None,
            tail: Vec::new(),
            newest: None,
            shown: Vec::new(),
            shown_stride: 1,
        }
    }

    /// Poses held.
    pub fn len(&self) -> usize {
        self.spilled_rows + self.tail.len()
    }

    /// Whether no pose was added.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The newest pose.
    pub fn last(&self) -> Option<StampedPose> {
        self.newest
    }

    /// Adds the newest pose.
    pub fn push(&mut self, pose: StampedPose) {
        if self.len().is_multiple_of(self.shown_stride) {
            self.shown.push(pose);
            if self.shown.len() >= self.options.max_shown {
                // Every other one: the stride doubles, and index 0 stays.
                let mut keep = false;
                self.shown.retain(|_| {
                    keep = !keep;
                    keep
                });
                self.shown_stride *= 2;
            }
        }
        self.tail.push(pose);
        self.newest = Some(pose);
        if self.tail.len() >= self.options.block_rows && !self.file_failed && self.spill().is_err()
        {
            self.file_failed = true;
        }
    }

    /// At most [`PoseHistoryOptions::max_shown`] poses evenly spaced in index, the first and
    /// the newest among them: what a view draws.
    pub fn thinned(&self) -> impl Iterator<Item = StampedPose> + '_ {
        let newest_shown = (self.shown.len().saturating_sub(1)) * self.shown_stride;
        let newest = self.last().filter(|_| self.len() > newest_shown + 1);
        self.shown.iter().copied().chain(newest)
    }

    /// Re-expresses every pose held, as `new_from_old ∘ pose` (the map frame changed). Should
    /// the file fail meanwhile, reading the history back reports it.
    pub fn transform(&mut self, new_from_old: Pose2) {
        if let Err(error) = self.transform_all(new_from_old) {
            self.transform_failure
                .get_or_insert_with(|| format!("re-expressing the older poses failed: {error}"));
        }
    }

    fn transform_all(&mut self, new_from_old: Pose2) -> io::Result<()> {
        let apply =
            |p: &mut StampedPose| p.pose_in_map = compose_pose(new_from_old, p.pose_in_map).0;
        self.tail.iter_mut().for_each(apply);
        self.shown.iter_mut().for_each(apply);
        self.newest.iter_mut().for_each(apply);
        let Some(file) = self.file.as_mut() else {
            return Ok(());
        };
        let mut block = vec![0u8; self.options.block_rows * ROW_BYTES];
        let mut done = 0;
        while done < self.spilled_rows {
            let rows = (self.spilled_rows - done).min(self.options.block_rows);
            let bytes = &mut block[..rows * ROW_BYTES];
            let offset = (done * ROW_BYTES) as u64;
            file.seek(SeekFrom::Start(offset))?;
            file.read_exact(bytes)?;
            for row in bytes.chunks_exact_mut(ROW_BYTES) {
                let mut pose = decode(row);
                apply(&mut pose);
                encode(&pose, row);
            }
            file.seek(SeekFrom::Start(offset))?;
            file.write_all(bytes)?;
            done += rows;
        }
        file.seek(SeekFrom::End(0))?;
        Ok(())
    }

    /// Calls `visit` with every pose, oldest first, reading the file back.
    ///
    /// # Errors
    /// The file cannot be read back, or failed when the poses were re-expressed.
    pub fn for_each(&self, mut visit: impl FnMut(StampedPose)) -> io::Result<()> {
        if let Some(failure) = &self.transform_failure {
            return Err(io::Error::other(failure.clone()));
        }
        if let Some(file) = self.file.as_ref() {
            let mut handle = file.try_clone()?;
            handle.seek(SeekFrom::Start(0))?;
            let mut reader = BufReader::new(handle).take((self.spilled_rows * ROW_BYTES) as u64);
            let mut row = [0u8; ROW_BYTES];
            for _ in 0..self.spilled_rows {
                reader.read_exact(&mut row)?;
                visit(decode(&row));
            }
            // The shared cursor goes back to the end, where the next block is appended.
            reader.into_inner().into_inner().seek(SeekFrom::End(0))?;
        }
        self.tail.iter().copied().for_each(visit);
        Ok(())
    }

    /// Every pose, oldest first.
    ///
    /// # Errors
    /// As [`PoseHistory::for_each`].
    pub fn to_vec(&self) -> io::Result<Vec<StampedPose>> {
        let mut poses = Vec::with_capacity(self.len());
        self.for_each(|p| poses.push(p))?;
        Ok(poses)
    }

    /// Moves the in-memory poses to the end of the file.
    fn spill(&mut self) -> io::Result<()> {
        let file = match self.file.as_mut() {
            Some(file) => file,
            None => self.file.insert(match &self.options.folder {
                Some(folder) => tempfile::tempfile_in(folder)?,
                None => tempfile::tempfile()?,
            }),
        };
        let mut writer = BufWriter::new(file);
        let mut row = [0u8; ROW_BYTES];
        for pose in &self.tail {
            encode(pose, &mut row);
            writer.write_all(&row)?;
        }
        writer.flush()?;
        self.spilled_rows += self.tail.len();
        self.tail.clear();
        Ok(())
    }
}

fn encode(pose: &StampedPose, row: &mut [u8]) {
    let p = pose.pose_in_map;
    for (k, value) in [pose.time_s, p.x_m, p.y_m, p.theta_rad]
        .into_iter()
        .enumerate()
    {
        row[k * 8..(k + 1) * 8].copy_from_slice(&value.to_le_bytes());
    }
}

fn decode(row: &[u8]) -> StampedPose {
    let value = |k: usize| {
        let mut bytes = [0u8; 8];
        bytes.copy_from_slice(&row[k * 8..(k + 1) * 8]);
        f64::from_le_bytes(bytes)
    };
    StampedPose {
        time_s: value(0),
        pose_in_map: Pose2::new(value(1), value(2), value(3)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(k: usize) -> StampedPose {
        StampedPose {
            time_s: k as f64 * 0.1,
            pose_in_map: Pose2::new(k as f64, -(k as f64), 0.001 * k as f64),
        }
    }

    fn small() -> PoseHistoryOptions {
        PoseHistoryOptions {
            block_rows: 7,
            max_shown: 10,
            folder: None,
        }
    }

    #[test]
    fn every_pose_comes_back_in_order_across_blocks() {
        let mut history = PoseHistory::new(small());
        for k in 0..100 {
            history.push(pose(k));
        }
        assert_eq!(history.len(), 100);
        assert!(history.file.is_some(), "blocks moved to the file");
        assert!(history.tail.len() < 7);
        let all = history.to_vec().unwrap();
        assert_eq!(all, (0..100).map(pose).collect::<Vec<_>>());
        // Reading leaves the file ready for more.
        for k in 100..120 {
            history.push(pose(k));
        }
        assert_eq!(
            history.to_vec().unwrap(),
            (0..120).map(pose).collect::<Vec<_>>()
        );
    }

    #[test]
    fn a_transform_reaches_the_file_the_tail_and_the_view() {
        let mut history = PoseHistory::new(small());
        for k in 0..50 {
            history.push(pose(k));
        }
        let moved = Pose2::new(10.0, 5.0, 0.5);
        history.transform(moved);
        history.push(pose(50));
        let expected: Vec<StampedPose> = (0..51)
            .map(|k| {
                let mut p = pose(k);
                if k < 50 {
                    p.pose_in_map = compose_pose(moved, p.pose_in_map).0;
                }
                p
            })
            .collect();
        let all = history.to_vec().unwrap();
        for (got, want) in all.iter().zip(&expected) {
            assert_eq!(got.time_s, want.time_s);
            assert!((got.pose_in_map.x_m - want.pose_in_map.x_m).abs() < 1e-9);
            assert!((got.pose_in_map.y_m - want.pose_in_map.y_m).abs() < 1e-9);
        }
        assert_eq!(all.len(), 51);
        let first_shown = history.thinned().next().unwrap();
        assert!((first_shown.pose_in_map.x_m - 10.0).abs() < 1e-9);
    }

    #[test]
    fn the_file_goes_to_the_folder_given_and_a_missing_folder_keeps_poses_in_memory() {
        let folder = tempfile::tempdir().unwrap();
        let mut history = PoseHistory::new(PoseHistoryOptions {
            folder: Some(folder.path().to_path_buf()),
            ..small()
        });
        for k in 0..20 {
            history.push(pose(k));
        }
        assert!(history.file.is_some());
        assert_eq!(
            history.to_vec().unwrap(),
            (0..20).map(pose).collect::<Vec<_>>()
        );

        let mut history = PoseHistory::new(PoseHistoryOptions {
            folder: Some(folder.path().join("missing")),
            ..small()
        });
        for k in 0..20 {
            history.push(pose(k));
        }
        assert!(history.file.is_none() && history.file_failed);
        assert_eq!(history.tail.len(), 20);
        assert_eq!(
            history.to_vec().unwrap(),
            (0..20).map(pose).collect::<Vec<_>>()
        );
    }

    #[test]
    fn the_view_stays_bounded_and_spans_the_run() {
        let mut history = PoseHistory::new(small());
        for k in 0..1_000 {
            history.push(pose(k));
            let shown: Vec<StampedPose> = history.thinned().collect();
            assert!(shown.len() <= 10 + 1, "{} shown", shown.len());
            assert_eq!(shown[0], pose(0));
            assert_eq!(*shown.last().unwrap(), pose(k));
            let gaps: Vec<f64> = shown
                .windows(2)
                .map(|w| w[1].time_s - w[0].time_s)
                .collect();
            let widest = gaps.iter().cloned().fold(0.0, f64::max);
            // Evenly spaced: no gap wider than a quarter of the run once thinned.
            if k > 40 {
                assert!(widest <= 0.1 * k as f64 / 4.0 + 1e-9, "gap {widest} at {k}");
            }
        }
    }
}
