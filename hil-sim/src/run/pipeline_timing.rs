//! `performance.json` of a run: how long the host's pipeline took over each scan, the
//! process's peak memory and where the grid method's time went, on this machine. Kept apart
//! from `summary.json`, which is byte-identical between runs of the same seed; these figures
//! are not.

use host::ekf_slam::EkfPipelineStats;
use host::slam::{SlamStats, SlamTimings};
use serde::Serialize;

/// How long the pipeline took per scan (the wall time of handing it one scan event, its
/// tracking, submaps, loop closure and optimisation included), and the peak memory.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct PipelineTiming {
    /// Scans timed.
    pub scans: usize,
    /// Mean per scan, milliseconds.
    pub mean_ms: f64,
    /// Median per scan, milliseconds.
    pub p50_ms: f64,
    /// 90th percentile, milliseconds.
    pub p90_ms: f64,
    /// 99th percentile, milliseconds.
    pub p99_ms: f64,
    /// The slowest scan, milliseconds.
    pub max_ms: f64,
    /// Mean over the first 1 000 scans, and over the last 1 000 (the same scans when there are
    /// fewer than 2 000), milliseconds: whether the cost of a scan grows with the run.
    pub first_1000_mean_ms: f64,
    /// See [`Self::first_1000_mean_ms`].
    pub last_1000_mean_ms: f64,
    /// Mean per scan over each tenth of the run in turn (fewer parts when there are fewer
    /// than ten scans), milliseconds: whether a scan costs more as the map grows, or only
    /// once there are places to recognise (the first 1 000 scans have none).
    pub mean_ms_by_tenth: Vec<f64>,
    /// The largest resident memory of the process the run is in at any time, MiB: the
    /// kernel's high-water mark (`VmHWM`), read at the end. It holds the emulated sensors, the
    /// host pipeline and the firmware when it runs on the host (not under `--qemu` or on
    /// `--hardware`). `None` where the system does not give it (no `/proc`).
    pub peak_resident_mib: Option<f64>,
    /// Where the grid method's SLAM spent its time, part by part, seconds in all (tracking,
    /// choosing and searching loop closures, optimising, the end of the run); `None` for
    /// the EKF method.
    pub slam_parts_s: Option<SlamTimings>,
    /// The same over the first 1 000 scans, and over the last 1 000: which part makes a
    /// scan cost more as the run goes on.
    pub slam_parts_first_1000_s: Option<SlamTimings>,
    /// See [`Self::slam_parts_first_1000_s`].
    pub slam_parts_last_1000_s: Option<SlamTimings>,
    /// What that time was spent on: the grid method's nodes, searches, closures and solves
    /// over the run; `None` for the EKF method. Kept here rather than in `summary.json`, as
    /// under `--qemu` or on `--hardware` the scans the host receives depend on timing.
    pub slam_work: Option<SlamStats>,
    /// What the EKF method did over the run: scans and fixes used, scans that came later than
    /// its reorder window, reports of a GPS epoch already taken; `None` for the other methods.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ekf_work: Option<EkfPipelineStats>,
    /// The same figures per camera frame (its `scans` are frames) for the camera method:
    /// the wall time of handing the pipeline one frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_frames: Option<Box<PipelineTiming>>,
}

impl PipelineTiming {
    /// The figures of `step_us`, the time of each scan in order, microseconds.
    pub fn from_step_times(step_us: &[u32]) -> PipelineTiming {
        if step_us.is_empty() {
            return PipelineTiming::default();
        }
        let ms = |us: f64| us / 1000.0;
        let mean =
            |part: &[u32]| ms(part.iter().map(|&t| f64::from(t)).sum::<f64>() / part.len() as f64);
        let mut sorted = step_us.to_vec();
        sorted.sort_unstable();
        // Nearest rank: the smallest time at or above the fraction `q` of the scans.
        let quantile = |q: f64| {
            let rank = (q * sorted.len() as f64).ceil() as usize;
            ms(f64::from(sorted[rank.clamp(1, sorted.len()) - 1]))
        };
        let window = step_us.len().min(super::host_side::TIMING_WINDOW);
        PipelineTiming {
            scans: step_us.len(),
            mean_ms: mean(step_us),
            p50_ms: quantile(0.5),
            p90_ms: quantile(0.9),
            p99_ms: quantile(0.99),
            max_ms: quantile(1.0),
            first_1000_mean_ms: mean(&step_us[..window]),
            last_1000_mean_ms: mean(&step_us[step_us.len() - window..]),
            mean_ms_by_tenth: tenths(step_us.len())
                .map(|range| mean(&step_us[range]))
                .collect(),
            peak_resident_mib: None,
            slam_parts_s: None,
            slam_parts_first_1000_s: None,
            slam_parts_last_1000_s: None,
            slam_work: None,
            ekf_work: None,
            camera_frames: None,
        }
    }
}

/// The scans of each tenth of a run of `scans`, in order: ten ranges as equal as whole scans
/// allow (as many as there are scans when there are fewer than ten).
fn tenths(scans: usize) -> impl Iterator<Item = std::ops::Range<usize>> {
    let parts = scans.min(10);
    (0..parts).map(move |k| k * scans / parts..(k + 1) * scans / parts)
}

/// This process's peak resident memory so far, MiB (`VmHWM` of `/proc/self/status`); `None`
/// where there is no such file or field.
pub fn peak_resident_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let kib = crate::proc_status::status_field(&status, "VmHWM:")?;
    Some(kib as f64 / 1024.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_by_nearest_rank() {
        let steps: Vec<u32> = (1..=100).map(|k| k * 1000).collect();
        let timing = PipelineTiming::from_step_times(&steps);
        assert_eq!(timing.scans, 100);
        assert_eq!(timing.p50_ms, 50.0);
        assert_eq!(timing.p90_ms, 90.0);
        assert_eq!(timing.p99_ms, 99.0);
        assert_eq!(timing.max_ms, 100.0);
        assert_eq!(timing.mean_ms, 50.5);
        assert_eq!(timing.first_1000_mean_ms, timing.last_1000_mean_ms);
        assert_eq!(
            PipelineTiming::from_step_times(&[]),
            PipelineTiming::default()
        );
    }

    #[test]
    fn peak_memory_is_read_where_the_system_gives_it() {
        let Some(peak_mib) = peak_resident_mib() else {
            eprintln!("skipped: this system gives no VmHWM in /proc/self/status");
            return;
        };
        // This test process holds at least its own code, and far less than a terabyte.
        assert!(peak_mib > 1.0 && peak_mib < 1e6, "{peak_mib} MiB");
        let held = std::hint::black_box(vec![1u8; 64 << 20]);
        let after = peak_resident_mib().unwrap_or(0.0);
        assert!(after >= peak_mib.max(64.0), "{after} MiB after 64 MiB held");
        drop(held);
    }

    #[test]
    fn tenths_cover_every_scan_once_in_order() {
        for scans in [1, 7, 10, 11, 999, 134_893] {
            let ranges: Vec<_> = tenths(scans).collect();
            assert_eq!(ranges.len(), scans.min(10));
            assert_eq!(ranges[0].start, 0);
            assert_eq!(ranges[ranges.len() - 1].end, scans);
            for pair in ranges.windows(2) {
                assert_eq!(pair[0].end, pair[1].start);
            }
            assert!(ranges.iter().all(|range| !range.is_empty()));
        }
        let steps: Vec<u32> = (0..20).map(|k| if k < 10 { 1000 } else { 2000 }).collect();
        let timing = PipelineTiming::from_step_times(&steps);
        assert_eq!(
            timing.mean_ms_by_tenth,
            [1.0, 1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 2.0, 2.0]
        );
    }

    #[test]
    fn first_and_last_thousand_apart() {
        let steps: Vec<u32> = (0..3000)
            .map(|k| if k < 1000 { 1000 } else { 3000 })
            .collect();
        let timing = PipelineTiming::from_step_times(&steps);
        assert_eq!(timing.first_1000_mean_ms, 1.0);
        assert_eq!(timing.last_1000_mean_ms, 3.0);
    }
}
