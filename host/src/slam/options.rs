//! The options of the SLAM pipeline, each with a default that works on the benchmark logs.

use super::closure_confirmation::ConfirmationOptions;
use super::icp::IcpOptions;
use super::motion_filter::MotionFilterOptions;
use super::motion_prior::MotionPriorOptions;
use super::point_map::PointMapOptions;
use super::settled_submaps::SettleOptions;
use super::slam_submap::SubmapFit;
use crate::grid::SubmapOptions;
use crate::pose_graph::{OptimizeOptions, RobustKernel};
use crate::scan_match::Scan;

/// Everything [`super::GraphSlam`] can be told.
#[derive(Clone, Debug)]
pub struct SlamOptions {
    /// How submap grids are built (5 cm cells by default).
    pub submap: SubmapOptions,
    /// How submaps keep their end points for alignment.
    pub point_map: PointMapOptions,
    /// Which tracked scans are inserted into the submaps and the pose graph.
    pub motion_filter: MotionFilterOptions,
    /// Scans a submap receives before the next one starts; each submap receives up to twice as
    /// many (two submaps are active at a time).
    pub scans_per_submap: usize,
    /// Beams longer than this are treated as no return, metres.
    pub max_range_m: f64,
    /// Beams shorter than this are dropped (robot body, dust), metres.
    pub min_range_m: f64,
    /// Local tracking.
    pub local: LocalTrackingOptions,
    /// Loop closure.
    pub loop_closure: LoopClosureOptions,
    /// Loop closure against a chain of earlier scans, for scans no submap took.
    pub chain_closure: ChainClosureOptions,
    /// Loop closure over a window as wide as the pose's uncertainty relative to a submap,
    /// where that reaches beyond [`Self::loop_closure`]'s window.
    pub uncertain_closure: UncertainClosureOptions,
    /// Weak loop closures where the pose is uncertain beyond the window.
    pub weak_closure: WeakClosureOptions,
    /// The search over every heading after local tracking lost its way.
    pub relocalisation: RelocalisationOptions,
    /// The alignment of every scan on the submaps near it at the end of a run.
    pub refinement: RefinementOptions,
    /// When a place later passes agree on becomes part of the fixed reference
    /// ([`super::settled_submaps`]).
    pub settle: SettleOptions,
    /// Standard deviation of a consecutive-scan constraint: translation (m), rotation (rad).
    pub odometry_sigma: [f64; 2],
    /// A constraint (scan to scan, loop closure, final refinement) is left almost free along
    /// the direction of translation in which its alignment holds less than this fraction of
    /// the information it holds across it (a corridor's axis; [`super::degeneracy`]). 0
    /// keeps every constraint at [`Self::odometry_sigma`] or [`Self::loop_closure_sigma`].
    pub degenerate_information_ratio: f64,
    /// Standard deviation added to such a constraint along that direction, metres (to a
    /// scan-to-scan constraint at most this: [`super::TrackedScan::unmeasured_sigma_m`]).
    pub degenerate_sigma_m: f64,
    /// Standard deviation of a loop-closure constraint: translation (m), rotation (rad).
    pub loop_closure_sigma: [f64; 2],
    /// The robust kernel of loop-closure (and refinement) constraints: dynamic covariance
    /// scaling with `Φ = 10`, about the 98 % point of χ² with three degrees of freedom, so a
    /// closure that agrees with the graph as well as its covariance says keeps its full
    /// weight, and one that disagrees by far more all but switches itself off.
    pub loop_closure_kernel: RobustKernel,
    /// Pose-graph solver.
    pub optimize: OptimizeOptions,
    /// The graph is solved again once the constraints added since its last solve disagree
    /// with its poses by more than this χ² in sum, each weighted by its robust kernel as the
    /// solve would; 7.81, the 95 % point of χ² with three degrees of freedom. Constraints the
    /// poses already satisfy within their covariance would move them by less than the
    /// constraints' own uncertainty, and those the kernel switches off would not move them:
    /// they wait for the next solve (or the end of the run) instead of costing a solve of the
    /// graph's free nodes each. A loop closure that agrees in this sense also counts towards
    /// settling its submap ([`super::settled_submaps`]). With the default kernel one closure adds at most `Φ` (10) however
    /// far off it is, so one alone triggers a solve only when `Φ` exceeds this value.
    pub solve_above_chi2: f64,
    /// A loop-closure search (in a finished submap or in a chain of earlier scans) runs only
    /// where a closure would tell the graph at least this much, nats: the mutual information
    /// between the closure and the scan's pose relative to the place, from the graph's
    /// covariance of that relative pose and a closure's own
    /// ([`super::closure_gain`]). Right after a closure to a place the robot's pose relative
    /// to it is about as certain as another closure would make it, and searching there again
    /// is wasted; the scans tracked since make it less certain, until a search is worth its
    /// cost again. The default, 4 nats, asks for a closure that would shrink the relative
    /// pose's variance about 14-fold along each of its three directions, were they equally
    /// uncertain. A pose uncertain beyond the search window, and a scan searched because a
    /// chain closure waits for its confirmation, are searched whatever the gain. 0 searches
    /// every candidate.
    pub min_closure_gain_nats: f64,
}

impl SlamOptions {
    /// `scan` without the beams outside `min_range_m ..= max_range_m`: what the SLAM tracks,
    /// and what the global map holds.
    pub fn trusted_beams(&self, scan: &Scan) -> Scan {
        let (min_m, max_m) = (self.min_range_m, self.max_range_m);
        Scan::from_points_in_robot(
            scan.points_in_robot()
                .iter()
                .map(|p| {
                    p.filter(|p| {
                        let range_m = p[0].hypot(p[1]);
                        range_m >= min_m && range_m <= max_m
                    })
                })
                .collect(),
        )
    }
}

impl Default for SlamOptions {
    fn default() -> Self {
        // Scans of the benchmark logs are about a metre apart, so a submap holds few of them:
        // walls must stand out from free space after one or two hits for the refinement to
        // find them (with 0.55 / 0.49 a young submap's walls barely differ from free space and
        // the refinement is drawn to the edge of the known area instead).
        let mut submap = SubmapOptions::default();
        submap.range_inserter.hit_probability = 0.9;
        submap.range_inserter.miss_probability = 0.3;
        let scans_per_submap = 30;
        SlamOptions {
            submap,
            point_map: PointMapOptions::default(),
            motion_filter: MotionFilterOptions::default(),
            scans_per_submap,
            max_range_m: 50.0,
            min_range_m: 0.1,
            local: LocalTrackingOptions::default(),
            // Closures in neighbouring submaps (frames one submap apart) confirm each other,
            // carried from one frame into the other through local tracking: a scan seen from
            // another side of a place often lands in the submap next to the first one's.
            loop_closure: LoopClosureOptions {
                confirmation: ConfirmationOptions {
                    max_frame_gap_nodes: scans_per_submap,
                    ..ConfirmationOptions::default()
                },
                ..LoopClosureOptions::default()
            },
            chain_closure: ChainClosureOptions::default(),
            uncertain_closure: UncertainClosureOptions::default(),
            weak_closure: WeakClosureOptions::default(),
            relocalisation: RelocalisationOptions::default(),
            refinement: RefinementOptions::default(),
            settle: SettleOptions::default(),
            odometry_sigma: [0.02, 0.5f64.to_radians()],
            degenerate_information_ratio: 0.03,
            degenerate_sigma_m: 3.0,
            loop_closure_sigma: [0.03, 0.5f64.to_radians()],
            loop_closure_kernel: RobustKernel::Dcs { phi: 10.0 },
            optimize: OptimizeOptions::default(),
            solve_above_chi2: 7.81,
            min_closure_gain_nats: 4.0,
        }
    }
}

/// How each scan is placed against the active submap.
#[derive(Clone, Debug)]
pub struct LocalTrackingOptions {
    /// The point-to-line alignment on the submap's points.
    pub icp: IcpOptions,
    /// An alignment from the prediction that leaves a smaller share of the scanned surface
    /// ([`SubmapFit::surface_fraction`](super::SubmapFit)) on the submap's surfaces than this
    /// triggers the wide search.
    pub min_surface_fraction: f64,
    /// When the wide search still leaves a smaller share than this on the submap's surfaces,
    /// it runs once more over every heading (a turn larger than its rotation window); what it
    /// finds competes on its score.
    pub full_turn_below_surface_fraction: f64,
    /// How much the share of the scanned surface that contradicts the submap (end points on
    /// cells it has seen free, beams through its surfaces) counts against a candidate pose,
    /// against the share on its surfaces
    /// ([`SubmapFit::tracking_score`](super::SubmapFit::tracking_score)).
    pub free_weight: f64,
    /// Half width of the wide search's translation window, metres.
    pub search_window_m: f64,
    /// Half width of the wide search's rotation window, radians.
    pub search_window_rad: f64,
    /// Pixel size of the wide search's raster, metres.
    pub search_resolution_m: f64,
    /// Rotation step of the wide search, radians.
    pub search_rotation_step_rad: f64,
    /// Scans drawn as the wide search's reference.
    pub recent_scans: usize,
    /// What tracking expects of the motion between scans, and how sure it is of it.
    pub motion_prior: MotionPriorOptions,
    /// Half width of the far search's translation window, metres. The far search runs with
    /// the wide one whenever three of the prior's standard deviations reach beyond
    /// [`Self::search_window_m`].
    pub far_search_window_m: f64,
    /// Pixel size of the far search's raster, metres.
    pub far_search_resolution_m: f64,
    /// Rotation step of the far search, radians.
    pub far_search_rotation_step_rad: f64,
}

impl Default for LocalTrackingOptions {
    fn default() -> Self {
        LocalTrackingOptions {
            icp: IcpOptions::default(),
            min_surface_fraction: 0.8,
            full_turn_below_surface_fraction: 0.5,
            free_weight: 0.5,
            search_window_m: 1.0,
            search_window_rad: 45f64.to_radians(),
            search_resolution_m: 0.1,
            search_rotation_step_rad: 1f64.to_radians(),
            recent_scans: 5,
            motion_prior: MotionPriorOptions::default(),
            far_search_window_m: 4.0,
            far_search_resolution_m: 0.2,
            far_search_rotation_step_rad: 2f64.to_radians(),
        }
    }
}

/// How earlier submaps are searched for the current scan.
#[derive(Clone, Debug)]
pub struct LoopClosureOptions {
    /// Whether to search at all.
    pub enabled: bool,
    /// Search every this many nodes (scans the motion filter inserted).
    pub every_n_scans: usize,
    /// Half width of the translation window, metres.
    pub search_window_m: f64,
    /// Half width of the rotation window, radians.
    pub search_window_rad: f64,
    /// Pixel size of the search raster, metres.
    pub search_resolution_m: f64,
    /// Rotation step, radians.
    pub search_rotation_step_rad: f64,
    /// Side of the search raster, pixels.
    pub raster_side_px: u32,
    /// Submaps whose frame is farther from the scan's estimated pose than this are not
    /// searched with this window; those within this plus [`Self::gate_sigmas`] standard
    /// deviations of that pose relative to the submap, where those reach beyond the window,
    /// may be searched by [`UncertainClosureOptions`], metres.
    pub max_distance_m: f64,
    /// How many standard deviations of the scan's pose relative to a submap (compounded along
    /// the pose graph, [`relative_covariances`](crate::pose_graph::relative_covariances)) the
    /// search must reach: beyond the window it is searched by [`UncertainClosureOptions`].
    pub gate_sigmas: f64,
    /// A closure whose error at the graph's poses has at most this χ² against the sum of its
    /// own covariance and that of the scan's pose relative to the submap agrees with what the
    /// graph knows, however far off it is: it is solved once without the robust kernel. The
    /// default is χ² with three degrees of freedom at 99.73 %, the mass of three standard
    /// deviations.
    pub max_consistent_chi2: f64,
    /// The point-to-line alignment of a match on the submap's points.
    pub icp: IcpOptions,
    /// Fraction of the scan's end points on the submap's surfaces, after alignment, that
    /// accepts a match.
    pub min_inlier_fraction: f64,
    /// Largest fraction of the scan's end points on cells the submap has seen free, after
    /// alignment, that accepts a match.
    pub max_free_fraction: f64,
    /// Mean grid probability at the scan's end points on cells the submap observed, after
    /// alignment, that accepts a match.
    pub min_probability: f64,
    /// How a closure is confirmed by a second one before it enters the pose graph.
    pub confirmation: ConfirmationOptions,
    /// Submaps whose last scan is this recent (in scans) are not searched (local tracking
    /// covers them).
    pub min_scans_apart: usize,
    /// Of the submaps within [`Self::max_distance_m`], at most this many are searched for a
    /// scan: those searched longest ago, then those the scan's pose is most uncertain
    /// relative to (where a closure tells the graph the most). A place passed many times has
    /// tens of submaps near it, each then searched in turn by the scans that pass, so the
    /// work per scan stays bounded however often the robot comes back.
    pub max_searches_per_scan: usize,
}

impl LoopClosureOptions {
    /// Whether a scan aligned on a submap with `fit` is good enough to become a constraint.
    pub fn accepts(&self, fit: &SubmapFit) -> bool {
        fit.inlier_fraction >= self.min_inlier_fraction
            && fit.free_fraction <= self.max_free_fraction
            && fit.mean_probability >= self.min_probability
    }
}

impl Default for LoopClosureOptions {
    fn default() -> Self {
        LoopClosureOptions {
            enabled: true,
            every_n_scans: 5,
            search_window_m: 3.0,
            search_window_rad: 30f64.to_radians(),
            search_resolution_m: 0.1,
            search_rotation_step_rad: 1f64.to_radians(),
            raster_side_px: 256,
            max_distance_m: 10.0,
            gate_sigmas: 3.0,
            max_consistent_chi2: 14.16,
            icp: IcpOptions::default(),
            min_inlier_fraction: 0.8,
            max_free_fraction: 0.05,
            min_probability: 0.6,
            confirmation: ConfirmationOptions::default(),
            min_scans_apart: 30,
            max_searches_per_scan: 4,
        }
    }
}

/// How a scan that no finished submap took is searched in a chain of earlier scans: the
/// scans around the earlier one nearest to it, drawn into a submap of their own at the
/// poses the graph holds now ([`super::GraphSlam`]).
///
/// A submap holds up to twice [`SlamOptions::scans_per_submap`] scans, tens of metres of a
/// trajectory, and a stretch that local tracking got wrong (a slide along a corridor) blurs
/// it for every later match; a chain of a few metres either side of where the scan is
/// believed to be is what the robot saw of that place. Its window is wide, for the drift
/// of a long loop, so its matches must also agree with a second one before they count
/// ([`ConfirmationOptions::max_frame_gap_nodes`] lets chains around nearby scans agree).
#[derive(Clone, Debug)]
pub struct ChainClosureOptions {
    /// Whether to search at all (only on the scans loop closure searches).
    pub enabled: bool,
    /// Scans taken on each side of the nearest earlier scan.
    pub half_length_scans: usize,
    /// A chain drawn for an earlier search serves again while the nearest earlier scan lies
    /// within this distance of its centre, m (and the graph holds its scans where they were
    /// drawn): a robot driving where it drove before meets the same place search after
    /// search, and a chain of [`Self::half_length_scans`] either side reaches metres beyond
    /// such a shift. Drawing the chain and readying it for the matcher is much of what a
    /// search costs. 0: every search draws the chain around its own nearest scan.
    pub reuse_within_m: f64,
    /// The search and its acceptance. Its `max_distance_m` bounds the distance to the
    /// nearest earlier scan, and its `min_scans_apart` how recent that scan may be; its
    /// `enabled`, `every_n_scans` and `max_searches_per_scan` are not used (chains are searched on the scans loop
    /// closure searches, and on every scan while a chain closure waits).
    pub search: LoopClosureOptions,
}

impl Default for ChainClosureOptions {
    fn default() -> Self {
        let half_length_scans = 12;
        ChainClosureOptions {
            enabled: true,
            half_length_scans,
            reuse_within_m: 0.5,
            search: LoopClosureOptions {
                // A window this wide at the submaps' 10 cm and 1° costs several times more;
                // ICP's first stage reaches farther than the coarser steps leave.
                search_window_m: 10.0,
                search_resolution_m: 0.2,
                search_rotation_step_rad: 2f64.to_radians(),
                raster_side_px: 256,
                min_inlier_fraction: 0.75,
                max_free_fraction: 0.15,
                min_probability: 0.5,
                confirmation: ConfirmationOptions {
                    max_frame_gap_nodes: 2 * half_length_scans,
                    ..ConfirmationOptions::default()
                },
                min_scans_apart: 50,
                ..LoopClosureOptions::default()
            },
        }
    }
}

/// How a scan is searched in a submap when its pose relative to that submap is more uncertain
/// than [`LoopClosureOptions`]' window covers: after a long loop, or after scans local
/// tracking could not place, whose constraints carry the motion prior's wide uncertainty.
///
/// The window is the widest the raster holds around the submap: a whole submap's worth of
/// translations and a wide turn, at coarser steps (ICP's first stage reaches farther than the
/// steps leave). A window that wide finds look-alikes as readily as the true place, so its
/// matches pass the loop closure's own acceptance test and then must agree with a second one
/// on the motion local tracking measured between them before they enter the graph; and only a
/// few submaps are searched per scan, those searched longest ago first.
#[derive(Clone, Debug)]
pub struct UncertainClosureOptions {
    /// Whether to search at all.
    pub enabled: bool,
    /// Submaps searched this way per searched scan, at most.
    pub max_searches_per_scan: usize,
    /// The search and its acceptance; its `max_distance_m`, `gate_sigmas`, `enabled`,
    /// `every_n_scans` and `min_scans_apart` are those of [`LoopClosureOptions`], and its
    /// `max_searches_per_scan` is not used (see [`Self::max_searches_per_scan`]).
    pub search: LoopClosureOptions,
}

impl Default for UncertainClosureOptions {
    fn default() -> Self {
        UncertainClosureOptions {
            enabled: true,
            max_searches_per_scan: 2,
            search: LoopClosureOptions {
                search_window_m: 16.0,
                search_window_rad: 45f64.to_radians(),
                search_resolution_m: 0.2,
                search_rotation_step_rad: 2f64.to_radians(),
                raster_side_px: 512,
                min_inlier_fraction: 0.75,
                max_free_fraction: 0.15,
                min_probability: 0.5,
                ..LoopClosureOptions::default()
            },
        }
    }
}

/// Weak loop closures: where the scan's pose relative to a finished submap near it is uncertain
/// beyond the usual search window, the scan is searched in that submap at every node (not
/// only every [`LoopClosureOptions::every_n_scans`]), and a match that puts far fewer of its
/// end points on the submap's surfaces than the usual test asks is taken when three things
/// hold together: the match lies within the graph's own uncertainty of that relative pose;
/// the place is distinctive over a window as wide as that uncertainty (the uncertain closer's,
/// [`UncertainClosureOptions`]): the match fits best there and no pose outside its basin fits
/// nearly as well ([`LoopCloser::ambiguity_around`](super::LoopCloser::ambiguity_around));
/// and further matches agree with it on the motion local tracking measured. A robot coming
/// back to its start from the other side sees only part of what it mapped there, and that
/// part is what these take.
#[derive(Clone, Debug)]
pub struct WeakClosureOptions {
    /// Whether to search at all.
    pub enabled: bool,
    /// Submaps searched this way per scan, at most (the nearest first).
    pub max_searches_per_scan: usize,
    /// The largest ambiguity of a match taken, over the uncertain closer's window around it
    /// ([`LoopCloser::ambiguity_around`](super::LoopCloser::ambiguity_around)): the best pose
    /// outside the match's basin may fit at most this share of what the match fits.
    pub max_ambiguity: f64,
    /// The search and its acceptance: the usual search's raster with lower thresholds; its
    /// `max_distance_m`, `gate_sigmas`, `every_n_scans`, `min_scans_apart` and
    /// `max_consistent_chi2` are those of [`LoopClosureOptions`].
    pub search: LoopClosureOptions,
    /// How weak matches confirm each other: more agreeing than a usual closure needs.
    pub confirmation: ConfirmationOptions,
}

impl Default for WeakClosureOptions {
    fn default() -> Self {
        WeakClosureOptions {
            enabled: true,
            max_searches_per_scan: 2,
            max_ambiguity: 0.9,
            search: LoopClosureOptions {
                min_inlier_fraction: 0.35,
                max_free_fraction: 0.2,
                min_probability: 0.5,
                ..LoopClosureOptions::default()
            },
            confirmation: ConfirmationOptions {
                min_agreeing: 2,
                ..ConfirmationOptions::default()
            },
        }
    }
}

/// Relocalisation after local tracking lost its way: for a while after a scan tracking could
/// not place, a scan whose heading relative to a finished submap it has come back near is
/// uncertain beyond [`UncertainClosureOptions`]' turn is searched there over every heading,
/// centred on the places on the ring the robot can be on near the submap's scans (the
/// uncertain closer still searches as well: drift around a long loop lies off the ring).
///
/// A turn on the spot in open space loses the heading, not the position: the lost scans'
/// constraints carry the motion prior's 0.5 m, so the robot is still within metres of where
/// it is believed, but its heading is anyone's guess. The window (the uncertain closer's
/// ±16 m, every heading) then covers all the robot's pose can be, so a look-alike within
/// it shows in the ratio test: the match must fit best there and no pose outside its basin
/// may fit more than [`Self::max_ambiguity`] of what it fits
/// ([`LoopCloser::ambiguity_around`](super::LoopCloser::ambiguity_around)). Outdoors a place
/// seen again from elsewhere puts far fewer end points on the submap's surfaces than
/// indoors, so the match passes the weak matches' test ([`WeakClosureOptions`]), and two
/// scans after it must be found where it predicts them before it enters the graph.
#[derive(Clone, Debug)]
pub struct RelocalisationOptions {
    /// Whether to search at all.
    pub enabled: bool,
    /// Searched scans this many nodes after a lost scan at most are relocalised: long
    /// enough for a robot that drove on into ground not mapped before to come back.
    pub after_lost_nodes: usize,
    /// Submaps searched this way per searched scan, at most.
    pub max_searches_per_scan: usize,
    /// Lost scans at most this many nodes apart belong to one stretch.
    pub stretch_gap_nodes: usize,
    /// How many standard deviations of the position the lost scans leave the ring's width
    /// spans.
    pub gate_sigmas: f64,
    /// What local tracking may have drifted since the stretch, as a share of the distance
    /// from the last node placed before it.
    pub drift_fraction: f64,
    /// What local tracking may have drifted in heading since the stretch, radians.
    pub drift_rad: f64,
    /// Submaps none of whose scans were taken within this of the ring are not tried, metres.
    pub max_distance_m: f64,
    /// The largest ambiguity of a match taken, over the search's window around it.
    pub max_ambiguity: f64,
    /// Where the part of the ring the window holds turns the heading by at most this either
    /// way, the search tries only those headings, radians.
    pub narrow_turn_rad: f64,
    /// The search and its acceptance; its `enabled`, `every_n_scans`, `min_scans_apart`,
    /// `max_distance_m` and `max_searches_per_scan` are not used.
    pub search: LoopClosureOptions,
}

impl Default for RelocalisationOptions {
    fn default() -> Self {
        let weak = WeakClosureOptions::default().search;
        RelocalisationOptions {
            enabled: true,
            after_lost_nodes: 300,
            max_searches_per_scan: 2,
            stretch_gap_nodes: 5,
            gate_sigmas: 3.0,
            drift_fraction: 0.05,
            drift_rad: 5f64.to_radians(),
            max_distance_m: 10.0,
            max_ambiguity: 0.9,
            narrow_turn_rad: 45f64.to_radians(),
            search: LoopClosureOptions {
                search_window_rad: std::f64::consts::PI,
                min_inlier_fraction: weak.min_inlier_fraction,
                max_free_fraction: weak.max_free_fraction,
                min_probability: weak.min_probability,
                ..UncertainClosureOptions::default().search
            },
        }
    }
}

/// How every scan is aligned on the finished submaps near it, as its place settles or once
/// the run is over ([`super::final_refinement`]). An alignment runs the loop closure's ICP
/// and is accepted by its test ([`LoopClosureOptions::accepts`]).
#[derive(Clone, Debug)]
pub struct RefinementOptions {
    /// Whether to run it at all.
    pub enabled: bool,
    /// Submaps whose frame lies farther from the scan than this are not tried, metres.
    pub max_distance_m: f64,
    /// An alignment that moves the scan farther than this from where the graph holds it is
    /// not used, metres.
    pub max_correction_m: f64,
    /// Likewise for its heading, radians.
    pub max_correction_rad: f64,
    /// Submaps each scan is tried on at most, the nearest (their frames to the scan):
    /// a place seen on many laps has a submap per lap, and a few of them tie the scan to the
    /// map as well as all of them.
    pub max_submaps_per_scan: usize,
    /// Nodes fixed during the run whose alignments are made ahead, at most, each time a node
    /// is added ([`super::final_refinement::RefinedAhead`]): a place that settles fixes many
    /// nodes at once, and their alignments are spread over the nodes that follow.
    pub nodes_ahead_per_node: usize,
}

impl Default for RefinementOptions {
    fn default() -> Self {
        RefinementOptions {
            enabled: true,
            max_distance_m: 10.0,
            max_correction_m: 0.5,
            max_correction_rad: 3f64.to_radians(),
            max_submaps_per_scan: 10,
            nodes_ahead_per_node: 2,
        }
    }
}
