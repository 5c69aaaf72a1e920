// hedgefit info FILE: what a cloud file holds, like `pdal info`.

#include <nlohmann/json.hpp>

#include <cstdio>
#include <iostream>

#include "apps/commands.hpp"
#include "cloud/cloud_io.hpp"

namespace hedgefit::apps {

namespace {

// Clouds in metres rarely span more than ~200 units; in mm, rarely less than ~50.
std::string UnitsGuess(double extent) {
  if (extent <= 0) return "unknown (all points coincide)";
  if (extent < 50.0) return "m (largest extent " + std::to_string(extent) + "; read with scale 1000 for mm)";
  return "mm";
}

}  // namespace

void AddInfoCommand(CLI::App& app, CommandFn* run) {
  auto* cmd = app.add_subcommand("info", "Describe a cloud file: points, fields, organisation, bounds, NaNs, units");
  cmd->footer(
      "Examples:\n"
      "  hedgefit info sample_clouds/cap_z2300_a60_o10.pcd\n"
      "  hedgefit info --json ../shared/data/pcl_test/table_scene_mug_stereo_textured.pcd\n");
  auto file = std::make_shared<std::string>();
  auto as_json = std::make_shared<bool>(false);
  cmd->add_option("FILE", *file, "cloud file (" + cloud::CloudExtensionList() + ")")->required();
  cmd->add_flag("--json", *as_json, "print JSON instead of text");
  cmd->callback([=]() {
    *run = [=]() {
      cloud::CloudFileHeader header;
      const cloud::PointCloud c = cloud::ReadCloud(*file, {}, &header);
      Eigen::Vector3f lo = Eigen::Vector3f::Zero(), hi = Eigen::Vector3f::Zero();
      const bool any = cloud::Bounds(c, &lo, &hi);
      const std::size_t nonfinite = cloud::CountNonFinite(c);
      const double extent = any ? (hi - lo).maxCoeff() : 0.0;
      const std::string& format = header.format;
      if (*as_json) {
        nlohmann::json j;
        j["file"] = *file;
        j["format"] = format;
        j["encoding"] = header.encoding;
        j["points"] = c.size();
        j["fields"] = header.fields;
        j["organized"] = c.IsOrganized();
        j["width"] = c.width;
        j["height"] = c.height;
        j["has_color"] = c.HasColor();
        j["nonfinite"] = nonfinite;
        if (any) {
          j["bounds"] = {{"min", {lo.x(), lo.y(), lo.z()}}, {"max", {hi.x(), hi.y(), hi.z()}}};
        }
        j["units_guess"] = extent <= 0 ? "unknown" : extent < 50.0 ? "m" : "mm";
        std::cout << j.dump(2) << "\n";
        return kExitOk;
      }
      std::string fields;
      for (const auto& f : header.fields) fields += (fields.empty() ? "" : " ") + f;
      std::printf("file        %s\n", file->c_str());
      std::printf("format      %s (%s)\n", format.c_str(), header.encoding.c_str());
      std::printf("points      %zu (%s)\n", c.size(),
                  c.IsOrganized() ? ("organised " + std::to_string(c.width) + " x " + std::to_string(c.height)).c_str()
                                  : "unorganised");
      std::printf("fields      %s\n", fields.c_str());
      std::printf("colour      %s\n", c.HasColor() ? "yes" : "no");
      std::printf("non-finite  %zu\n", nonfinite);
      if (any) {
        std::printf("bounds      x [%.3f, %.3f]  y [%.3f, %.3f]  z [%.3f, %.3f]\n", lo.x(), hi.x(), lo.y(), hi.y(),
                    lo.z(), hi.z());
      } else {
        std::printf("bounds      none (no finite points)\n");
      }
      std::printf("units       %s\n", UnitsGuess(extent).c_str());
      return kExitOk;
    };
  });
}

}  // namespace hedgefit::apps
