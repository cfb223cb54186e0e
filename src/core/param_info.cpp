#include "rrr_graphslam/core/param_info.h"

#include <iomanip>

namespace rrr_graphslam::core {

std::string outOfRangeMessage(const ParamInfo& info, const std::string& value) {
  std::ostringstream what;
  what << std::setprecision(12) << info.name << " = " << value << " is out of range: must be in ["
       << info.low << ", " << info.high << "]";
  return what.str();
}

std::string choiceList(const std::vector<std::string>& names) {
  std::string list;
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (k > 0) list += k + 1 == names.size() ? " or " : ", ";
    list += names[k];
  }
  return list;
}

std::string notAChoiceMessage(const ParamInfo& info, const std::string& value,
                              const std::vector<std::string>& names) {
  return std::string(info.name) + " must be " + choiceList(names) + ", not '" + value + "'";
}

}  // namespace rrr_graphslam::core
