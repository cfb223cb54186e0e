#pragma once
// Shared by the libFuzzer targets of the file readers (scripts/fuzz builds and runs them).
//
// The readers take a path, so each input is written to an anonymous in-memory file (memfd) and
// read back through /proc/self/fd/N: nothing is left on disk when a run crashes, and parallel
// runs cannot share a file. zlib opens the path itself, so a gzip input exercises the .gz path.
//
// The expected answer to a bad input is the exception the reader's header promises (InputError,
// naming file and line). What the targets report besides crashes and sanitizer errors is a broken
// promise of the header, via RRR_FUZZ_CHECK or unexpectedException: the message names the
// promise, then abort() lets libFuzzer save the input.

#include <cxxabi.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <typeinfo>

#define RRR_FUZZ_CHECK(condition, what)                                                     \
  do {                                                                                      \
    if (!(condition)) {                                                                     \
      std::fprintf(stderr, "\n[fuzz] broken promise: %s (%s, %s:%d)\n", (what), #condition, \
                   __FILE__, __LINE__);                                                     \
      std::abort();                                                                         \
    }                                                                                       \
  } while (false)

namespace rrr_graphslam::fuzz {

/// Replaces the content of this process's input file with `data`; returns the file's path.
inline const std::string& writeInput(const std::uint8_t* data, std::size_t size) {
  static const int fd = memfd_create("rrr_fuzz_input", 0);
  static const std::string path = "/proc/self/fd/" + std::to_string(fd);
  if (fd < 0 || ftruncate(fd, 0) != 0) {
    std::perror("[fuzz] memfd");
    std::abort();
  }
  std::size_t written = 0;
  while (written < size) {
    const ssize_t n = pwrite(fd, data + written, size - written, static_cast<off_t>(written));
    if (n <= 0) {
      std::perror("[fuzz] pwrite");
      std::abort();
    }
    written += static_cast<std::size_t>(n);
  }
  return path;
}

/// A reader threw what its header does not promise (std::length_error from a wrapped count, ...).
[[noreturn]] inline void unexpectedException(const std::exception& e) {
  int status = 0;
  char* type = abi::__cxa_demangle(typeid(e).name(), nullptr, nullptr, &status);
  std::fprintf(stderr, "\n[fuzz] broken promise: bad input throws InputError, not %s: %s\n",
               type != nullptr ? type : typeid(e).name(), e.what());
  std::abort();
}

}  // namespace rrr_graphslam::fuzz
