#include "rrr_graphslam/core/chi2.h"

#include <boost/math/distributions/chi_squared.hpp>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>

namespace rrr_graphslam::core {

double chi2Quantile(double alpha, int dof) {
  if (!(alpha > 0.0 && alpha < 1.0) || dof < 1) {
    throw std::invalid_argument("chi2Quantile: need 0 < alpha < 1 and dof >= 1, got alpha=" +
                                std::to_string(alpha) + " dof=" + std::to_string(dof));
  }
  static std::mutex mutex;
  static std::map<std::pair<double, int>, double> cache;
  const std::lock_guard<std::mutex> lock(mutex);
  const auto key = std::make_pair(alpha, dof);
  const auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  const double q = boost::math::quantile(boost::math::chi_squared(dof), alpha);
  cache.emplace(key, q);
  return q;
}

}  // namespace rrr_graphslam::core
