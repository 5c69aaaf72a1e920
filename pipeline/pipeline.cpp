#include "pipeline/pipeline.hpp"

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <pcl/pcl_config.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>

#include "pipeline/version.hpp"

namespace hedgefit::pipeline {

using nlohmann::json;

namespace {

OptionValue ValueFromJson(const json& j, const std::string& where) {
  switch (j.type()) {
    case json::value_t::boolean: return j.get<bool>();
    case json::value_t::number_integer: return j.get<std::int64_t>();
    case json::value_t::number_unsigned: return static_cast<std::int64_t>(j.get<std::uint64_t>());
    case json::value_t::number_float: return j.get<double>();
    case json::value_t::string: return j.get<std::string>();
    case json::value_t::array: {
      std::vector<double> v;
      for (const auto& e : j) {
        if (!e.is_number()) throw Error(where + ": arrays must hold numbers only");
        v.push_back(e.get<double>());
      }
      return v;
    }
    default: throw Error(where + ": expected a boolean, number, string or array of numbers, got " + j.type_name());
  }
}

json ToJson(const OptionValue& v) {
  return std::visit([](const auto& x) { return json(x); }, v);
}

struct Parsed {
  std::string type;
  std::string tag;
  std::map<std::string, OptionValue> given;
};

}  // namespace

std::map<std::string, std::string> LibraryVersions() {
  return {{"hedgefit", kVersion},
          {"pcl", PCL_VERSION_PRETTY},
          {"eigen", std::to_string(EIGEN_WORLD_VERSION) + "." + std::to_string(EIGEN_MAJOR_VERSION) + "." +
                        std::to_string(EIGEN_MINOR_VERSION)},
          {"nlohmann_json", std::to_string(NLOHMANN_JSON_VERSION_MAJOR) + "." +
                                std::to_string(NLOHMANN_JSON_VERSION_MINOR) + "." +
                                std::to_string(NLOHMANN_JSON_VERSION_PATCH)}};
}

Pipeline Pipeline::FromFile(const std::string& path, const Registry& registry,
                            const std::vector<std::string>& overrides) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(path + ": no such pipeline file; check the path");
  if (std::filesystem::is_directory(path, ec)) throw Error(path + ": is a directory; give a pipeline .json file");
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot be opened; check its permissions");
  std::stringstream ss;
  ss << in.rdbuf();
  return FromJson(ss.str(), path, registry, overrides);
}

namespace {

// The pipeline's JSON: an array of stages, or {"pipeline": [...]}.
json ParseDocument(const std::string& json_text, const std::string& source) {
  json doc;
  // JSON keeps the last of two equal keys without a word ({"mean_k": 10, "mean_k": 50}): one of
  // them is a mistake, so name it.
  std::vector<std::set<std::string>> keys;
  std::string twice;
  const json::parser_callback_t duplicates = [&](int, json::parse_event_t event, json& parsed) {
    if (event == json::parse_event_t::object_start) keys.emplace_back();
    if (event == json::parse_event_t::object_end && !keys.empty()) keys.pop_back();
    if (event == json::parse_event_t::key && !keys.empty() && !keys.back().insert(parsed.get<std::string>()).second &&
        twice.empty()) {
      twice = parsed.get<std::string>();
    }
    return true;
  };
  try {
    doc = json::parse(json_text, duplicates);
  } catch (const json::parse_error& e) {
    std::string msg = e.what();
    const auto colon = msg.find("]: ");
    throw Error(source + ": invalid JSON at byte " + std::to_string(e.byte) +
                (colon == std::string::npos ? "" : ": " + msg.substr(colon + 3)));
  }
  catch (const json::exception& e) {  // e.g. a number too large for a double
    std::string msg = e.what();
    const auto colon = msg.find("] ");
    throw Error(source + ": invalid JSON: " + (colon == std::string::npos ? msg : msg.substr(colon + 2)));
  }
  if (!twice.empty()) {
    throw Error(source + ": key '" + twice + "' appears twice in one object; JSON keeps only the last, so remove the "
                "one you did not mean");
  }
  if (doc.is_object() && doc.contains("pipeline")) doc = doc["pipeline"];
  if (!doc.is_array()) throw Error(source + ": a pipeline is a JSON array of stages (or {\"pipeline\": [...]})");
  if (doc.empty()) throw Error(source + ": the pipeline has no stages");

  return doc;
}

// Each stage's type, tag and given options; a bare file name becomes a reader or a writer.
std::vector<Parsed> ParseStages(const json& doc, const std::string& source, const Registry& registry) {
  std::vector<Parsed> parsed;
  bool seen_non_reader = false;
  for (std::size_t i = 0; i < doc.size(); ++i) {
    const json& s = doc[i];
    const std::string where = source + ": stage " + std::to_string(i + 1);
    Parsed p;
    std::string filename;
    if (s.is_string()) {
      filename = s.get<std::string>();
    } else if (s.is_object()) {
      for (auto it = s.begin(); it != s.end(); ++it) {
        if (it.key() == "type") {
          if (!it->is_string()) throw Error(where + ": \"type\" must be a string");
          p.type = it->get<std::string>();
        } else if (it.key() == "tag") {
          if (!it->is_string()) throw Error(where + ": \"tag\" must be a string");
          p.tag = it->get<std::string>();
        } else {
          p.given[it.key()] = ValueFromJson(*it, where + ", option '" + it.key() + "'");
        }
      }
      if (p.type.empty()) {
        auto f = p.given.find("filename");
        if (f == p.given.end() || !std::holds_alternative<std::string>(f->second)) {
          throw Error(where + ": needs a \"type\" (or a \"filename\" to choose a reader/writer by extension)");
        }
        filename = std::get<std::string>(f->second);
      }
    } else {
      throw Error(where + ": must be a file name or an object with \"type\"");
    }
    if (p.type.empty()) {
      // PDAL's rule: a filename is a writer after any non-reader stage, or as the last of
      // several stages (so ["in.pcd", "out.ply"] converts).
      const bool writer = seen_non_reader || (i + 1 == doc.size() && i > 0);
      const StageDescriptor* d = registry.ForExtension(filename, writer);
      if (d == nullptr) {
        throw Error(where + ": no " + std::string(writer ? "writer" : "reader") + " for '" + filename +
                    "'; use " + registry.ExtensionList(writer) + ", or give \"type\"");
      }
      p.type = d->info.name;
      p.given["filename"] = filename;
    }
    if (p.type.rfind("readers.", 0) != 0) seen_non_reader = true;
    parsed.push_back(std::move(p));
  }

  return parsed;
}

// A command-line override "label.option=value", label being a tag or a type.
void ApplyOverride(const std::string& o, const std::string& source, const Registry& registry,
                   std::vector<Parsed>* stages) {
  std::vector<Parsed>& parsed = *stages;
  const auto eq = o.find('=');
  const auto dot = o.substr(0, eq).find_last_of('.');
  if (eq == std::string::npos || dot == std::string::npos || dot == 0) {
    throw Error("--set '" + o + "': expected stage.option=value, e.g. filters.statistical_outlier.mean_k=30");
  }
  const std::string label = o.substr(0, dot), option = o.substr(dot + 1, eq - dot - 1), value = o.substr(eq + 1);
  std::vector<Parsed*> matches;
  for (auto& p : parsed) {
    if (p.tag == label || (p.tag.empty() && p.type == label) || (!p.tag.empty() && p.type == label)) matches.push_back(&p);
  }
  if (matches.empty()) {
    std::vector<std::string> labels;
    for (const auto& p : parsed) labels.push_back(p.tag.empty() ? p.type : p.tag);
    const std::string hint = DidYouMean(label, labels);
    throw Error("--set '" + o + "': no stage '" + label + "' in " + source +
                (hint.empty() ? "" : " (did you mean '" + hint + "'?)"));
  }
  if (matches.size() > 1) {
    throw Error("--set '" + o + "': " + std::to_string(matches.size()) + " stages are '" + label +
                "'; give them a \"tag\" in the pipeline and use it");
  }
  const StageDescriptor& d = registry.Get(matches[0]->type, source + ": ");
  const OptionSpec* spec = d.info.FindOption(option);
  if (spec == nullptr) {
    std::vector<std::string> names;
    for (const auto& s : d.info.options) names.push_back(s.name);
    const std::string hint = DidYouMean(option, names);
    throw Error("--set '" + o + "': stage '" + label + "' has no option '" + option + "'" +
                (hint.empty() ? "" : " (did you mean '" + hint + "'?)"));
  }
  matches[0]->given[option] = ParseOptionString(*spec, value, label);
}

}  // namespace

Pipeline Pipeline::FromJson(const std::string& json_text, const std::string& source, const Registry& registry,
                            const std::vector<std::string>& overrides, const std::vector<std::string>& provided) {
  const json doc = ParseDocument(json_text, source);
  std::vector<Parsed> parsed = ParseStages(doc, source, registry);
  for (const std::string& o : overrides) ApplyOverride(o, source, registry, &parsed);

  Pipeline pipeline;
  std::set<std::string> available(provided.begin(), provided.end());
  std::set<std::string> labels;
  for (std::size_t i = 0; i < parsed.size(); ++i) {
    Parsed& p = parsed[i];
    const StageDescriptor& d = registry.Get(p.type, source + ": stage " + std::to_string(i + 1) + ": ");
    PlannedStage planned;
    planned.type = p.type;
    planned.label = p.tag.empty() ? p.type : p.tag;
    if (!p.tag.empty() && !labels.insert(p.tag).second) {
      throw Error(source + ": tag '" + p.tag + "' is used twice; tags must be unique");
    }
    for (const std::string& in : d.info.inputs) {
      if (!available.count(in)) {
        throw Error(source + ": stage '" + planned.label + "' needs a '" + in + "' artifact but no earlier stage makes one" +
                    (in == "cloud" ? "; start the pipeline with a reader, e.g. \"input.pcd\"" : ""));
      }
    }
    planned.options = ResolveOptions(d.info, p.given, planned.label);
    if (d.option_inputs) {
      for (const auto& [in, why] : d.option_inputs(planned.options)) {
        if (!available.count(in)) {
          throw Error(source + ": stage '" + planned.label + "': " + why + " needs a '" + in +
                      "' artifact but no earlier stage makes one");
        }
      }
    }
    for (const std::string& out : d.info.outputs) available.insert(out);
    planned.stage = d.make(planned.options);  // may reject option combinations
    pipeline.stages_.push_back(std::move(planned));
  }
  return pipeline;
}

RunReport Pipeline::Run(Context& ctx) { return Run(ctx, 0, stages_.size()); }

RunReport Pipeline::Run(Context& ctx, std::size_t first, std::size_t end) {
  RunReport report;
  end = std::min(end, stages_.size());
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  // Outputs are staged beside their targets and renamed into place only when every stage
  // has succeeded: a failed run leaves every existing file as it was.
  ctx.stage_outputs = true;
  ctx.staged_outputs.clear();
  struct Discard {
    Context& ctx;
    ~Discard() {
      std::error_code ec;
      for (const auto& [staged, final_path] : ctx.staged_outputs) std::filesystem::remove(staged, ec);
      ctx.staged_outputs.clear();
      ctx.stage_outputs = false;
    }
  } discard{ctx};
  for (std::size_t i = first; i < end; ++i) {
    PlannedStage& s = stages_[i];
    StageReport r;
    r.label = s.label;
    r.type = s.type;
    ctx.current_stage = s.label;
    r.points_in = ctx.SizeOf("cloud");
    const auto t0 = Clock::now();
    try {
      s.stage->Run(ctx);
    } catch (const Error& e) {
      // A writer that failed names its hidden staged file: the user gave the final path.
      std::string what = e.what();
      bool renamed = false;
      for (const auto& [staged, final_path] : ctx.staged_outputs) {
        for (std::size_t at; (at = what.find(staged)) != std::string::npos; renamed = true) {
          what.replace(at, staged.size(), final_path);
        }
      }
      if (!renamed) throw;
      if (dynamic_cast<const InputError*>(&e)) throw InputError(what);
      if (dynamic_cast<const ProcessingError*>(&e)) throw ProcessingError(what);
      throw Error(what);
    } catch (const std::exception& e) {
      throw ProcessingError("stage '" + s.label + "' failed: " + e.what());
    }
    r.wall_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    r.points_out = ctx.SizeOf("cloud");
    r.notes = ctx.notes[s.label];
    report.stages.push_back(std::move(r));
  }
  for (const auto& [staged, final_path] : ctx.staged_outputs) {
    std::error_code ec;
    std::filesystem::rename(staged, final_path, ec);
    if (ec) {
      throw Error(final_path + ": cannot be replaced (" + ec.message() + "); the pipeline's other outputs were " +
                  "written");
    }
  }
  report.total_ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  return report;
}

std::string Pipeline::MetadataJson(const RunReport& report, const Context& ctx) const {
  json meta;
  meta["versions"] = LibraryVersions();
  meta["seed"] = ctx.seed;
  json stages = json::array();
  for (const auto& s : stages_) {
    json j;
    j["type"] = s.type;
    if (s.label != s.type) j["tag"] = s.label;
    for (const auto& [k, v] : s.options.values()) j[k] = ToJson(v);
    stages.push_back(j);
  }
  meta["pipeline"] = stages;
  json runs = json::array();
  for (const auto& r : report.stages) {
    json j;
    j["label"] = r.label;
    j["type"] = r.type;
    j["wall_ms"] = r.wall_ms;
    if (r.points_in >= 0) j["points_in"] = r.points_in;
    if (r.points_out >= 0) j["points_out"] = r.points_out;
    json notes = json::object();
    for (const auto& [k, v] : r.notes) notes[k] = ToJson(v);
    j["notes"] = notes;
    runs.push_back(j);
  }
  meta["stages"] = runs;
  meta["total_ms"] = report.total_ms;
  return meta.dump(2) + "\n";
}

}  // namespace hedgefit::pipeline
