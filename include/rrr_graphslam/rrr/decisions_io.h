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

/// Reads a table (4 or 5 columns; plain or .gz). Throws core::InputError naming file:line.
std::vector<DecisionRow> readDecisions(const std::string& path);

/// g2o has no edge kinds: its reader takes an edge between id-consecutive nodes for odometry, so
/// a loop between the last node of one session and the first of the next would come back as
/// trusted odometry. A graph saved with its decisions (the node's ~save) holds its loop
/// candidates last, in the table's order: this marks the last rows.size() edges as candidates,
/// and the edges before them that do not join consecutive ids as marginal constraints (~save
/// writes odometry, then marginal constraints, then the candidates). Throws core::InputError naming
/// `decisions_path` when the rows do not match those edges.
void markCandidates(const std::vector<DecisionRow>& rows, const std::string& decisions_path,
                    core::PoseGraph& graph);

}  // namespace rrr_graphslam::rrr
