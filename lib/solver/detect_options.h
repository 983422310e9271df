#pragma once
/// @file detect_options.h
/// DetectOptions: the options of DetectObjects (detect.h) and of the region forming it shares
/// with the solve on a mask's depth regions (proposals.h).

#include <string>

#include "solver/segments.h"

namespace g6d {

/// Options of DetectObjects().
struct DetectOptions {
  /// Depth segmentation (sensor noise, step between neighbours of one surface, fragments).
  SegmentOptions segments = [] {
    SegmentOptions segments;
    segments.min_segment_pixels = 40;
    return segments;
  }();
  /// Support planes: at most this many, found one after the other by RANSAC on a sample of
  /// the frame's depth points. A bin shows the ground outside it, its floor and up to three
  /// walls: with 3, a bin's floor seen at a slant (its walls larger in the image) stayed, and
  /// every part on it was one island with it (synth_dev's bins 47.1% -> 47.5% with 5; the
  /// real YCB-V sets unchanged; bench/RESULTS.md, issue 31).
  int max_planes = 5;
  int plane_iterations = 300;
  int plane_samples = 4000;
  /// A point lies on a plane within noise_sigmas · σ(z) (segments.sensor_noise_at_1m, σ
  /// growing with z²) plus this: real tables and floors are not flat to the millimetre, and
  /// the depth of a real sensor bends by a few millimetres across the image.
  double plane_flatness_m = 0.006;
  /// When set, each plane reads its flatness off its own largest support part: the 95th
  /// percentile of the part's local level (its height above the plane averaged over
  /// `raised_level_px` squares), at most plane_flatness_m. A flat floor then holds only what
  /// lies within the noise of it (a bin's floor 8 mm above it is a plane of its own); a bent
  /// real table keeps its bend.
  bool measure_plane_flatness = false;
  /// A plane is a support when its inliers hold at least this fraction of the sampled points
  /// and a connected part of them spans more than `support_extent_factor` times the largest
  /// diameter of the objects looked for (so that no face of an object is taken away); only
  /// such large connected parts are removed.
  double min_plane_fraction = 0.03;
  double support_extent_factor = 1.5;
  /// Thin parts lying flat on a support: a sheet-metal part on a bin's floor stands 1-3 mm
  /// above it, inside the plane's tolerance, and went with the floor. On each support, the
  /// height above the plane is averaged over `raised_window_px` squares (the sensor's noise
  /// averages out, a part's face does not) and compared with the support's local level (the
  /// average over `raised_level_px` squares of the pixels not raised); pixels higher than
  /// `raised_sigmas` robust sigmas of that smoothed height over the whole support (and than
  /// `raised_min_height_m`) are raised, when they form a connected part of at least
  /// segments.min_segment_pixels that is level: the robust spread of its heights at most
  /// `raised_flatness` times the support's. Raised pixels join the islands (island_open_px),
  /// not the depth segments: given to the segments too, they found 40.8% of synth_dev's bin
  /// parts without masks (34.5% without them), but on the real YCB-V clutter (Asus Xtion) the
  /// table's depth smeared up to an object's foot joined its segments and an answer went
  /// wrong (100% -> 93.3%); as islands only: bins 37.4%, the real sets unchanged
  /// (bench/RESULTS.md, issue 31). The test reads depth alone: a table's texture cannot
  /// trigger it. 0 = off.
  double raised_sigmas = 3.0;
  /// 13: averaging 13 x 13 pixels lowers the smoothed height's noise (and the steps of a
  /// quantised disparity on a slanted floor), so the 3-sigma threshold falls, and a part
  /// 40-60 px across still fills the square (synth_dev without masks, with 7 -> 13: 55.3% ->
  /// 57.0%, bins 47.5% -> 49.6%, wrong answers at >= 0.9 8 -> 4 of 255; the real YCB-V sets and
  /// LM-O unchanged; bench/RESULTS.md, issue 31). Lowering raised_sigmas to 2 instead found
  /// more bin parts (51.7%) but cost the real YCB-V clutter a third of its answers.
  int raised_window_px = 13;
  int raised_level_px = 101;
  double raised_min_height_m = 0.001;
  double raised_flatness = 1.5;
  /// Thin parts the colour image outlines (OutlinedRaisedPixels in proposals.cc): an area of a
  /// support enclosed by colour edges (Canny on the grey image, thresholds this and twice
  /// this; 0 = off), no larger than the largest object, is raised when the mean of its heights
  /// stands above the median height of the support within `raised_outline_ring_px` outside
  /// its edges by more than raised_min_height_m, `raised_outline_min_noise` times the sensor's
  /// noise at its depth, and raised_sigmas times its own noise over its size; and is level
  /// (raised_flatness). A sheet-metal part on a bin's floor is 1-3 mm high: averaged over a
  /// 13 x 13 square that reaches the floor around it, it stayed below the depth-only test.
  double raised_outline_edge = 40.0;
  int raised_outline_ring_px = 6;
  double raised_outline_min_noise = 1.0;
  /// Islands (FormIslands, proposals.h): the connected parts of the frame less its support,
  /// opened by a (2 · island_open_px + 1) square, are candidate regions too, beside the depth
  /// segments and their unions (-1 = none). Not inside a request's `within`.
  int island_open_px = 1;
  /// Islands split at their necks (FormIslands, SplitAtNecks): a core is where the island is
  /// at least this fraction as thick (distance to its edge) as anywhere within
  /// `island_split_window` of the largest object's size in pixels around it. 0 = no split.
  double island_split_core = 0.6;
  double island_split_window = 0.25;
  int island_split_min_core_px = 4;
  /// An island that splits into more pieces than this is no pile of objects (a wall, the
  /// floor beyond a table) and gives none.
  int island_split_max_pieces = 40;
  /// Pieces are candidates for objects without colour only (true) or for every object.
  bool island_pieces_uncoloured_only = true;
  /// For an object without colour, an island's rank (in [0, 1] by size and shape) gets this
  /// much more: with neither colour nor texture to go by, a part the support surrounds is
  /// the region most likely to hold one whole object (on synth_dev's bins, 58% of the
  /// islands solved held an instance, 18% of the segment regions), but a small island of
  /// poor shape must not pass a region that looks like the object. Tried: 1 (islands strictly
  /// first) found 44.1% of the bins' parts, but on the real YCB-V clutter the can (no colour
  /// in its cache) was answered on speckle islands (100% -> 60%); 0.15: bins 43.3%, the can
  /// unchanged; 0: bins 40.8% (bench/RESULTS.md, issue 31).
  double uncoloured_island_bonus = 0.15;
  /// Holes in the depth at most this many pixels across are bridged for the segmentation
  /// (BridgeDepthHoles, segments.h): a real sensor's blobs without depth (dark, shining or
  /// grazing surfaces, the projector's shadow) no longer cut an object into segments. Only
  /// the segmentation reads the bridged depth; solves, scores and the frame check read the
  /// frame's. 0 = off.
  int bridge_holes_px = 0;
  /// Segments whose pixel boxes lie within this many pixels of each other are neighbours.
  int neighbour_gap_px = 6;
  /// Segments also are neighbours across a gap of at most this many metres (at a segment's
  /// depth) that holds no depth, fragments or a nearer segment (NeighboursAcrossGaps,
  /// proposals.h): the two sides of an object behind a thin occluder, widened by the
  /// projector's shadow, or an object a real sensor's holes cut in pieces. 0 = off, the
  /// default: at 0.03 on LM-O every 4th through the simulated sensor (g6d-bench-dataset
  /// --depth-sensor) the mean over five sensor seeds went from 87.2% to 87.5% without masks
  /// (+1.7 points on one seed, -0.9 on two), every other dev set's answers unchanged, and the
  /// proposals took 2-9 ms more (bench/RESULTS.md, "Neighbours across a gap").
  double gap_neighbour_reach_m = 0.0;
  /// A segment is an occluder on such a path when its median depth lies this many metres in
  /// front of the segment the path starts from; a fragment more than this behind it stops the
  /// path (what lies behind is no gap).
  double gap_occluder_margin_m = 0.01;
  /// Unions of at most this many neighbouring segments are candidates too.
  int max_union_segments = 3;
  /// At most this many distinct regions (segments and unions) are formed.
  int max_regions = 400;
  /// A region is a candidate for an object when its extent (Spans::Extent, a lower bound on
  /// its diameter) is at most the object's diameter plus the sensor noise and this many
  /// pixels at its depth at each end, and at least `min_extent_fraction` of the diameter.
  double extent_margin_px = 2.0;
  double min_extent_fraction = 0.3;
  /// ... and holds at least this fraction of the pixels the whole object would cover at the
  /// region's depth (about (f · diameter / z)² · π / 8 for a compact object).
  double min_area_fraction = 0.05;
  /// Candidates solved per object: its count plus this many, best ranked first (a candidate
  /// mostly inside one already chosen for solving is skipped). The explaining-away pass
  /// gives an object without an answer a second chance. 2: the right region of a part
  /// without colour often ranks 3rd or lower (its shape term is weak), and of an LM-O object
  /// on a crowded table too. From 1 to 2, without masks: synth_dev 58.5% -> 61.7% (AR 0.565
  /// -> 0.595), LM-O 90.4% -> 94.0% (0.906 -> 0.942), real YCB-V unchanged; wrong answers
  /// at >= 0.9 3 -> 4 of 264 -> 282 and 2 -> 3 of 412 -> 427; absent objects refused on
  /// synth_dev 90.0% -> 88.3%; p50 per image +24% (synth_dev 0.89 -> 1.11 s) and +36%
  /// (YCB-V clutter, 3 objects, 0.45 -> 0.61 s), side by side (bench/RESULTS.md, "More
  /// regions solved per object"). (At 2, issue 23's first detection lost a sample image to
  /// a wrong region's S; the confidence has read the frame since.)
  int extra_candidates = 2;
  /// The solve of a candidate region keeps at most this many hypotheses after observable
  /// selection (min with SolverOptions::num_hypotheses; 0 = the solver's K), and runs
  /// MSAC-PnP only on the correspondence sets whose quality Q_j is at least
  /// `solve_pnp_min_quality` of the best (SolverOptions::pnp_min_quality_ratio; the larger
  /// of the two). Most candidates hold no instance (in synth_dev's bins 73% of the regions
  /// solved), and the point-pair-feature poses keep their own slots. Measured without masks
  /// (bench/RESULTS.md, "Detection's solves"): synth_dev 52.7% at K = 18 and at K = 12 with
  /// PnP on sets of Q_j >= 0.5 Q_1, p50 per image 1920 -> 1465 ms; K = 6: 52.9%, 1370 ms,
  /// but the real YCB-V clutter's AR fell from 0.824 to 0.750 (textured objects' poses are
  /// more precise with more PnP starts; K = 12 keeps 0.824).
  int max_solve_hypotheses = 12;
  double solve_pnp_min_quality = 0.5;
  /// Poses from the outline (SolverOptions::use_silhouettes) in a candidate region's solve.
  /// Off: a region is cut from the depth, so its outline is the depth's (a pile of touching
  /// parts is one region), and the regions that hold an object have depth for the
  /// point-pair features.
  bool solve_silhouettes = false;
  /// Poses from the outline in the solve of an island or an island's piece (FormIslands): its
  /// outline is drawn by the support around it, pixels without depth included, so it is an
  /// object's outline when the island holds one object.
  bool island_silhouettes = true;
  /// The answer's flips checked in a candidate region's solve (in place of the caller's
  /// SolverOptions::check_flips):
  /// a region drawn by the depth shows a bare part from one side, and its 180-degree turn
  /// fits that side nearly as well. On synth_dev without masks: 64.8% -> 65.0%, wrong answers
  /// with confidence >= 0.9 7 -> 6 of 300, absent objects refused 83.3% -> 86.7%, answers
  /// called ambiguous 22 -> 33; LM-O 95.1% -> 94.9% (one instance), real YCB-V unchanged
  /// (bench/RESULTS.md, "Regions ranked by their area").
  bool solve_check_flips = true;
  /// Ranking: weight of the colour agreement against the size agreement (0 = size only).
  /// The colour term is the Bhattacharyya coefficient of chromaticity histograms of the
  /// region's pixels and the cache's appearance samples (neutral 0.5 for an uncoloured
  /// model).
  double colour_weight = 0.5;
  /// Ranking: the size agreement is the region's 3D extent over the object's diameter, and,
  /// with this weight, its area against the object's silhouettes at the region's depth
  /// (area_term: 1 between the 10th and 90th percentiles of the templates' silhouette areas,
  /// scaled to the region's depth, the ratio to the nearer one outside; 0 = extent only).
  /// A strip of a bin's wall or rim spans a part's diameter with a tenth of its area; a
  /// region of two parts has twice a silhouette's. 1 (the area alone; the extent still bounds
  /// a candidate): synth_dev without masks 61.7% -> 64.8% (AR 0.595 -> 0.626; bins 54.2 ->
  /// 56.3%, tables 71.8 -> 76.4%), LM-O 94.0 -> 95.1%, real YCB-V unchanged; 0.5: 64.3%. The
  /// regions solved that hold a part rose from 247 to about 290 of 429 (bench/RESULTS.md,
  /// "Regions ranked by their area").
  double area_weight = 1.0;
  /// Ranking an object without colour (bare metal, an uncoloured CAD model) by its shape:
  /// the shape term stands in for the colour term (same weight). It is the point-pair-feature
  /// vote's support of the region (PpfReferenceSupport of `shape_references` points of each
  /// of its depth segments, the segment's best, the region's pixel-weighted mean over its
  /// segments) over the best region's for that object: does the depth there look like the
  /// object, not only fit its size? In a bin the walls' fragments, the floor's speckle and
  /// the parts all fit a part's size. Objects with colour keep the colour term: on the real
  /// YCB-V clutter, ranking by shape too put a box's region first for the mustard bottle (the
  /// vote tells a curved surface from a flat one, not one flat-faced object from another;
  /// bench/RESULTS.md). Needs the bank's PPF model and SolverOptions::use_ppf (else 0.5).
  bool rank_uncoloured_by_shape = true;
  int shape_references = 4;
  /// An object's candidates are solved in rank order until it has `count` answers (not
  /// overlapping) whose confidence (SolverOptions' calibration of S_A) is at least
  /// `accept_confidence` and that explain their region: the mask the answer implies
  /// (PoseResult::corrected_mask) has an IoU of at least `accept_region_iou` with it. (A
  /// region of two objects can hold a good pose of one; it does not end the search.) The
  /// rest are not solved. 1 (the default) = always solve every chosen candidate: on the
  /// real YCB-V clutter a region of the sugar box and the bottle's top held a mustard-bottle
  /// pose with confidence 0.95 and region IoU 0.85, ranked above the bottle's own region
  /// (bench/RESULTS.md, issue 23); the search must compare the candidates.
  double accept_confidence = 1.0;
  double accept_region_iou = 0.7;
  /// The region solved is the candidate's segments plus the pixels without depth (or in
  /// depth fragments) within this many pixels of them that no other segment or support
  /// holds: a segmenter's mask covers the dark rims and holes of the object's depth too.
  int fill_gap_px = 3;
  /// Explaining away: when an object still lacks answers after a pass, the pixels of the
  /// answers kept so far are taken out and the rest is proposed, ranked and solved again for
  /// the objects still wanted, at most this many times (0 = one pass). Two objects that
  /// touch without a crease between them form one region too large for either; once the one
  /// found elsewhere (or in a region of its own) is taken out, the other stands alone.
  int explain_away_passes = 1;
  /// ... and then at most this many further passes for the objects that already have an
  /// answer and want more (a bin of one part: each pass takes the found parts out of the
  /// pile, and the parts that touched them stand alone, and regions ranked below the count
  /// get their turn). An object with no answer yet gets no further pass: it may not be there
  /// at all, and every pass is another chance for a confident guess. 1 (measured side by side
  /// on synth_dev without masks, bench/RESULTS.md, "One more pass for the parts of a bin"):
  /// 284 -> 288 of 412 right, bins' AR 0.592 -> 0.608, wrong answers at >= 0.9 2 -> 2, absent
  /// objects refused 88.3% unchanged, p50 per image +2%; 2 found no more and answered 2 more
  /// wrong (p50 of a bin of >= 10 parts +24%). Only the regions near answers new since the
  /// pass before: half the gain. (First measured at 0 -> 2 on older code: a bin of 10 parts
  /// took twice as long.)
  int found_object_passes = 1;
  /// An answer whose S_A is above this is no answer (confidence about 1% at the defaults).
  double max_score = 0.35;
  /// Non-maximum suppression: an answer whose corrected mask shares more than this fraction
  /// of its pixels with the mask of a better answer (lower S_A) is dropped.
  double max_overlap = 0.3;
  /// Objects compete for a region: an answer less confident than this is solved again on
  /// its own region as each other object asked for that the region was ranked for (an
  /// object that is not there takes the region of one that is: a bracket missed in a bin).
  /// When another object explains the region with a higher confidence (at least
  /// min_confidence), the answer is dropped, and the other object's answer takes its place
  /// if that object still wants instances and the pixels are free. 0 = off. On synth_dev without
  /// masks: 1 more part right, 1 fewer absent object answered, real sets unchanged, about
  /// 70 ms per image in the median (bench/RESULTS.md, "Objects compete for a region").
  double identity_check_below = 0.9;
  /// Regions from the point-pair-feature vote over the frame (less its support; ppf.h), for
  /// objects whose bank has a PPF model (and SolverOptions::use_ppf): the pose clusters with
  /// the most votes, each rendered into the frame, and the pixels whose depth lies on its
  /// rendered surface are a candidate region of that object, besides the depth segments'.
  /// Parts that touch in a bin, or an object leaning on another, form no segment of their
  /// own; the vote finds them anyway. Per object, its count plus `ppf_extra` such regions
  /// are solved (0 = off, the default: on synth_dev without masks they cost 1.1 s per image
  /// and took recall from 39.1% to 37.1%: a pose laid onto a surface that runs on past it
  /// explains its own region, and S cannot tell; bench/RESULTS.md).
  int ppf_extra = 0;
  /// The vote over the frame: every n-th scene point is a reference, at most this many scene points.
  int ppf_reference_stride = 4;
  int ppf_max_scene_points = 5000;
  /// A pose's region: its rendered pixels whose observed depth lies within this fraction of
  /// the diameter of the rendered surface; a pose whose rendered pixels see past its surface
  /// (observed depth farther than that: free space the object would fill) for more than
  /// `ppf_max_free_space` of them is no candidate.
  double ppf_surface_fraction = 0.1;
  double ppf_max_free_space = 0.5;
  /// ... and an object ends where the depth steps: at this fraction of its rendered outline
  /// at least, the depth just outside it must lie behind it (or in front: an occluder, or
  /// be missing) by more than `ppf_contour_step_m`. A pose laid onto a larger surface (a
  /// flat part onto a wall, a plate onto another part) explains the depth under it as well
  /// as the true one, but the surface runs on past its outline.
  double ppf_min_contour_support = 0.3;
  double ppf_contour_step_m = 0.005;
  /// Every answer is checked against the whole frame at its final pose (FrameCheck, in
  /// Detection::check): it is no answer when more than `max_free_space` of its rendered
  /// pixels with depth see past its surface (by more than `free_space_fraction` of the
  /// diameter), or when less than `min_contour_support` of its outline shows a depth step
  /// (ppf_contour_step_m). Off by default (1 and 0): as hard limits (0.15, 0.5) they took
  /// synth_dev's recall without masks from 39.1% to 33.3%, refusing right answers of parts
  /// whose outline meets a touching part at the same depth (bench/RESULTS.md).
  double max_free_space = 1.0;
  double free_space_fraction = 0.05;
  double min_contour_support = 0.0;
  /// An answer's confidence (PoseResult::confidence of a Detection): the probability that it
  /// is right, a logistic in what the answer has, fitted on the answers of every dev set
  /// without masks, absent objects asked for too (scripts/calibrate_detection.py;
  /// bench/RESULTS.md, "A confidence that knows"):
  ///   1 / (1 + exp(-(bias + score · S_A + ambiguous · [ambiguous] + on_surface ·
  ///   FrameCheck::on_surface + free_space · FrameCheck::free_space + contour ·
  ///   FrameCheck::contour_support + region_iou · IoU(corrected mask, region) + colour ·
  ///   CandidateTrial::colour_term + in_image · FrameCheck::in_image + edge ·
  ///   FrameCheck::oriented_edge + runner_up · RunnerUpGap + free_band ·
  ///   FrameCheck::free_space_band_px))).
  /// S_A alone says little here: a pose laid onto the wrong region explains that region;
  /// the frame around it says more, and so does the region's colour: an object asked for
  /// that is not there is mostly answered on another object's region (colour_term 0.5 for a
  /// model without colour, so bare metal is neither helped nor hurt).
  /// A pose mostly beyond the image's border is checked on the little of it inside: a flat
  /// part laid onto a sliver of floor at the border explains it at S_A 0.02 (in_image).
  /// A flat part lying on a table or a bin's floor shows no depth step at its outline, and
  /// its region holds only what stands above the support: a right answer on such a part had
  /// a low contour and region IoU and was refused; its outline is still in the colour image
  /// (edge · FrameCheck::oriented_edge: an edge along the outline; on a carpet or a keyboard
  /// any outline meets some edge, FrameCheck::edge_support, which read them as support).
  /// A wrong answer is mostly one of two poses that explain the frame almost equally (a
  /// bracket turned over): its own solve had a rival close in S (RunnerUpGap: median 0.04
  /// for wrong answers, 0.22 for right ones), which the yes/no `ambiguous` told only below
  /// SolverOptions::ambiguity_margin (runner_up · RunnerUpGap; ambiguous's weight fell to
  /// 0.2 beside it, and stays only so that old weight lists keep their order).
  /// What the camera sees through is read as a band's width in pixels along the outline
  /// (free_band · FrameCheck::free_space_band_px), not as a share of the rendered pixels
  /// (FrameCheck::free_space, weight 0 now, kept so that old lists keep their order): a right
  /// answer's rim of a pixel or two is a third of a small part's rendering and 1% of a large
  /// box's, while a slab laid onto a smaller box hangs over it by a band 5 px wide (13% of it).
  /// Fitted on 848 answers (synth_dev, all of LM-O, real YCB-V asked for every dev-set
  /// object, at min_confidence 0; answers refused by rule, whose confidence is 0, left out:
  /// they are no answers whatever the weights) by scripts/calibrate_detection.py, its
  /// features standardized and their weights held back by one L2 penalty (3): left out one
  /// object at a time ECE 0.012, Brier 0.022, answers wrong with confidence >= 0.9: 2; each
  /// dataset held out (fitted on the others) Brier synth_dev 0.050, LM-O 0.019, YCB-V clutter
  /// 0.021, foam brick scene 0.043, and synth_dev's answers wrong at >= 0.9 5 of 351. The
  /// fit as unpenalized as before, on the same answers: 0.017, 0.025, 6; held out 0.078
  /// (12 wrong at >= 0.9), 0.022, 0.018, 0.053 (bench/RESULTS.md, "Detection's confidence,
  /// fitted to hold in scenes it has not seen").
  double confidence_bias = -16.737;
  double confidence_score_weight = -4.868;
  double confidence_ambiguous_weight = 0.114;
  double confidence_on_surface_weight = 3.955;
  double confidence_free_space_weight = 0.0;
  double confidence_contour_weight = 2.063;
  double confidence_region_iou_weight = 6.337;
  double confidence_colour_weight = 1.997;
  double confidence_in_image_weight = 6.283;
  double confidence_edge_weight = 4.546;
  double confidence_runner_up_weight = 16.110;
  double confidence_free_band_weight = -3.719;
  /// An answer less likely right than wrong is no answer: a request for an object that is
  /// not there mostly gets none (the service's STATUS_NO_SOLUTION). A trade: on synth_dev
  /// without masks 0.1 / 0.5 answered 75% / 90% of the requests for absent objects with no
  /// answer and found 52.9% / 52.7% of the objects there; on LM-O 91.8% / 90.9%
  /// (bench/RESULTS.md, "A confidence that knows").
  double min_confidence = 0.5;
  /// An answer whose model reaches behind the support under its region (the solve found no
  /// finalist in front of it: StageReport::answer_behind_support, SolverOptions::
  /// support_penetration_fraction; or it reaches behind the frame's support plane that holds
  /// most of the depth around its region, DepthBehindFrameSupport) is no answer: no object
  /// lies inside the table or floor.
  /// On synth_dev without masks: wrong answers 29 -> 21, absent objects refused 88.3% ->
  /// 93.3%, right 288 -> 290 of 412 (no right answer lost); in the search of depth regions
  /// inside a degraded mask, cut / merged / box +2 / +2 / +3; the real sets and LM-O
  /// unchanged (bench/RESULTS.md, "Detection refuses answers inside the support").
  bool refuse_behind_support = true;
  /// The order in which answers claim their object's count and the frame's pixels: those at
  /// least this confident first, then the others, each group by S_A (lowest first). A sure
  /// answer is not pushed out by an unsure one of lower S_A (a pose that fits a few pixels
  /// closely, e.g. one mostly beyond the image); among sure answers S_A decides, as in the
  /// paper. > 1 = by S_A alone.
  double sure_first_confidence = 0.9;
  /// A region's solve takes the frame's support plane around it (SupportAround) as its
  /// support limit where the depth in its own ring shows none (Instance::has_support_limit):
  /// the solve then prefers a finalist in front of it, instead of an answer refused after.
  bool support_limit_from_frame = true;

  /// Empty when valid, else names the bad field.
  std::string Check() const;
};

}  // namespace g6d
