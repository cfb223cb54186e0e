#include "rrr_graphslam/rrr/decisions_io.h"

#include <algorithm>
#include <ostream>

#include "rrr_graphslam/core/atomic_file.h"
#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/core/line_parser.h"
#include "rrr_graphslam/core/text_file.h"

namespace rrr_graphslam::rrr {

void writeDecisions(std::ostream& out, const std::vector<DecisionRow>& rows) {
  out << "from\tto\tcluster\tverdict\treason\n";
  for (const DecisionRow& row : rows) {
    std::string reason = row.reason;
    std::replace_if(
        reason.begin(), reason.end(), [](char c) { return c == '\t' || c == '\n'; }, ' ');
    out << row.from << '\t' << row.to << '\t' << row.cluster << '\t' << toString(row.verdict)
        << '\t' << reason << '\n';
  }
}

void writeDecisions(const std::string& path, const std::vector<DecisionRow>& rows) {
  core::writeFileAtomically(path, [&](std::ostream& out) { writeDecisions(out, rows); });
}

std::vector<DecisionRow> readDecisions(const std::string& path) {
  core::LineReader reader(path);
  std::string line;
  if (!reader.next(line) ||
      (line != "from\tto\tcluster\tverdict" && line != "from\tto\tcluster\tverdict\treason")) {
    throw core::InputError(path, 1,
                           "header must be 'from<TAB>to<TAB>cluster<TAB>verdict' (+ reason)");
  }
  const bool with_reason = line.size() > std::string("from\tto\tcluster\tverdict").size();
  std::vector<DecisionRow> rows;
  while (reader.next(line)) {
    std::vector<std::string> fields;
    std::size_t start = 0;
    for (std::size_t tab = line.find('\t');; tab = line.find('\t', start)) {
      fields.push_back(
          line.substr(start, tab == std::string::npos ? std::string::npos : tab - start));
      if (tab == std::string::npos) break;
      start = tab + 1;
    }
    const std::size_t columns = with_reason ? 5 : 4;
    if (fields.size() != columns) {
      throw core::InputError(path, reader.lineNumber(),
                             "expected " + std::to_string(columns) +
                                 " tab-separated fields, found " + std::to_string(fields.size()));
    }
    DecisionRow row{};
    try {
      std::size_t used = 0;
      row.from = std::stoull(fields[0], &used);
      if (used != fields[0].size()) throw std::invalid_argument("from");
      row.to = std::stoull(fields[1], &used);
      if (used != fields[1].size()) throw std::invalid_argument("to");
      row.cluster = std::stoi(fields[2], &used);
      if (used != fields[2].size()) throw std::invalid_argument("cluster");
    } catch (const std::exception&) {
      throw core::InputError(path, reader.lineNumber(), "from, to and cluster must be integers");
    }
    if (fields[3] == "accepted") {
      row.verdict = Verdict::kAccepted;
    } else if (fields[3] == "rejected") {
      row.verdict = Verdict::kRejected;
    } else if (fields[3] == "pending") {
      row.verdict = Verdict::kPending;
    } else {
      throw core::InputError(
          path, reader.lineNumber(),
          "verdict must be accepted, rejected or pending, not '" + fields[3] + "'");
    }
    if (with_reason) row.reason = fields[4];
    rows.push_back(std::move(row));
  }
  return rows;
}

void markCandidates(const std::vector<DecisionRow>& rows, const std::string& decisions_path,
                    core::PoseGraph& graph) {
  if (rows.size() > graph.numEdges()) {
    throw core::InputError(decisions_path, 0,
                           std::to_string(rows.size()) + " decisions for a graph of " +
                               std::to_string(graph.numEdges()) + " edges");
  }
  const std::size_t first = graph.numEdges() - rows.size();
  for (std::size_t k = 0; k < first; ++k) {
    const auto& edge = graph.edge(k);
    if (core::PoseGraph::defaultKind(edge.from, edge.to) != core::EdgeKind::kOdometry) {
      graph.setEdgeKind(k, core::EdgeKind::kMarginal);
    }
  }
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const auto& edge = graph.edge(first + k);
    if (edge.from != rows[k].from || edge.to != rows[k].to) {
      throw core::InputError(decisions_path, k + 2,
                             "decision " + std::to_string(rows[k].from) + " -> " +
                                 std::to_string(rows[k].to) + " does not match the graph's edge " +
                                 std::to_string(edge.from) + " -> " + std::to_string(edge.to) +
                                 " (the candidates must be the graph's last edges, as ~save "
                                 "writes them)");
    }
    graph.setEdgeKind(first + k, core::EdgeKind::kLoopCandidate);
  }
}

}  // namespace rrr_graphslam::rrr
