// rrr_bench_icp_slam LOG.clf[.gz] --trajectory TRAJ.txt [--max-scans N]
// The baseline of scripts/bench_slam: MRPT's ICP-SLAM (CMetricMapBuilderICP, the algorithm of the
// icp-slam application: scan-to-map ICP on a points map, no loop closing) run in-process on the
// scans of a CARMEN log read by our reader, so that it sees the same beams (carmen2rawlog 2.5.8
// gets the FLASER angles and the timestamps wrong). Writes the pose of every scan in TUM format.

#include <chrono>
#include <cstdio>
#include <exception>
#include <iomanip>
#include <iostream>
#include <string>

#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose3DPDF.h>
#include <mrpt/slam/CMetricMapBuilderICP.h>

#include "rrr_graphslam/core/atomic_file.h"
#include "rrr_graphslam/core/text_file.h"
#include "rrr_graphslam/frontend/carmen_log.h"

namespace {

namespace core = rrr_graphslam::core;
namespace frontend = rrr_graphslam::frontend;

// The scan in MRPT's documented convention (rays aperture/(N-1) apart, centred on the sensor's x).
mrpt::obs::CObservation2DRangeScan::Ptr toIcpObservation(const frontend::LaserRecord& r) {
  auto obs = mrpt::obs::CObservation2DRangeScan::Create();
  const std::size_t n = r.ranges.size();
  const double aperture = static_cast<double>(n - 1) * r.angle_increment;
  const core::Pose2 laser = r.laserInRobot();
  obs->aperture = static_cast<float>(aperture);
  obs->rightToLeft = true;
  obs->maxRange = static_cast<float>(r.max_range);
  obs->sensorPose = mrpt::poses::CPose3D(laser.x(), laser.y(), 0.0,
                                         laser.z() + r.angle_min + 0.5 * aperture, 0.0, 0.0);
  obs->resizeScan(n);
  for (std::size_t i = 0; i < n; ++i) {
    obs->setScanRange(i, r.ranges[i]);
    obs->setScanRangeValidity(i, r.ranges[i] < r.max_range && r.ranges[i] > 0.05F);
  }
  return obs;
}

}  // namespace

int main(int argc, char** argv) {
  std::string log_path, trajectory;
  std::size_t max_scans = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--trajectory" && i + 1 < argc) {
      trajectory = argv[++i];
    } else if (a == "--max-scans" && i + 1 < argc) {
      max_scans = std::stoul(argv[++i]);
    } else if (!a.empty() && a[0] != '-' && log_path.empty()) {
      log_path = a;
    } else {
      std::cerr << "usage: rrr_bench_icp_slam LOG --trajectory TRAJ.txt [--max-scans N]\n";
      return 2;
    }
  }
  if (log_path.empty() || trajectory.empty()) {
    std::cerr << "usage: rrr_bench_icp_slam LOG --trajectory TRAJ.txt [--max-scans N]\n";
    return 2;
  }
  try {
    const frontend::CarmenLog log = frontend::readCarmenLog(log_path);
    const std::size_t n = max_scans > 0 ? std::min(max_scans, log.scans.size()) : log.scans.size();
    mrpt::slam::CMetricMapBuilderICP icp;
    icp.setVerbosityLevel(mrpt::system::LVL_ERROR);
    icp.ICP_options.mapInitializers.push_back(mrpt::maps::CSimplePointsMap::TMapDefinition());
    icp.initialize();
    mrpt::obs::CActionRobotMovement2D::TMotionModelOptions motion;
    const auto start = std::chrono::steady_clock::now();
    std::vector<core::Pose2> poses;
    for (std::size_t k = 0; k < n; ++k) {
      const auto& r = log.scans[k];
      mrpt::obs::CActionCollection actions;
      if (k > 0) {
        const core::Pose2 d = core::between(log.scans[k - 1].odom_pose, r.odom_pose);
        mrpt::obs::CActionRobotMovement2D move;
        move.computeFromOdometry(mrpt::poses::CPose2D(d.x(), d.y(), d.z()), motion);
        move.timestamp = mrpt::Clock::fromDouble(r.timestamp);
        actions.insert(move);
      }
      mrpt::obs::CSensoryFrame frame;
      auto obs = toIcpObservation(r);
      obs->timestamp = mrpt::Clock::fromDouble(r.timestamp);
      frame.insert(obs);
      icp.processActionObservation(actions, frame);
      const auto pose = icp.getCurrentPoseEstimation()->getMeanVal();
      poses.emplace_back(pose.x(), pose.y(), pose.yaw());
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    core::writeFileAtomically(trajectory, [&](std::ostream& out) {
      out << "# t x y z qx qy qz qw (MRPT CMetricMapBuilderICP)\n" << std::fixed;
      for (std::size_t k = 0; k < poses.size(); ++k) {
        const core::Pose2& x = poses[k];
        out << std::setprecision(6) << log.scans[k].timestamp << ' ' << x.x() << ' ' << x.y()
            << " 0 0 0 " << std::setprecision(9) << std::sin(0.5 * x.z()) << ' '
            << std::cos(0.5 * x.z()) << '\n';
      }
    });
    std::printf("scans %zu time %.2f s\n", n, seconds);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "rrr_bench_icp_slam: " << e.what() << "\n";
    return 1;
  }
}
