// The warning about OpenBLAS's generic kernel: given for Prescott on a processor with AVX2 unless
// the user chose a kernel, never for a recognised one or another BLAS.

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "rrr_graphslam/core/blas_kernel.h"

namespace rrr_graphslam::core {
namespace {

bool processorHasAvx2() {
#if defined(__x86_64__) || defined(__i386__)
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
#else
  return false;
#endif
}

TEST(BlasKernel, OnlyTheGenericKernelOnAModernProcessorIsWarnedAbout) {
  const char* before = std::getenv("OPENBLAS_CORETYPE");
  const std::string saved = before != nullptr ? before : "";
  unsetenv("OPENBLAS_CORETYPE");
  EXPECT_FALSE(blasKernelWarning("Haswell"));
  EXPECT_FALSE(blasKernelWarning("SkylakeX"));
  EXPECT_FALSE(blasKernelWarning(""));  // not OpenBLAS
  const auto warning = blasKernelWarning("Prescott");
  EXPECT_EQ(warning.has_value(), processorHasAvx2());
  if (warning) {
    EXPECT_NE(warning->find("OPENBLAS_CORETYPE=Haswell"), std::string::npos);
  }
  // A kernel the user chose is left alone.
  setenv("OPENBLAS_CORETYPE", "Prescott", 1);
  EXPECT_FALSE(blasKernelWarning("Prescott"));
  if (before != nullptr) {
    setenv("OPENBLAS_CORETYPE", saved.c_str(), 1);
  } else {
    unsetenv("OPENBLAS_CORETYPE");
  }
}

TEST(BlasKernel, TheLoadedLibraryNamesItsKernel) {
  // CHOLMOD's BLAS is loaded with this test (the core library links it). Debian's alternatives
  // may choose another BLAS than OpenBLAS: then the name is empty.
  const std::string name = openBlasCoreName();
  EXPECT_EQ(name.find(' '), std::string::npos) << name;
  if (const char* forced = std::getenv("OPENBLAS_CORETYPE"); forced != nullptr && !name.empty()) {
    EXPECT_EQ(name, std::string(forced));
  }
}

}  // namespace
}  // namespace rrr_graphslam::core
