#pragma once
// Eq. (7)'s four components of the aggregated woven BSDF, per unit k_d and
// k_s of each yarn type: f = kd_warp c_warp + kd_weft c_weft + ks_warp
// s_warp + ks_weft s_weft. What the Monte Carlo estimator (woven_aggregate.h)
// and the network (woven_network.h) both answer, and WovenQuery's targets.

namespace psrig::cloth {

struct WovenComponents {
  float c_warp = 0, c_weft = 0, s_warp = 0, s_weft = 0;
};

}  // namespace psrig::cloth
