// rrr_align_scans LOG.clf[.gz] PAIRS.tsv [--max-range M] [--window M] [--angular-window DEG]
//                 [--min-score S] [--overlap-distance M]
// Aligns pairs of a log's raw scans with each other (frontend/scan_alignment.h) and scores
// given relative poses by the overlap of the two scans: the measurement side of the scan-
// consistency check of scripts/evaluate_slam.

#include <cmath>
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "command_line.h"
#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/core/line_parser.h"
#include "rrr_graphslam/core/text_file.h"
#include "rrr_graphslam/frontend/carmen_log.h"
#include "rrr_graphslam/frontend/range_scan.h"
#include "rrr_graphslam/frontend/scan_alignment.h"

namespace {

namespace tools = rrr_graphslam::tools;
namespace core = rrr_graphslam::core;
namespace frontend = rrr_graphslam::frontend;

const char* const kUsage =
    "usage: rrr_align_scans LOG.clf[.gz] PAIRS.tsv [--max-range M] [--window M]\n"
    "                       [--angular-window DEG] [--min-score S] [--overlap-distance M]\n"
    "  LOG        the CARMEN log (FLASER / ROBOTLASER1 scans, counted from 0 in log order)\n"
    "  PAIRS.tsv  one pair a line: 'A B x y theta [x y theta ...]', scans A and B and one or\n"
    "             more poses of B's robot in A's robot frame (m, rad); the first is where the\n"
    "             search starts. Lines starting with # are skipped.\n"
    "  --max-range         readings beyond it are not used (default 30 m)\n"
    "  --window            half-width of the translations searched (default 2 m)\n"
    "  --angular-window    half-width of the rotations searched (default 15 degrees)\n"
    "  --min-score         branch-and-bound score an alignment needs (default 0.3)\n"
    "  --overlap-distance  a point of B overlaps within this of A's surfaces (its points, and\n"
    "                      lines between neighbouring points at most 0.5 m apart) (default 0.1 m)\n"
    "Prints one line a pair: 'A B found x y theta score overlap lx ly ltheta loverlap\n"
    "overlap_1 ...': found is 1 when the scans aligned in the window (x y theta: the best pose\n"
    "there, overlap: its overlap fraction), else 0 (x y theta score overlap are then nan);\n"
    "lx ly ltheta: ICP alone from the first given pose (the nearest local optimum), loverlap its\n"
    "overlap; overlap_k is the overlap fraction at the k-th given pose.\n";

struct Pair {
  std::size_t a;
  std::size_t b;
  std::vector<core::Pose2> poses;
};

std::vector<Pair> readPairs(const std::string& path, std::size_t num_scans) {
  core::LineReader reader(path);
  std::vector<Pair> pairs;
  std::string line;
  while (reader.next(line)) {
    const auto fields = core::splitFields(line);
    if (fields.empty() || fields[0].front() == '#') continue;
    const core::LineParser parser(reader, "pair", fields);
    // The parser counts fields after a tag; a pair line has none, so field k is fields[k].
    if (fields.size() < 5 || (fields.size() - 2) % 3 != 0) {
      parser.fail("needs 'A B' and one or more 'x y theta'");
    }
    Pair pair{
        parser.unsignedInteger(0, "a scan index"), parser.unsignedInteger(1, "a scan index"), {}};
    if (pair.a >= num_scans || pair.b >= num_scans) {
      parser.fail("scan index beyond the log's " + std::to_string(num_scans) + " scans");
    }
    for (std::size_t k = 2; k < fields.size(); k += 3) pair.poses.push_back(parser.pose(k));
    pairs.push_back(std::move(pair));
  }
  return pairs;
}

}  // namespace

int main(int argc, char** argv) {
  const tools::CommandLine cli(argc, argv, "rrr_align_scans", kUsage);
  std::string log_path, pairs_path;
  frontend::RangeScanParams scan_params;
  frontend::ScanAlignmentParams params;
  double overlap_m = 0.1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--max-range") {
      scan_params.max_range_m = cli.number(a, cli.value(i, a), 0.5, 1000.0);
    } else if (a == "--window") {
      params.window.linear_m = cli.number(a, cli.value(i, a), 0.0, 20.0);
    } else if (a == "--angular-window") {
      params.window.angular_rad = cli.number(a, cli.value(i, a), 0.0, 180.0) * M_PI / 180;
    } else if (a == "--min-score") {
      params.min_score = cli.number(a, cli.value(i, a), 0.0, 1.0);
    } else if (a == "--overlap-distance") {
      overlap_m = cli.number(a, cli.value(i, a), 0.001, 10.0);
    } else if (!a.empty() && a[0] != '-' && log_path.empty()) {
      log_path = a;
    } else {
      cli.positional(a, pairs_path);
    }
  }
  if (log_path.empty() || pairs_path.empty()) cli.fail("needs a log and a pairs file");
  try {
    const frontend::CarmenLog log = frontend::readCarmenLog(log_path);
    const std::vector<Pair> pairs = readPairs(pairs_path, log.scans.size());
    // A's surfaces (its points, and between neighbouring ones) against B's points.
    std::vector<frontend::PointCloud> points(log.scans.size()), surfaces(log.scans.size());
    auto pointsOf = [&](std::size_t k) -> const frontend::PointCloud& {
      if (points[k].empty()) {
        points[k] =
            frontend::matchingPoints(frontend::RangeScan::fromCarmen(log.scans[k]), scan_params);
      }
      return points[k];
    };
    auto surfaceOf = [&](std::size_t k) -> const frontend::PointCloud& {
      if (surfaces[k].empty()) surfaces[k] = frontend::surfacePoints(pointsOf(k), 0.5, 0.02);
      return surfaces[k];
    };
    for (const Pair& pair : pairs) {
      const auto& a = surfaceOf(pair.a);
      const auto& b = pointsOf(pair.b);
      const auto aligned = frontend::alignScans(a, b, pair.poses.front(), params);
      std::printf("%zu %zu %d", pair.a, pair.b, aligned ? 1 : 0);
      if (aligned) {
        std::printf(" %.4f %.4f %.5f %.3f %.3f", aligned->pose.x(), aligned->pose.y(),
                    aligned->pose.z(), aligned->score,
                    frontend::overlapFraction(a, b, aligned->pose, overlap_m));
      } else {
        std::printf(" nan nan nan nan nan");
      }
      // No search: ICP from the given pose, which a scan pair with several good alignments (a
      // corridor, a row of doors) needs beside the best one to be told apart from a wrong pose.
      const core::Pose2 near = frontend::refineScanIcp(a, b, pair.poses.front(), params);
      std::printf(" %.4f %.4f %.5f %.3f", near.x(), near.y(), near.z(),
                  frontend::overlapFraction(a, b, near, overlap_m));
      for (const auto& pose : pair.poses) {
        std::printf(" %.3f", frontend::overlapFraction(a, b, pose, overlap_m));
      }
      std::printf("\n");
    }
  } catch (const std::exception& e) {
    std::cerr << "rrr_align_scans: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
