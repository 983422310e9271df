#pragma once
/// @file neighbours.h
/// A frame's instances read together: pixels of one instance's mask that a more confident
/// neighbour's answer explains are that neighbour's, not the instance's.
///
/// A segmenter that merges two touching objects, or a detector's box over a neighbour,
/// gives a mask the depth alone often cannot split: the objects touch at the same depth,
/// and S, read on that mask, prefers a pose that covers the neighbour too. When the
/// neighbour is itself an instance of the same request and its answer is confident, the
/// mask its pose implies (PoseResult::corrected_mask: its silhouette where the depth agrees)
/// says which pixels are its own. The instance is solved again on its mask less those
/// pixels, and that answer replaces the first when its S_A is lower.

#include <vector>

#include "core/executor.h"
#include "core/frame.h"
#include "solver/pipeline.h"
#include "templates/template_bank.h"

namespace g6d {

/// Two answers of one object closer than this fraction of its diameter (the centres of the
/// mesh at the two poses) are one instance's.
constexpr double kSamePlaceFraction = 0.1;

/// True when successful answers `a` and `b` of `bank`'s object lie at one place
/// (kSamePlaceFraction): they are answers on one instance.
bool SamePlace(const PoseResult& a, const PoseResult& b, const TemplateBank& bank);

/// For each answer, the index of another instance's answer of the same object at the same
/// place with a lower S_A (on a tie, the lower index), or -1: two requests answered on one
/// instance (two masks merged over the same parts of a bin). All -1 when
/// SolverOptions::resolve_duplicates is off.
std::vector<int> DuplicateAnswers(const std::vector<Instance>& instances, const std::vector<const TemplateBank*>& banks,
                                  const std::vector<PoseResult>& answers, const SolverOptions& options);

/// Second pass over a frame's answers (SolverOptions::explain_neighbours, MaskTrust::kDepth):
/// `instances[i]`, solved with `banks[i]` into `(*answers)[i]` (EstimatePose, or any solve
/// that fills corrected_mask), is solved again on its mask less the pixels of the confident
/// answers of lower S_A of the other instances (not UnsureOfScore),
/// when its mask holds more than the object (a merged mask, a box) or its answer is unsure,
/// and the neighbours explain at least `SolverOptions::neighbour_min_fraction` of its mask.
/// An answer with a twin (DuplicateAnswers) is solved again too, without the twin's pixels
/// whatever the twin's S_A, and any successful answer elsewhere replaces it (two requests
/// are two instances); an answer still at a twin's place afterwards is flagged
/// (StageReport::duplicate_answer) and its confidence is at most 1 - the twin's. Otherwise a
/// lower S_A replaces the answer (StageReport::neighbour_pixels, neighbour_answer_chosen,
/// neighbours_ms). Every re-solve reads only the first pass's answers, so the result does
/// not depend on the instances' order. `may_solve_again`: empty, or one flag per instance;
/// an instance whose flag is 0 keeps its answer (the service's tracked answers: a tracked
/// pose is not solved from scratch every frame) but still explains its pixels for the
/// others. The sizes must agree (else g6d::Error); never throws for bad data in an instance
/// (its answer stands).
void ExplainAwayNeighbours(const Frame& frame, const std::vector<Instance>& instances,
                           const std::vector<const TemplateBank*>& banks, const std::vector<char>& may_solve_again,
                           const SolverOptions& options, Executor* executor, std::vector<PoseResult>* answers);

}  // namespace g6d
