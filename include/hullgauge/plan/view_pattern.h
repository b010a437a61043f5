// View pattern analysis (dissertation 5.5, 5.6.1) on view variation lists.
//
// Candidate poses are numbered 0..P-1. A view variation list is the sorted
// set of candidate poses that give a view's information (5.4: the poses
// equivalent to a best view under Rules 1-4). A requirement is one AND term of
// a landmark's best views (eq. 5.3.2-2): OR over sub-views (eq. 5.3.2-1), each
// with its own variation list.
//
// The greedy follows 5.6.1: (1) OR redundancy removal — repeatedly take the
// OR sub-view with the largest intersection with a view it is not OR-related
// to, keep it and drop its siblings; (2) AND combination — repeatedly merge the
// two views with the largest intersection (the merged list is the
// intersection, 5.4.4) until no two views intersect in at least
// `minIntersection` poses. Each surviving group is one final view.
//
// The exact solver states the same problem as a set cover integer program
// (one binary per candidate pose, one covering row per requirement) and solves
// it with GLPK's branch and cut, to measure how far the greedy is from optimal.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace hg::plan {

/// Sorted, duplicate-free candidate pose indices.
using PoseSet = std::vector<int>;

PoseSet intersect(const PoseSet& a, const PoseSet& b);
std::size_t intersectionSize(const PoseSet& a, const PoseSet& b);

/// One AND term of one landmark: any one of `anyOf` sub-views will do.
struct Requirement {
    std::size_t landmark = 0;
    std::vector<PoseSet> anyOf;
};

struct PatternOptions {
    /// AND combination stops when no two views share this many poses (>= 1).
    std::size_t minIntersection = 1;
};

/// One final view group: its variation list and what it serves.
struct ViewGroup {
    PoseSet variation;
    std::vector<std::size_t> requirements; ///< indices into the requirement list
    std::vector<std::size_t> landmarks;    ///< sorted, unique
};

/// The greedy of 5.6.1. A requirement with an empty sub-view list, or whose
/// chosen sub-view has an empty variation list, cannot be served: it is
/// returned in `unserved` and gets no group.
struct GreedyResult {
    std::vector<ViewGroup> groups;
    std::vector<std::size_t> unserved;
};
GreedyResult greedyViewPattern(const std::vector<Requirement>& requirements, const PatternOptions& options = {});

/// Drops final poses whose requirements are all met by the other poses
/// (a final redundancy check after 5.4.4's pose choice: a pose chosen for one
/// group often also lies in other groups' lists). Poses serving the fewest
/// requirements are tried first; the result keeps the input order.
std::vector<int> removeRedundantPoses(const std::vector<Requirement>& requirements, std::vector<int> poses);

/// Minimum set cover by integer programming (GLPK). Every requirement must be
/// met by one chosen pose from the union of its sub-views' lists.
struct ExactResult {
    bool solved = false;  ///< an integer solution was found
    bool optimal = false; ///< and proven optimal within the time limit
    std::vector<int> poses;
    std::string message; ///< why it was not solved
};
ExactResult exactViewCover(const std::vector<Requirement>& requirements, double timeLimitSeconds = 10.0);

} // namespace hg::plan
