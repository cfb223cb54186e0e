// map_server worlds: write then read, the PGM variants map_server reads, and errors that name the
// file, the line and the field.

#include <gtest/gtest.h>

#include "rrr_graphslam/core/input_error.h"
#include "rrr_graphslam/sim/world.h"
#include "test_worlds.h"

namespace rrr_graphslam::sim {
namespace {

using testing::writeTemp;

const char* const kYaml =
    "image: IMAGE\nresolution: 0.5\norigin: [1.25, -2.0, 0.0]\nnegate: NEGATE\n"
    "occupied_thresh: 0.65\nfree_thresh: 0.196\n";

std::string yamlFor(const std::string& image, int negate = 0) {
  std::string text = kYaml;
  text.replace(text.find("IMAGE"), 5, image);
  text.replace(text.find("NEGATE"), 6, std::to_string(negate));
  return text;
}

TEST(World, WriteThenReadGivesTheSameWorld) {
  World w = testing::twoRooms();
  w.origin_m = {-2.05, -1.025};  // not a multiple of the resolution
  w.set(50, 40, Cell::kUnknown);
  const std::string base = ::testing::TempDir() + "round_trip";
  writeWorld(w, base);
  const World r = readWorld(base + ".yaml");
  EXPECT_EQ(r.width, w.width);
  EXPECT_EQ(r.height, w.height);
  EXPECT_DOUBLE_EQ(r.resolution_m, w.resolution_m);
  EXPECT_DOUBLE_EQ(r.origin_m.x(), w.origin_m.x());
  EXPECT_DOUBLE_EQ(r.origin_m.y(), w.origin_m.y());
  EXPECT_TRUE(r.cells == w.cells);
  EXPECT_EQ(r.count(Cell::kUnknown), 1U);
}

TEST(World, ReadsPlainPgmWithCommentsAndNegate) {
  // 3 x 2, top row first: with negate 1 a value of 255 is occupied and 0 free.
  writeTemp("plain.pgm", "P2\n# a comment\n3 # width\n2\n# max\n255\n255 0 128\n0 0 0\n");
  const World w = readWorld(writeTemp("plain.yaml", yamlFor("plain.pgm", 1)));
  ASSERT_EQ(w.width, 3);
  ASSERT_EQ(w.height, 2);
  EXPECT_EQ(w.at(0, 1), Cell::kOccupied);  // the image's top row is the grid's top row
  EXPECT_EQ(w.at(1, 1), Cell::kFree);
  EXPECT_EQ(w.at(2, 1), Cell::kUnknown);
  EXPECT_EQ(w.at(0, 0), Cell::kFree);
  EXPECT_DOUBLE_EQ(w.resolution_m, 0.5);
  // A world point and its cell: origin (1.25, -2), 0.5 m cells.
  EXPECT_EQ(w.cellOf({1.3, -1.9}), Eigen::Vector2i(0, 0));
  EXPECT_EQ(w.cellOf({2.8, -1.4}), Eigen::Vector2i(3, 1));
  EXPECT_TRUE(w.centerOf(2, 1).isApprox(Eigen::Vector2d(2.5, -1.25)));
}

TEST(World, ReadsSixteenBitBinaryPgm) {
  std::string pgm = "P5\n2 1\n65535\n";
  pgm += std::string("\xff\xff\x00\x00", 4);  // white (free), black (occupied)
  writeTemp("wide.pgm", pgm);
  const World w = readWorld(writeTemp("wide.yaml", yamlFor("wide.pgm")));
  EXPECT_EQ(w.at(0, 0), Cell::kFree);
  EXPECT_EQ(w.at(1, 0), Cell::kOccupied);
}

struct BadInput {
  std::string yaml;
  std::string pgm;
  std::string file;  // the file the error must name (its name's end)
  std::size_t line;
  std::string message;
};

TEST(World, BadInputNamesFileLineAndField) {
  const std::string good_pgm = "P5\n2 2\n255\n" + std::string(4, '\xfe');
  const std::vector<BadInput> cases = {
      {yamlFor("w.pgm"), "P6\n2 2\n255\n", "w.pgm", 1, "not a PGM image"},
      {yamlFor("w.pgm"), "P5\n# comment\n2 two\n255\n", "w.pgm", 3, "the height 'two'"},
      {yamlFor("w.pgm"), "P5\n2 2\n255\nab", "w.pgm", 0, "holds 2 pixels, the 2 x 2 header"},
      {yamlFor("w.pgm"), "P5\n2 2\n", "w.pgm", 3, "the header ends early"},
      {yamlFor("missing.pgm"), good_pgm, "w.yaml", 1, "'image' names"},
      {"image: w.pgm\nresolution: -1\n", good_pgm, "w.yaml", 2, "'resolution' = -1 is out"},
      {"image: w.pgm\nresolution: 0.1\norigin: [0, 0]\n", good_pgm, "w.yaml", 3,
       "'origin' must be a list of 3 numbers"},
      {"image: w.pgm\nresolution: 0.1\norigin: [0, 0, 0.5]\n", good_pgm, "w.yaml", 3,
       "rotated map"},
      {"image: w.pgm\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n", good_pgm,
       "w.yaml", 1, "'free_thresh' is missing"},
      {yamlFor("w.pgm") + "resolutoin: 0.1\n", good_pgm, "w.yaml", 7,
       "'resolutoin' is not a known field"},
      {"- just\n- a list\n", good_pgm, "w.yaml", 0, "is not a map_server world"},
  };
  for (const BadInput& c : cases) {
    SCOPED_TRACE(c.message);
    writeTemp("w.pgm", c.pgm);
    const std::string path = writeTemp("w.yaml", c.yaml);
    try {
      readWorld(path);
      ADD_FAILURE() << "no error";
    } catch (const core::InputError& e) {
      EXPECT_NE(e.source().find(c.file), std::string::npos) << e.what();
      EXPECT_EQ(e.line(), c.line) << e.what();
      EXPECT_NE(e.reason().find(c.message), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace rrr_graphslam::sim
