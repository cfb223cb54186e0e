#include "rrr_graphslam/rrr/decisions_io.h"

#include <ostream>

#include "rrr_graphslam/core/text_file.h"

namespace rrr_graphslam::rrr {

void writeDecisions(const std::string& path, const std::vector<DecisionRow>& rows) {
  core::writeFileAtomically(path, [&](std::ostream& out) {
    out << "from\tto\tcluster\tverdict\n";
    for (const DecisionRow& row : rows) {
      out << row.from << '\t' << row.to << '\t' << row.cluster << '\t' << toString(row.verdict)
          << '\n';
    }
  });
}

}  // namespace rrr_graphslam::rrr
