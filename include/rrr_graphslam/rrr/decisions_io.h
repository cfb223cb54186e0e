#pragma once
// DECISIONS.tsv, the decision table the tools, the node's ~save and the evaluation scripts share:
// a header line "from<TAB>to<TAB>cluster<TAB>verdict<TAB>reason", then one row per loop candidate
// in input order (cluster -1 while the candidate is in no closed cluster; verdict accepted,
// rejected or pending; reason: the step of RRR that decided and its statistic against its
// threshold, without tabs). Readers take the first four columns; the fifth may be absent in
// files written before it existed.

#include <ostream>
#include <string>
#include <vector>

#include "rrr_graphslam/core/pose_graph.h"
#include "rrr_graphslam/rrr/rrr.h"

namespace rrr_graphslam::rrr {

struct DecisionRow {
  core::PoseGraph::NodeId from;
  core::PoseGraph::NodeId to;
  int cluster;
  Verdict verdict;
  std::string reason;
};

/// Writes the table atomically (temp file + rename); throws std::runtime_error naming the path.
void writeDecisions(const std::string& path, const std::vector<DecisionRow>& rows);
/// The table's text (header and rows), for a file written with others (core::AtomicFileSet).
void writeDecisions(std::ostream& out, const std::vector<DecisionRow>& rows);

}  // namespace rrr_graphslam::rrr
