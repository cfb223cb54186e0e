#include "rrr_graphslam/core/text_file.h"

#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "rrr_graphslam/core/input_error.h"

namespace rrr_graphslam::core {

LineReader::LineReader(const std::string& path) : path_(path), file_(gzopen(path.c_str(), "rb")) {
  if (file_ == nullptr) {
    throw InputError(path, 0, std::string("cannot open: ") + std::strerror(errno));
  }
  gzbuffer(static_cast<gzFile>(file_), 1 << 17);
}

LineReader::~LineReader() { gzclose(static_cast<gzFile>(file_)); }

bool LineReader::fill() {
  if (at_end_) return false;
  auto* file = static_cast<gzFile>(file_);
  // Drop what was returned already, then append one chunk.
  buffer_.erase(0, start_);
  start_ = 0;
  const std::size_t old_size = buffer_.size();
  constexpr std::size_t kChunk = 1 << 16;
  buffer_.resize(old_size + kChunk);
  const int n = gzread(file, &buffer_[old_size], static_cast<unsigned>(kChunk));
  buffer_.resize(old_size + static_cast<std::size_t>(std::max(n, 0)));
  int error_code = Z_OK;
  const char* message = gzerror(file, &error_code);
  if (n < 0 || (error_code != Z_OK && error_code != Z_STREAM_END)) {
    throw InputError(path_, line_number_ + 1, std::string("read error: ") + message);
  }
  if (n == 0) at_end_ = true;
  return n > 0;
}

bool LineReader::next(std::string& line) {
  std::size_t searched = start_;
  std::size_t end = std::string::npos;
  while ((end = buffer_.find('\n', searched)) == std::string::npos) {
    const std::size_t pending = buffer_.size() - start_;
    if (!fill()) break;
    searched = pending;  // fill() moved the pending bytes to the front
  }
  if (end == std::string::npos && start_ >= buffer_.size()) return false;
  const std::size_t stop = end == std::string::npos ? buffer_.size() : end;
  line.assign(buffer_, start_, stop - start_);
  start_ = end == std::string::npos ? buffer_.size() : end + 1;
  ++line_number_;
  const std::size_t nul = line.find('\0');
  if (nul != std::string::npos) {
    throw InputError(path_, line_number_,
                     "NUL byte at column " + std::to_string(nul + 1) + ": not a text file");
  }
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r')) line.pop_back();
  return true;
}

}  // namespace rrr_graphslam::core
