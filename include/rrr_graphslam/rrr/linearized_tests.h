#pragma once
// RRR's linearized tests: a set of loop links against the map the optimizer last factored,
// without optimizing again. The leave-one-out check, the far retry's gate, the online map check
// and conflict removal use them (doc/rrr_extensions.md).

#include <optional>
#include <vector>

#include "rrr_graphslam/core/se2.h"
#include "rrr_graphslam/rrr/verification_graph.h"

namespace rrr_graphslam::rrr {

/// Linearized tests of a set of links against the map the optimizer last factored (its marginal
/// covariance, core::Optimizer::covariance), at `poses`: the chi2 the links would add to the map
/// (predictedIndex), or the chi2 their removal would take off it (leaveOneOutIndex, the
/// studentized residual of regression: the links' residual weighed by its own covariance, their
/// covariance less the map's share, so a cluster that bends the map toward itself and fits it
/// well still stands out). Each over chi2(alpha, 3 * links); exact for a linear model.
/// predictedIndex: none when no factor is usable or there is no link. leaveOneOutIndex: 0 when
/// the residual covariance is not positive definite (the links alone fix what they measure).
std::optional<double> predictedIndex(const VerificationGraph& graph, const std::vector<int>& links,
                                     const std::vector<core::Pose2>& poses, double alpha);
double leaveOneOutIndex(const VerificationGraph& graph, const std::vector<int>& links,
                        const std::vector<core::Pose2>& poses, double alpha);
/// How much more the map leaves open of `links`' relative poses than the links themselves
/// measure: the largest generalized eigenvalue of the map's covariance of their residuals over
/// their own covariance. Above 1, in some direction a link's own error is smaller than where the
/// map would let its ends lie: the map cannot tell a false link there from a true one (the
/// optimization would move the nodes to fit it). None when no factor is usable or there is no
/// link.
std::optional<double> mapUncertaintyRatio(const VerificationGraph& graph,
                                          const std::vector<int>& links,
                                          const std::vector<core::Pose2>& poses);
/// leaveOneOutIndex of each set of links; 16 sets and more in parallel over the machine's cores
/// (each reads the same factor; the results do not depend on the threads).
std::vector<double> leaveOneOutIndices(const VerificationGraph& graph,
                                       const std::vector<const std::vector<int>*>& link_sets,
                                       const std::vector<core::Pose2>& poses, double alpha);

}  // namespace rrr_graphslam::rrr
