#pragma once
// Atomic file writes: a reader never sees a half-written graph, decision table or map, and a
// process killed mid-save leaves the previous files. Each file is written to a temporary next to
// it (same directory, so the rename stays on one file system), flushed, synced and renamed over
// its path. AtomicFileSet does that for files that belong together (a graph, its decisions, its
// optimized copy): every temporary is written before any is renamed.

#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace rrr_graphslam::core {

class AtomicFileSet {
 public:
  AtomicFileSet() = default;
  AtomicFileSet(const AtomicFileSet&) = delete;
  AtomicFileSet& operator=(const AtomicFileSet&) = delete;
  /// Removes the temporaries of a set that was not committed.
  ~AtomicFileSet();

  /// Renders `path`'s content now (in memory). Throws std::invalid_argument for a path added
  /// twice.
  void add(const std::string& path, const std::function<void(std::ostream&)>& write);

  /// Writes every file to its temporary; if any fails, removes them all and throws
  /// std::runtime_error naming the path (every previous file is left untouched). Then renames
  /// them over their paths in the order added and returns those paths. A rename that fails
  /// after others succeeded throws naming the files already replaced.
  std::vector<std::string> commit();

 private:
  struct File {
    std::string path;
    std::string content;
    std::string temporary;  // set once written
  };
  void removeTemporaries();

  std::vector<File> files_;
};

/// One file written atomically (an AtomicFileSet of one). Throws std::runtime_error naming the
/// path on failure; the previous file is then left untouched.
void writeFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& write);

}  // namespace rrr_graphslam::core
