#include "rrr_graphslam/sim/world.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <sstream>

#include <mrpt/containers/yaml.h>

#include "rrr_graphslam/core/atomic_file.h"
#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/sim/yaml_fields.h"

namespace rrr_graphslam::sim {
namespace {

using core::InputError;

// A PGM (P5 binary or P2 plain) as grey values 0..255, rows top to bottom.
struct PgmImage {
  int width = 0;
  int height = 0;
  std::vector<unsigned char> pixels;
};

// Reads the header's whitespace-separated tokens, skipping '#' comments, counting lines.
class PgmHeader {
 public:
  PgmHeader(const std::string& path, const std::string& bytes) : path_(path), bytes_(bytes) {}

  std::string token() {
    for (;;) {
      while (pos_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[pos_]))) {
        if (bytes_[pos_] == '\n') ++line_;
        ++pos_;
      }
      if (pos_ < bytes_.size() && bytes_[pos_] == '#') {
        while (pos_ < bytes_.size() && bytes_[pos_] != '\n') ++pos_;
        continue;
      }
      break;
    }
    const std::size_t start = pos_;
    while (pos_ < bytes_.size() && !std::isspace(static_cast<unsigned char>(bytes_[pos_]))) ++pos_;
    if (start == pos_) fail("the header ends early");
    return bytes_.substr(start, pos_ - start);
  }

  int integer(const char* what, int low, int high) {
    const std::string text = token();
    char* end = nullptr;
    const long v = std::strtol(text.c_str(), &end, 10);
    if (end == text.c_str() || *end != '\0' || v < low || v > high) {
      fail(std::string(what) + " '" + text + "' is not an integer in [" + std::to_string(low) +
           ", " + std::to_string(high) + "]");
    }
    return static_cast<int>(v);
  }

  [[noreturn]] void fail(const std::string& what) const { throw InputError(path_, line_, what); }
  std::size_t position() const { return pos_; }
  std::size_t line() const { return line_; }

 private:
  const std::string& path_;
  const std::string& bytes_;
  std::size_t pos_ = 0;
  std::size_t line_ = 1;
};

PgmImage readPgm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open the image");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  PgmHeader header(path, bytes);
  const std::string magic = header.token();
  if (magic != "P5" && magic != "P2") {
    header.fail("not a PGM image: starts with '" + magic.substr(0, 8) + "', not P5 or P2");
  }
  PgmImage image;
  image.width = header.integer("the width", 1, 1 << 15);
  image.height = header.integer("the height", 1, 1 << 15);
  const int max_value = header.integer("the maximum grey value", 1, 65535);
  const std::size_t count =
      static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
  image.pixels.resize(count);
  const auto scale = [&](int v) {
    return static_cast<unsigned char>(std::lround(255.0 * std::min(v, max_value) / max_value));
  };
  if (magic == "P2") {
    for (std::size_t i = 0; i < count; ++i) {
      image.pixels[i] = scale(header.integer("a grey value", 0, max_value));
    }
    return image;
  }
  // P5: exactly one whitespace byte after the maximum, then the pixels (2 bytes, big-endian,
  // above 255).
  const std::size_t start = header.position() + 1;
  const std::size_t bytes_per_pixel = max_value > 255 ? 2 : 1;
  const std::size_t available = bytes.size() > start ? bytes.size() - start : 0;
  if (available < count * bytes_per_pixel) {
    throw InputError(path, 0,
                     "holds " + std::to_string(available / bytes_per_pixel) + " pixels, the " +
                         std::to_string(image.width) + " x " + std::to_string(image.height) +
                         " header needs " + std::to_string(count));
  }
  for (std::size_t i = 0; i < count; ++i) {
    const auto* p =
        reinterpret_cast<const unsigned char*>(bytes.data() + start + i * bytes_per_pixel);
    image.pixels[i] = scale(bytes_per_pixel == 2 ? (p[0] << 8) | p[1] : p[0]);
  }
  return image;
}

}  // namespace

World::World(int width_cells, int height_cells, double resolution, const Eigen::Vector2d& origin,
             Cell fill)
    : resolution_m(resolution),
      origin_m(origin),
      width(width_cells),
      height(height_cells),
      cells(static_cast<std::size_t>(width_cells) * static_cast<std::size_t>(height_cells), fill) {}

Eigen::Vector2i World::cellOf(const Eigen::Vector2d& p_m) const {
  const Eigen::Vector2d c = (p_m - origin_m) / resolution_m;
  return {static_cast<int>(std::floor(c.x())), static_cast<int>(std::floor(c.y()))};
}

Eigen::Vector2d World::centerOf(int cx, int cy) const {
  return origin_m + resolution_m * Eigen::Vector2d(cx + 0.5, cy + 0.5);
}

std::size_t World::count(Cell c) const {
  std::size_t n = 0;
  for (const Cell x : cells) n += x == c;
  return n;
}

World readWorld(const std::string& yaml_path) {
  const YamlDocument doc(yaml_path);
  const YamlEntry map = doc.root("a map_server world");
  const std::string image = map.string("image");
  const double resolution = map.number("resolution", 1e-4, 1e3);
  const std::vector<double> origin = map.numbers("origin", 3);
  if (origin[2] != 0.0) map.fail("origin", "a rotated map (origin yaw != 0) is not supported");
  const double occupied_thresh = map.number("occupied_thresh", 0.0, 1.0);
  const double free_thresh = map.number("free_thresh", 0.0, 1.0);
  if (free_thresh >= occupied_thresh) {
    map.fail("free_thresh",
             "must be below occupied_thresh (" + std::to_string(occupied_thresh) + ")");
  }
  const long negate = map.integer("negate", 0, 1);
  if (map.has("mode") && map.string("mode") != "trinary") {
    map.fail("mode", "must be trinary (the only mode the simulator reads)");
  }
  map.expectOnly(
      {"image", "resolution", "origin", "occupied_thresh", "free_thresh", "negate", "mode"});

  std::filesystem::path image_path(image);
  if (image_path.is_relative()) image_path = std::filesystem::path(yaml_path).parent_path() / image;
  if (!std::ifstream(image_path)) {
    map.fail("image", "names " + image_path.string() + ", which cannot be opened");
  }
  const PgmImage pgm = readPgm(image_path.string());
  World world(pgm.width, pgm.height, resolution, {origin[0], origin[1]});
  for (int row = 0; row < pgm.height; ++row) {
    for (int cx = 0; cx < pgm.width; ++cx) {
      const int value = pgm.pixels[static_cast<std::size_t>(row) * pgm.width + cx];
      const double p = negate ? value / 255.0 : (255 - value) / 255.0;
      const Cell c = p > occupied_thresh ? Cell::kOccupied
                     : p < free_thresh   ? Cell::kFree
                                         : Cell::kUnknown;
      world.set(cx, pgm.height - 1 - row, c);
    }
  }
  return world;
}

void writeWorld(const World& world, const std::string& base) {
  core::AtomicFileSet files;
  files.add(base + ".pgm", [&](std::ostream& out) {
    out << "P5\n# rrr_simulate world, " << world.resolution_m << " m/pixel\n"
        << world.width << ' ' << world.height << "\n255\n";
    for (int row = 0; row < world.height; ++row) {
      for (int cx = 0; cx < world.width; ++cx) {
        const Cell c = world.at(cx, world.height - 1 - row);
        out.put(static_cast<char>(c == Cell::kFree ? 254 : c == Cell::kOccupied ? 0 : 205));
      }
    }
  });
  const std::string image = std::filesystem::path(base + ".pgm").filename().string();
  files.add(base + ".yaml", [&](std::ostream& out) {
    out << std::setprecision(12) << "image: " << image << "\nresolution: " << world.resolution_m
        << "\norigin: [" << world.origin_m.x() << ", " << world.origin_m.y()
        << ", 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
  });
  files.commit();
}

}  // namespace rrr_graphslam::sim
