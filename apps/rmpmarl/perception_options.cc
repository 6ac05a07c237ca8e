// --perception truth|depth: obstacles known exactly, or only through a simulated depth camera (docs/perception.md).
#include <fmt/format.h>

#include "commands.h"
#include "rmpmarl/common/error.h"

namespace rmpmarl::apps {

void AddPerceptionOptions(CLI::App* cmd, PerceptionArgs* args) {
  cmd->add_option("--perception", args->mode,
                  "what the controller knows of the obstacles: truth (their exact shapes) or depth (only what one "
                  "simulated depth camera sees, as point-set obstacles)")
      ->check(CLI::IsMember({"truth", "depth"}));
  cmd->add_option("--camera-rate", args->rate, "--perception depth: camera frames per second")
      ->check(CLI::Range(1.0, 1000.0));
  cmd->add_option("--camera-noise", args->noise,
                  "--perception depth: axial depth noise at 1 m [m] (σ grows with the square of the depth)")
      ->check(CLI::Range(0.0, 0.1));
  cmd->add_option("--camera-dropout", args->dropout, "--perception depth: fraction of pixels with no depth")
      ->check(CLI::Range(0.0, 0.9));
  cmd->add_option("--camera-width", args->width, "--perception depth: image width [px]")->check(CLI::Range(16, 4096));
  cmd->add_option("--camera-height", args->height, "--perception depth: image height [px]")
      ->check(CLI::Range(16, 4096));
  cmd->add_option("--voxel", args->voxel, "--perception depth: voxel size of the downsampled cloud [m]")
      ->check(CLI::Range(0.001, 0.5));
  cmd->add_option("--camera-memory", args->memory,
                  "--perception depth: on: points of obstacles at rest are remembered while the arm hides them from "
                  "the camera, until it sees through their place; off: each frame's cloud alone")
      ->check(CLI::IsMember({"on", "off"}));
  cmd->add_option("--point-margin", args->point_margin,
                  "--perception depth, --cloud: margin added to each sensed point's radius (half a voxel) [m]")
      ->check(CLI::Range(0.0, 0.2));
}

bool UsesDepth(const PerceptionArgs& args) { return args.mode == "depth"; }

bool UsesSensor(const PerceptionArgs& args) { return UsesDepth(args) || !args.cloud.empty(); }

perception::DepthPerceptionOptions DepthOptions(const PerceptionArgs& args, std::uint64_t seed) {
  perception::DepthPerceptionOptions o;
  perception::DepthCameraOptions& c = o.cameras.front();
  c.width = args.width;
  c.height = args.height;
  c.rate = args.rate;
  c.noise.sigma_at_1m = args.noise;
  c.noise.dropout = args.dropout;
  c.noise.seed = seed;
  o.cloud.voxel_size = args.voxel;
  o.cloud.point_margin = args.point_margin;
  o.memory.enabled = args.memory == "on";
  perception::ValidateDepthPerceptionOptions(o);
  return o;
}

std::function<std::unique_ptr<sim::ObstacleSensor>(const sim::WorldModel&)> MakeSensorFactory(
    const PerceptionArgs& args, std::uint64_t seed) {
  if (!args.cloud.empty()) {
    if (UsesDepth(args)) throw InputError("--cloud and --perception depth: give one source of obstacles");
    perception::RecordedCloudOptions options;
    options.rate = args.rate;
    options.cloud.voxel_size = args.voxel;
    options.cloud.point_margin = args.point_margin;
    perception::RecordedCloudFiles(args.cloud);  // a bad path is refused before anything runs
    return [options, path = args.cloud](const sim::WorldModel& model) -> std::unique_ptr<sim::ObstacleSensor> {
      return std::make_unique<perception::RecordedCloud>(model.robot(), path, options);
    };
  }
  if (!UsesDepth(args)) return {};
  return perception::DepthSensorMaker(DepthOptions(args, seed));
}

std::string DescribePerception(const PerceptionArgs& args) {
  if (!args.cloud.empty()) {
    return fmt::format("perception: the recorded cloud {} (robot base frame, metres), updated at {:g} Hz, voxels {:g} "
                       "m, point margin {:g} m; the scene's own obstacles are simulated but not told to the controllers",
                       args.cloud, args.rate, args.voxel, args.point_margin);
  }
  if (!UsesDepth(args)) return "perception: truth (the obstacles' exact shapes)";
  return fmt::format("perception: depth (one {}x{} camera at {:g} Hz, noise {:g} m at 1 m, dropout {:g}, voxels {:g} m, "
                     "point margin {:g} m, memory of hidden obstacles {})", args.width, args.height, args.rate,
                     args.noise, args.dropout, args.voxel, args.point_margin, args.memory);
}

}  // namespace rmpmarl::apps
