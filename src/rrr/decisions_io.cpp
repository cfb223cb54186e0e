#include "rrr_graphslam/rrr/decisions_io.h"

#include <algorithm>
#include <ostream>

#include "rrr_graphslam/core/atomic_file.h"

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

}  // namespace rrr_graphslam::rrr
