#include "rrr_graphslam/core/param_info.h"

#include <iomanip>

namespace rrr_graphslam::core {

std::string outOfRangeMessage(const ParamInfo& info, const std::string& value) {
  std::ostringstream what;
  what << std::setprecision(12) << info.name << " = " << value << " is out of range: must be in ["
       << info.low << ", " << info.high << "]";
  return what.str();
}

std::string notAChoiceMessage(const ParamInfo& info, const std::string& value,
                              const std::vector<std::string>& names) {
  std::string what = std::string(info.name) + " must be ";
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (k > 0) what += k + 1 == names.size() ? " or " : ", ";
    what += names[k];
  }
  return what + ", not '" + value + "'";
}

}  // namespace rrr_graphslam::core
