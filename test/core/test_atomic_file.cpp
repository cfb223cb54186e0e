// Files written together: every temporary before any rename; a failure leaves the old files.

#include <gtest/gtest.h>

#include <dirent.h>

#include <fstream>
#include <sstream>
#include <string>

#include "rrr_graphslam/core/atomic_file.h"

namespace rrr_graphslam::core {
namespace {

std::string readAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

int filesIn(const std::string& dir) {
  int n = 0;
  if (DIR* d = opendir(dir.c_str())) {
    while (const dirent* e = readdir(d)) n += e->d_name[0] != '.';
    closedir(d);
  }
  return n;
}

std::string freshDir(const std::string& name) {
  const std::string dir = ::testing::TempDir() + name;
  std::system(("rm -rf '" + dir + "' && mkdir -p '" + dir + "'").c_str());
  return dir;
}

TEST(AtomicFileSet, WritesEveryFileAndSaysWhich) {
  const std::string dir = freshDir("atomic_ok");
  AtomicFileSet files;
  files.add(dir + "/a.g2o", [](std::ostream& out) { out << "graph\n"; });
  files.add(dir + "/a.decisions.tsv", [](std::ostream& out) { out << "decisions\n"; });
  EXPECT_THROW(files.add(dir + "/a.g2o", [](std::ostream&) {}), std::invalid_argument);
  const auto written = files.commit();
  EXPECT_EQ(written, (std::vector<std::string>{dir + "/a.g2o", dir + "/a.decisions.tsv"}));
  EXPECT_EQ(readAll(dir + "/a.g2o"), "graph\n");
  EXPECT_EQ(readAll(dir + "/a.decisions.tsv"), "decisions\n");
  EXPECT_EQ(filesIn(dir), 2);
}

TEST(AtomicFileSet, AFileThatCannotBeWrittenLeavesEveryPreviousFileWhole) {
  const std::string dir = freshDir("atomic_fail");
  writeFileAtomically(dir + "/a.g2o", [](std::ostream& out) { out << "old graph\n"; });
  AtomicFileSet files;
  files.add(dir + "/a.g2o", [](std::ostream& out) { out << "new graph\n"; });
  files.add(dir + "/missing/a.decisions.tsv", [](std::ostream& out) { out << "decisions\n"; });
  try {
    files.commit();
    FAIL() << "a file in a missing folder was written";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(dir + "/missing/a.decisions.tsv"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(readAll(dir + "/a.g2o"), "old graph\n");  // the graph was not replaced alone
  EXPECT_EQ(filesIn(dir), 1);                         // and no temporary is left
}

TEST(AtomicFileSet, AnUncommittedSetLeavesNothing) {
  const std::string dir = freshDir("atomic_dropped");
  {
    AtomicFileSet files;
    files.add(dir + "/a.g2o", [](std::ostream& out) { out << "graph\n"; });
  }
  EXPECT_EQ(filesIn(dir), 0);
}

}  // namespace
}  // namespace rrr_graphslam::core
