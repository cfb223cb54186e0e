#pragma once
// Which kernels the BLAS library runs. CHOLMOD's supernodal factorizations spend most of their
// time in BLAS (dgemm, dtrsm). OpenBLAS chooses its kernels for the processor when it is loaded;
// a processor newer than the library gets its generic "Prescott" (SSE3) kernels. Debian 12's
// OpenBLAS 0.3.21 does so on Intel Xeon Emerald Rapids (family 6, model 207): batch RRR on
// City10000 + 2000 false loops in groups of 20 took 59 s instead of 38 s with
// OPENBLAS_CORETYPE=Haswell, with the same decisions. The tools and the node warn when that
// happens, naming the setting that fixes it.

#include <optional>
#include <string>

namespace rrr_graphslam::core {

/// OpenBLAS's kernel name ("Haswell", "Prescott", ...), or "" when the BLAS library loaded in
/// this process is not OpenBLAS.
std::string openBlasCoreName();

/// The warning for `core_name` on this processor: set when OpenBLAS runs its generic kernel on a
/// processor with AVX2 and FMA (what its Haswell kernels need) and OPENBLAS_CORETYPE is not set.
std::optional<std::string> blasKernelWarning(const std::string& core_name);

/// The same for the BLAS library of this process.
inline std::optional<std::string> blasKernelWarning() {
  return blasKernelWarning(openBlasCoreName());
}

}  // namespace rrr_graphslam::core
