#pragma once
// Line-by-line reading of text files that may be gzip-compressed (zlib reads plain files
// transparently). Writing them: atomic_file.h.

#include <cstddef>
#include <ostream>
#include <string>

namespace rrr_graphslam::core {

class LineReader {
 public:
  /// Throws InputError (line 0) if the file cannot be opened.
  explicit LineReader(const std::string& path);
  ~LineReader();
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;

  /// Reads the next line without its end-of-line characters; false at end of file.
  /// Throws InputError on a read error (e.g. a truncated .gz) and for a line holding a NUL byte
  /// (no text file has one; C string handling would drop the rest of the line).
  bool next(std::string& line);
  /// 1-based number of the line last returned.
  std::size_t lineNumber() const { return line_number_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  /// Reads more of the file into buffer_; false at end of file.
  bool fill();

  void* file_;  // gzFile; kept opaque so zlib.h stays out of the header
  std::size_t line_number_ = 0;
  std::string buffer_;  // read, not yet returned from `start_` on
  std::size_t start_ = 0;
  bool at_end_ = false;
};

}  // namespace rrr_graphslam::core
