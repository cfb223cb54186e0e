#include "rrr_graphslam/core/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <random>
#include <sstream>
#include <stdexcept>

namespace rrr_graphslam::core {
namespace {

// Writes `data` to a new temporary file next to `path` (flushed, synced, readable as any file the
// user writes) and returns its name. Throws std::runtime_error naming `path`; nothing is left.
std::string writeTemporary(const std::string& path, const std::string& data) {
  // Created 0666 so that the kernel applies the process's umask (as to any file the user
  // writes), under a random name next to `path`; O_EXCL never reuses one that exists.
  static thread_local std::mt19937_64 names{std::random_device{}()};
  int fd = -1;
  std::string temp_path;
  for (int attempt = 0; attempt < 100 && fd < 0; ++attempt) {
    char suffix[32];
    std::snprintf(suffix, sizeof suffix, ".tmp.%012llx",
                  static_cast<unsigned long long>(names() & 0xffffffffffffULL));
    temp_path = path + suffix;
    fd = ::open(temp_path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0 && errno != EEXIST) break;
  }
  if (fd < 0) {
    throw std::runtime_error(path + ": cannot create temporary file: " + std::strerror(errno));
  }
  auto fail = [&](const std::string& what) {
    const std::string reason = std::strerror(errno);
    ::close(fd);
    std::remove(temp_path.c_str());
    throw std::runtime_error(path + ": " + what + ": " + reason);
  };
  std::size_t written = 0;
  while (written < data.size()) {
    const ssize_t n = ::write(fd, data.data() + written, data.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("write failed");
    }
    written += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) fail("fsync failed");
  if (::close(fd) != 0) {
    std::remove(temp_path.c_str());
    throw std::runtime_error(path + ": close failed: " + std::strerror(errno));
  }
  return temp_path;
}

}  // namespace

AtomicFileSet::~AtomicFileSet() { removeTemporaries(); }

void AtomicFileSet::add(const std::string& path, const std::function<void(std::ostream&)>& write) {
  for (const File& f : files_) {
    if (f.path == path) throw std::invalid_argument(path + ": written twice in one save");
  }
  std::ostringstream content;
  write(content);
  files_.push_back({path, content.str(), std::string()});
}

void AtomicFileSet::removeTemporaries() {
  for (File& f : files_) {
    if (!f.temporary.empty()) std::remove(f.temporary.c_str());
    f.temporary.clear();
  }
}

std::vector<std::string> AtomicFileSet::commit() {
  try {
    for (File& f : files_) f.temporary = writeTemporary(f.path, f.content);
  } catch (...) {
    removeTemporaries();
    throw;
  }
  std::vector<std::string> replaced;
  for (File& f : files_) {
    if (std::rename(f.temporary.c_str(), f.path.c_str()) != 0) {
      std::string what = f.path + ": rename failed: " + std::strerror(errno);
      removeTemporaries();
      if (!replaced.empty()) {
        what += " (already replaced:";
        for (const std::string& p : replaced) what += " " + p;
        what += ")";
      }
      throw std::runtime_error(what);
    }
    f.temporary.clear();
    replaced.push_back(f.path);
  }
  files_.clear();
  return replaced;
}

void writeFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& write) {
  AtomicFileSet file;
  file.add(path, write);
  file.commit();
}

}  // namespace rrr_graphslam::core
