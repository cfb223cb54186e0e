#include "rrr_graphslam/frontend/map_io.h"
#include "rrr_graphslam/core/atomic_file.h"

#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <stdexcept>

#include <mrpt/img/CImage.h>

#include "rrr_graphslam/core/text_file.h"

namespace rrr_graphslam::frontend {
namespace {

// Pixel (column, row) of a point, row 0 at the top (largest y), as images are read.
Eigen::Array2i pixelOf(const mrpt::maps::COccupancyGridMap2D& grid, const core::Pose2& p) {
  const int cx = grid.x2idx(p.x());
  const int cy = grid.y2idx(p.y());
  return {cx, static_cast<int>(grid.getSizeY()) - 1 - cy};
}

}  // namespace

unsigned char mapServerPixel(float probability, const MapServerThresholds& thresholds) {
  if (probability >= thresholds.occupied) return 0;
  if (probability <= thresholds.free) return 254;
  return 205;
}

void writeMapServerFiles(const mrpt::maps::COccupancyGridMap2D& grid, const std::string& base,
                         const MapServerThresholds& thresholds) {
  const unsigned width = grid.getSizeX();
  const unsigned height = grid.getSizeY();
  core::writeFileAtomically(base + ".pgm", [&](std::ostream& out) {
    out << "P5\n# rrr_graphslam map, " << grid.getResolution() << " m/pixel\n"
        << width << ' ' << height << "\n255\n";
    for (unsigned row = 0; row < height; ++row) {
      const int cy = static_cast<int>(height - 1 - row);
      for (unsigned cx = 0; cx < width; ++cx) {
        out.put(static_cast<char>(
            mapServerPixel(1.0F - grid.getCell(static_cast<int>(cx), cy), thresholds)));
      }
    }
  });
  const std::string image = std::filesystem::path(base + ".pgm").filename().string();
  core::writeFileAtomically(base + ".yaml", [&](std::ostream& out) {
    out << std::setprecision(9) << "image: " << image << "\nresolution: " << grid.getResolution()
        << "\norigin: [" << grid.getXMin() << ", " << grid.getYMin() << ", 0.0]\nnegate: 0\n"
        << "occupied_thresh: " << thresholds.occupied << "\nfree_thresh: " << thresholds.free
        << "\n";
  });
}

void writeMapPng(const mrpt::maps::COccupancyGridMap2D& grid, const std::string& path,
                 const std::vector<core::Pose2>& trajectory, const std::vector<LoopLine>& loops) {
  const unsigned width = grid.getSizeX();
  const unsigned height = grid.getSizeY();
  mrpt::img::CImage image(width, height, mrpt::img::CH_RGB);
  for (unsigned row = 0; row < height; ++row) {
    const int cy = static_cast<int>(height - 1 - row);
    for (unsigned cx = 0; cx < width; ++cx) {
      // MRPT's cells hold the probability of being free: white is free.
      const auto grey = static_cast<unsigned>(255.0F * grid.getCell(static_cast<int>(cx), cy));
      image.setPixel(static_cast<int>(cx), static_cast<int>(row),
                     (grey << 16) | (grey << 8) | grey);
    }
  }
  for (std::size_t k = 1; k < trajectory.size(); ++k) {
    const auto a = pixelOf(grid, trajectory[k - 1]);
    const auto b = pixelOf(grid, trajectory[k]);
    image.line(a.x(), a.y(), b.x(), b.y(), mrpt::img::TColor(40, 90, 255));
  }
  for (const LoopLine& loop : loops) {
    if (loop.accepted) continue;  // rejected first, so accepted loops stay visible on top
    const auto a = pixelOf(grid, loop.from);
    const auto b = pixelOf(grid, loop.to);
    image.line(a.x(), a.y(), b.x(), b.y(), mrpt::img::TColor(230, 30, 30));
  }
  for (const LoopLine& loop : loops) {
    if (!loop.accepted) continue;
    const auto a = pixelOf(grid, loop.from);
    const auto b = pixelOf(grid, loop.to);
    image.line(a.x(), a.y(), b.x(), b.y(), mrpt::img::TColor(0, 180, 0));
  }
  // CImage picks the encoder by extension: write NAME.tmp.png next to it, then rename.
  const std::string temp = path + ".tmp.png";
  if (!image.saveToFile(temp)) {
    std::remove(temp.c_str());
    throw std::runtime_error(path + ": cannot write the PNG image");
  }
  if (std::rename(temp.c_str(), path.c_str()) != 0) {
    std::remove(temp.c_str());
    throw std::runtime_error(path + ": cannot rename the written PNG into place");
  }
}

}  // namespace rrr_graphslam::frontend
