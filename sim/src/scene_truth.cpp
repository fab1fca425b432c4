#include "psrig/sim/scene_truth.h"

#include "psrig/sim/fabric_truth.h"
#include "psrig/sim/world.h"

namespace psrig::sim {
namespace {

class SceneTruthCamera final : public cameras::Camera {
 public:
  SceneTruthCamera(std::unique_ptr<cameras::Camera> inner, std::shared_ptr<const World> world,
                   double rotation_deg)
      : inner_(std::move(inner)), world_(std::move(world)), rotation_deg_(rotation_deg) {}
  Status configure(const config::CameraConfig& settings) override {
    return inner_->configure(settings);
  }
  Status start() override { return inner_->start(); }
  Result<cameras::Frame> grab(std::chrono::milliseconds timeout) override {
    return inner_->grab(timeout);
  }
  Status stop() override { return inner_->stop(); }
  std::string describe() const override { return inner_->describe(); }
  void describe_scene(formats::Scan& scan) const override {
    inner_->describe_scene(scan);
    add_scene_truth(*world_, rotation_deg_, scan);
  }

 private:
  std::unique_ptr<cameras::Camera> inner_;
  std::shared_ptr<const World> world_;
  double rotation_deg_;
};

}  // namespace

void add_scene_truth(const World& world, double rotation_deg, formats::Scan& scan) {
  scan.ground_truth_normal = world.swatch().normal;
  scan.ground_truth_height = world.swatch().height_mm;
  if (const auto& pattern = world.pattern())
    scan.description.document["ground_truth"]["fabric"] =
        fabric_ground_truth(*pattern, rotation_deg);
}

std::unique_ptr<cameras::Camera> with_scene_truth(std::unique_ptr<cameras::Camera> camera,
                                                  std::shared_ptr<const World> world,
                                                  double rotation_deg) {
  return std::make_unique<SceneTruthCamera>(std::move(camera), std::move(world), rotation_deg);
}

}  // namespace psrig::sim
