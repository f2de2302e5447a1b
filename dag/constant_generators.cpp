#include "dag/constant_generators.h"

#include "dag/remap_table.h"

namespace lpstereo {

std::vector<BuiltinConstantGenerator> builtin_constant_generators() {
  std::vector<BuiltinConstantGenerator> generators;
  // identity_rectification: an all-zero remap_q5 map (the views are already rectified).
  generators.push_back({"identity_rectification", {ElementType::remap_q5, 0},
                        [](const nlohmann::json& params, int width, int height) {
                          check_param_names(params, {});
                          return Plane(width, height, {ElementType::remap_q5, 0});
                        }});
  // synthetic_rectification: a realistic rectification map (rotation, zoom, radial distortion)
  // for running the pipeline without a calibration file (dag/remap_table.h).
  generators.push_back({"synthetic_rectification", {ElementType::remap_q5, 0},
                        [](const nlohmann::json& params, int width, int height) {
                          check_param_names(params, {"rotation_rad", "scale", "k1", "focal_px"});
                          SyntheticRectification model;
                          model.rotation_rad = param_double(params, "rotation_rad", model.rotation_rad, -0.2, 0.2);
                          model.scale = param_double(params, "scale", model.scale, 0.5, 2.0);
                          model.k1 = param_double(params, "k1", model.k1, -1.0, 1.0);
                          model.focal_px = param_double(params, "focal_px", model.focal_px, 0.0, 1e6);
                          return make_synthetic_rectification_map(width, height, model);
                        }});
  return generators;
}

}  // namespace lpstereo
