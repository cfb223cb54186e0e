#pragma once
// The decisions as a run makes them (rrr_slam_offline and rrr_offline --decision-stream): one row
// per loop candidate's arrival and per verdict change, with the scan and node at which it happened.
// The decisions table (--decisions) holds only the final verdicts; this is what a robot saw on the
// way, for scoring online decisions and for finding when a session was tied to a map.

#include <cstddef>
#include <iomanip>
#include <ostream>
#include <string>
#include <vector>

#include "rrr_graphslam/core/atomic_file.h"
#include "rrr_graphslam/rrr/online_rrr.h"

namespace rrr_graphslam::tools {

class DecisionStream {
 public:
  /// Takes `rrr`'s changes since the last call: they happened at log scan `scan` (1-based), when
  /// the graph had `nodes` nodes, at ipc_timestamp `stamp`. `final`: the decision from scratch at
  /// the end of the run. The candidates of a loaded map arrived in earlier runs: they have no
  /// arrival row, only their changes.
  void record(rrr::OnlineRrr& rrr, std::size_t scan, int nodes, double stamp, bool final) {
    for (rrr::DecisionChange& change : rrr.takeChanges()) {
      add(scan, nodes, stamp, final, std::move(change));
    }
  }
  /// One row: `change` happened at `scan` with `nodes` nodes, at `stamp`.
  void add(std::size_t scan, int nodes, double stamp, bool final, rrr::DecisionChange change) {
    rows_.push_back({scan, nodes, stamp, final, std::move(change)});
  }

  /// Header 'when scan nodes stamp candidate from to cluster previous verdict reason'; `when` is
  /// `online` or `final`, `previous` equals `verdict` (pending) on an arrival. Written atomically.
  void write(const std::string& path) const {
    core::writeFileAtomically(path, [&](std::ostream& out) {
      out << "when\tscan\tnodes\tstamp\tcandidate\tfrom\tto\tcluster\tprevious\tverdict\treason\n";
      out << std::fixed << std::setprecision(6);
      for (const Row& r : rows_) {
        const rrr::DecisionChange& c = r.change;
        out << (r.final ? "final" : "online") << '\t' << r.scan << '\t' << r.nodes << '\t'
            << r.stamp << '\t' << c.candidate << '\t' << c.from << '\t' << c.to << '\t' << c.cluster
            << '\t' << rrr::toString(c.previous) << '\t' << rrr::toString(c.verdict) << '\t'
            << c.reason << '\n';
      }
    });
  }

  std::size_t size() const { return rows_.size(); }

 private:
  struct Row {
    std::size_t scan;
    int nodes;
    double stamp;
    bool final;
    rrr::DecisionChange change;
  };
  std::vector<Row> rows_;
};

}  // namespace rrr_graphslam::tools
