#include "rrr_graphslam/rrr/rrr_params.h"

#include <stdexcept>

namespace rrr_graphslam::rrr {

const std::vector<std::string>& presetNames() {
  static const std::vector<std::string> names{"default", "paper"};
  return names;
}

void applyPreset(const std::string& name, RrrParams& params) {
  RrrParams p;
  if (name == "paper") {
    p.reduced_intra_graph = false;
    p.intra_worst_link_removal = false;
    p.split_mixed_clusters = false;
    p.robust_ordering = false;
    p.warm_start = false;
    p.reverse_good_clusters = false;
    p.batch_removal_fraction = 1.0;
    p.conflict_removal = false;
    p.settle_good_map = false;
    p.recover_gate = std::numeric_limits<double>::infinity();
    p.far_retry_min_links = 0;
    p.leave_one_out_check = false;
    p.loo_joint_min_index = 0.0;
    p.joint_link_check = false;
    p.place_sessions = false;
    p.placement_wider_reading = false;
    p.online_map_check = false;
    p.online_untestable_ratio = 0.0;
    p.online_group_wait_nodes = 0;
    p.online_increase_test = false;
    p.online_scratch_check = false;
    p.incremental_rebatch_every = 0;
    p.incremental_factor_updates = false;
  } else if (name != "default") {
    throw std::invalid_argument("preset must be default or paper, not '" + name + "'");
  }
  p.alpha = params.alpha;
  p.cluster_gap = params.cluster_gap;
  p.max_rounds = params.max_rounds;
  p.optimizer = params.optimizer;
  params = p;
}

void validate(const RrrParams& params) {
  forEachParam(params,
               [](const ParamInfo& info, const auto& value) { core::checkRange(info, value); });
}

}  // namespace rrr_graphslam::rrr
