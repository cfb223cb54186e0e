#pragma once
// Trajectories as the tools write them: TUM format, 't x y z qx qy qz qw' per pose, z = 0 and
// the yaw as a quaternion about z; written atomically.

#include <cmath>
#include <iomanip>
#include <ostream>
#include <string>
#include <vector>

#include "rrr_graphslam/core/atomic_file.h"
#include "rrr_graphslam/core/se2.h"

namespace rrr_graphslam::tools {

/// Poses from index `first` on, each with its timestamp; `source` names the writer in the
/// header comment.
inline void writeTumTrajectory(const std::string& path, const std::string& source,
                               const std::vector<double>& stamps,
                               const std::vector<core::Pose2>& poses, std::size_t first = 0) {
  core::writeFileAtomically(path, [&](std::ostream& out) {
    out << "# t x y z qx qy qz qw (" << source << "; t = ipc_timestamp)\n" << std::fixed;
    for (std::size_t k = first; k < poses.size(); ++k) {
      const core::Pose2& x = poses[k];
      out << std::setprecision(6) << stamps[k] << ' ' << std::setprecision(6) << x.x() << ' '
          << x.y() << " 0 0 0 " << std::setprecision(9) << std::sin(0.5 * x.z()) << ' '
          << std::cos(0.5 * x.z()) << '\n';
    }
  });
}

}  // namespace rrr_graphslam::tools
