//! `hil-sim replay-carmen`: occupancy-grid SLAM over a CARMEN laser log, measured on its
//! relations.

use std::path::PathBuf;

use super::CliResult;
use super::parsers::{parse_fraction, parse_weight};

/// Occupancy-grid SLAM over a CARMEN laser log: local tracking against submaps, loop
/// closure with the exact raster matcher, a pose graph; the map exported.
///
/// Writes OUT/trajectory.tsv (one line per scan: the log's timestamp as printed, then
/// `x_m y_m theta_rad`), OUT/map.pgm + OUT/map.yaml (ROS map_server) and OUT/map.png, and
/// OUT/summary.json (`scans`, `wall_s`, `scans_per_second`, and the error on the relations
/// given, Kümmerle et al. 2009). LOG.relations and LOG.reference.tsv beside the log (LOG
/// without its extension) are used when present. For a relations file it also names the
/// relations the log's own scans dispute (the two scans line up far worse at the true
/// relative pose than at the estimate) and gives the error without them.
#[derive(Debug, clap::Args)]
pub struct ReplayCarmenArgs {
    /// The CARMEN log (FLASER / ROBOTLASER1; `.gz` is read too).
    log: PathBuf,
    /// Output directory (created if missing).
    #[arg(long, default_value = "slam-out")]
    out: PathBuf,
    /// `none` ignores every pose in the log (laser only); `log` uses them as odometry.
    /// Laser-only logs (every pose zero) must be run with `none`.
    #[arg(long, default_value = "log", value_parser = ["log", "none"])]
    odometry: String,
    /// Ranges at or above this are "no return", m [default: read from the log: just below
    /// its largest range when many ranges pile up there, as a sensor's saturated readings
    /// do (32.767 m, 81.91 m); else 80 m].
    #[arg(long)]
    no_return_from_m: Option<f64>,
    /// Ground-truth relations (`t1 t2 x y z roll pitch yaw`) to measure the error on
    /// [default: LOG.relations when present].
    #[arg(long)]
    relations: Option<PathBuf>,
    /// A reference trajectory (`timestamp x y theta`) for consecutive and revisit
    /// relations [default: LOG.reference.tsv when present].
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Only the log's first N scans (a short run; the relations beyond them are not
    /// covered).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    first_scans: Option<u64>,
    /// With a reference trajectory: score the reference's motion into every scan as local
    /// tracking scores its candidates, and write OUT/tracking_check.tsv (the motion chosen
    /// and the reference's, with their scores) and `tracking_check` in summary.json: where
    /// tracking chose elsewhere (0.3 m or 3° away), whether its search missed the
    /// reference's pose, that pose scored lower, or it scored as a pose tracking refuses.
    #[arg(long)]
    check_tracking: bool,
    /// Disable loop closure (local tracking only).
    #[arg(long)]
    no_loop_closure: bool,
    /// Disable the loop closure against chains of earlier scans (±10 m) for scans no
    /// submap took.
    #[arg(long)]
    no_chain_closure: bool,
    /// Disable the relocalisation after scans tracking could not place (the search over
    /// every heading on the ring of places the robot can be; see docs/method2.md).
    #[arg(long)]
    no_relocalisation: bool,
    /// Disable the weak loop closures where the pose is uncertain (matches with fewer end
    /// points on the submap, taken when distinctive, within the graph's uncertainty and
    /// confirmed by two more).
    #[arg(long)]
    no_weak_closures: bool,
    /// Skip the final refinement (every scan aligned on the submaps near it, as its place
    /// settles or once the run is over).
    #[arg(long)]
    no_refinement: bool,
    /// Keep every node of the pose graph free during the run: no place settles (see
    /// docs/method2.md, "Settled places").
    #[arg(long)]
    no_settle: bool,
    /// Local tracking: below this share of the scanned surface (end points weighted by
    /// range) on the submap after alignment, the wide search runs.
    #[arg(long, default_value_t = host::slam::LocalTrackingOptions::default().min_surface_fraction, allow_hyphen_values = true, value_parser = parse_fraction)]
    min_surface_fraction: f64,
    /// Local tracking: below this share after the wide search, it runs again over every
    /// heading, and a pose it finds must bring the share to this.
    #[arg(long, default_value_t = host::slam::LocalTrackingOptions::default().full_turn_below_surface_fraction, allow_hyphen_values = true, value_parser = parse_fraction)]
    every_heading_below: f64,
    /// Local tracking: how much the share of the scanned surface that contradicts the submap
    /// (end points on cells it has seen free, beams through its walls) counts against a
    /// candidate pose (the share on its surfaces counts 1).
    #[arg(long, default_value_t = host::slam::LocalTrackingOptions::default().free_weight, allow_hyphen_values = true, value_parser = parse_weight)]
    free_weight: f64,
    /// Pose graph: a scan-to-scan constraint is left almost free along the direction in
    /// which its alignment holds less than this fraction of the information it holds
    /// across it (a corridor's axis); 0 never does.
    #[arg(long, default_value_t = host::slam::SlamOptions::default().degenerate_information_ratio, allow_hyphen_values = true, value_parser = parse_fraction)]
    degenerate_ratio: f64,
    /// Pose graph: the standard deviation added along such a direction, m.
    #[arg(long, default_value_t = host::slam::SlamOptions::default().degenerate_sigma_m, allow_hyphen_values = true, value_parser = parse_weight)]
    degenerate_sigma_m: f64,
}

/// Runs the SLAM over the log; prints the summary on stdout, the speed and the disputed
/// relations on stderr.
pub fn run(args: ReplayCarmenArgs) -> CliResult {
    let log = args.log;
    let beside = |suffix: &str| {
        let path = log.with_extension(suffix);
        path.exists().then_some(path)
    };
    let mut slam = host::slam::SlamOptions::default();
    slam.loop_closure.enabled = !args.no_loop_closure;
    slam.chain_closure.enabled = !args.no_chain_closure;
    slam.relocalisation.enabled = !args.no_relocalisation;
    slam.weak_closure.enabled = !args.no_weak_closures;
    slam.refinement.enabled = !args.no_refinement;
    slam.settle.enabled = !args.no_settle;
    slam.local.min_surface_fraction = args.min_surface_fraction;
    slam.local.full_turn_below_surface_fraction = args.every_heading_below;
    slam.local.free_weight = args.free_weight;
    slam.degenerate_information_ratio = args.degenerate_ratio;
    slam.degenerate_sigma_m = args.degenerate_sigma_m;
    let options = hil_sim::slam_replay::SlamReplayOptions {
        relations: args.relations.or_else(|| beside("relations")),
        reference: args.reference.or_else(|| beside("reference.tsv")),
        log,
        out: args.out,
        odometry: args.odometry == "log",
        no_return_from_m: args.no_return_from_m,
        slam,
        first_scans: args
            .first_scans
            .map(|n| usize::try_from(n).unwrap_or(usize::MAX)),
        check_tracking: args.check_tracking,
    };
    if options.check_tracking && options.reference.is_none() {
        return Err(
            "--check-tracking needs a reference trajectory (--reference, or \
                    LOG.reference.tsv beside the log)"
                .into(),
        );
    }
    let summary = hil_sim::slam_replay::replay_carmen_slam(&options)?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    eprintln!(
        "hil-sim: {} scans in {:.3} s ({:.0} scans/s); outputs in {}",
        summary.scans,
        summary.wall_s,
        summary.scans_per_second,
        options.out.display()
    );
    if let Some(agreement) = &summary.relations_agreement {
        let without = &agreement.undisputed_summary;
        eprintln!(
            "hil-sim: the scans dispute {} of {} relations (their true pose lines them up far \
             worse than the estimate); without those: {:.4} m, {:.3}° over {}",
            agreement.disputed.len(),
            agreement.checked,
            without.mean_translation_m,
            without.mean_rotation_deg,
            without.count
        );
    }
    Ok(())
}
