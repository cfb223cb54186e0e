#include "rrr_graphslam/core/blas_kernel.h"

#include <dlfcn.h>

#include <cstdlib>

namespace rrr_graphslam::core {

std::string openBlasCoreName() {
  // Looked up at run time: the product links the generic libblas.so.3, which Debian's
  // alternatives may point at OpenBLAS, BLIS or the reference BLAS. RTLD_NOLOAD only finds a
  // library this process has loaded already (also from a nodelet manager's local scope).
  using CoreName = const char* (*)();
  for (const char* library : {"libopenblas.so.0", "libblas.so.3"}) {
    void* handle = dlopen(library, RTLD_LAZY | RTLD_NOLOAD);
    if (handle == nullptr) continue;
    auto* core_name = reinterpret_cast<CoreName>(dlsym(handle, "openblas_get_corename"));
    std::string name = core_name != nullptr ? core_name() : "";
    dlclose(handle);
    if (!name.empty()) return name;
  }
  return "";
}

std::optional<std::string> blasKernelWarning(const std::string& core_name) {
  if (core_name != "Prescott" && core_name != "prescott") return std::nullopt;
  if (std::getenv("OPENBLAS_CORETYPE") != nullptr) return std::nullopt;  // the user's choice
#if defined(__x86_64__) || defined(__i386__)
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma")) return std::nullopt;
  // Haswell, not SkylakeX, on an AVX-512 processor too: 38 s against 43 s on the run above.
  return std::string(
      "OpenBLAS does not recognise this processor and runs its generic kernel (Prescott), "
      "which makes large factorizations up to 1.5x slower; the processor has AVX2: set "
      "OPENBLAS_CORETYPE=Haswell in the environment");
#else
  return std::nullopt;
#endif
}

}  // namespace rrr_graphslam::core
