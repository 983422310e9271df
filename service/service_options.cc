#include "service/service_options.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>

#include "core/error.h"

namespace g6d {

std::string ServiceOptions::Check() const {
  std::ostringstream out;
  if (templates_dir.empty())
    out << "templates_dir must be set (--templates DIR)";
  else if (input_channel.empty())
    out << "input_channel must not be empty";
  else if (output_channel.empty())
    out << "output_channel must not be empty";
  else if (status_channel.empty())
    out << "status_channel must not be empty";
  else if (input_channel == output_channel || input_channel == status_channel ||
           output_channel == status_channel)
    out << "input, output and status channels must differ (got '" << input_channel << "', '"
        << output_channel << "', '" << status_channel << "')";
  else if (workers < 1 || workers > 256)
    out << "workers must be in 1..256 (got " << workers << ")";
  else if (!std::isfinite(max_age_ms) || max_age_ms < 0.0)
    out << "max_age_ms must be >= 0 (got " << max_age_ms << ")";
  else if (subscription_queue < 1 || subscription_queue > 1000)
    out << "subscription_queue must be in 1..1000 (got " << subscription_queue << ")";
  else if (!std::isfinite(status_period_s) || status_period_s < 0.01)
    out << "status_period_s must be >= 0.01 (got " << status_period_s << ")";
  else if (latency_window < 1)
    out << "latency_window must be >= 1 (got " << latency_window << ")";
  else if (!std::isfinite(shutdown_timeout_s) || shutdown_timeout_s < 0.0)
    out << "shutdown_timeout_s must be >= 0 (got " << shutdown_timeout_s << ")";
  else if (!std::isfinite(reload_scan_period_s) || reload_scan_period_s < 0.0)
    out << "reload_scan_period_s must be >= 0 (got " << reload_scan_period_s << ")";
  else if (const std::string error = limits.Check(); !error.empty())
    out << "limits." << error;
  else if (const std::string error = solver.Check(); !error.empty())
    out << "solver." << error;
  else if (const std::string error = detect.Check(); !error.empty())
    out << error;  // "DetectOptions.<field> ..."
  else if (const std::string error = adapter.Check(input_type); !error.empty())
    out << error;
  else if (publish_rigid_transforms && rigid_transform_prefix.empty())
    out << "rigid_transform_prefix must not be empty";
  else if (const std::string error = tracking.Check(); !error.empty())
    out << "tracking: " << error;
  else if (const std::string error = debug_images.Check(); !error.empty())
    out << error;
  else if (debug_images.enabled() &&
           (debug_images.channel == input_channel || debug_images.channel == output_channel ||
            debug_images.channel == status_channel))
    out << "debug_images channel '" << debug_images.channel
        << "' must differ from the input, output and status channels";
  return out.str();
}

namespace {

// Reads `node` as T or throws naming the file and key.
template <typename T>
T As(const YAML::Node& node, const std::string& file, const std::string& key) {
  try {
    return node.as<T>();
  } catch (const YAML::Exception&) {
    G6D_THROW(file << ": key '" << key << "' has a value of the wrong type");
  }
}

// Applies every key of the mapping `node` through `setters`; an unknown key is an error.
void ApplyMap(const YAML::Node& node, const std::string& file, const std::string& prefix,
              const std::map<std::string,
                             std::function<void(const YAML::Node&, const std::string&)>>& setters) {
  if (!node.IsMap())
    G6D_THROW(file << ": '" << (prefix.empty() ? "<root>" : prefix) << "' must be a mapping");
  for (const auto& entry : node) {
    const std::string key = entry.first.as<std::string>();
    const std::string full_key = prefix.empty() ? key : prefix + "." + key;
    const auto setter = setters.find(key);
    if (setter == setters.end()) G6D_THROW(file << ": unknown key '" << full_key << "'");
    setter->second(entry.second, full_key);
  }
}

}  // namespace

void ParseServiceOptionsYaml(const std::string& text, const std::string& name,
                             ServiceOptions* options) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    G6D_THROW(name << ": not valid YAML: " << e.what());
  }
  if (root.IsNull()) return;  // an empty file changes nothing
  ServiceOptions& o = *options;
  using Setter = std::function<void(const YAML::Node&, const std::string&)>;
  auto string_field = [&](std::string* field) -> Setter {
    return [&name, field](const YAML::Node& n, const std::string& key) {
      *field = As<std::string>(n, name, key);
    };
  };
  auto int_field = [&](int* field) -> Setter {
    return [&name, field](const YAML::Node& n, const std::string& key) {
      *field = As<int>(n, name, key);
    };
  };
  auto double_field = [&](double* field) -> Setter {
    return [&name, field](const YAML::Node& n, const std::string& key) {
      *field = As<double>(n, name, key);
    };
  };
  auto bool_field = [&](bool* field) -> Setter {
    return [&name, field](const YAML::Node& n, const std::string& key) {
      *field = As<bool>(n, name, key);
    };
  };
  ApplyMap(root, name, "",
           {{"name", string_field(&o.name)},
            {"templates", string_field(&o.templates_dir)},
            {"input", string_field(&o.input_channel)},
            {"output", string_field(&o.output_channel)},
            {"status", string_field(&o.status_channel)},
            {"lcm_url", string_field(&o.lcm_url)},
            {"workers", int_field(&o.workers)},
            {"hypotheses", int_field(&o.solver.num_hypotheses)},
            {"mask_trust",
             [&](const YAML::Node& n, const std::string& key) {
               try {
                 o.solver.mask_trust = ParseMaskTrust(As<std::string>(n, name, key));
               } catch (const Error& e) {
                 G6D_THROW(name << ": key '" << key << "': " << e.what());
               }
             }},
            {"max_age_ms", double_field(&o.max_age_ms)},
            {"budget_ms", double_field(&o.solver.budget_ms)},
            {"subscription_queue", int_field(&o.subscription_queue)},
            {"status_period_s", double_field(&o.status_period_s)},
            {"latency_window", int_field(&o.latency_window)},
            {"shutdown_timeout_s", double_field(&o.shutdown_timeout_s)},
            {"reload", bool_field(&o.reload)},
            {"reload_scan_period_s", double_field(&o.reload_scan_period_s)},
            {"input_type",
             [&](const YAML::Node& n, const std::string& key) {
               try {
                 o.input_type = ParseInputType(As<std::string>(n, name, key));
               } catch (const Error& e) {
                 G6D_THROW(name << ": key '" << key << "': " << e.what());
               }
             }},
            {"camera",
             [&](const YAML::Node& n, const std::string& key) {
               YAML::Emitter text;
               text << n;
               o.adapter.camera = ParseCameraYaml(text.c_str(), name + ": " + key);
             }},
            {"camera_file",
             [&](const YAML::Node& n, const std::string& key) {
               o.adapter.camera = LoadCameraYaml(As<std::string>(n, name, key));
             }},
            {"labels",
             [&](const YAML::Node& n, const std::string& key) {
               YAML::Emitter text;
               text << n;
               o.adapter.label_objects = ParseLabelMapYaml(text.c_str(), name + ": " + key);
             }},
            {"find",
             [&](const YAML::Node& n, const std::string& key) {
               if (!n.IsMap()) G6D_THROW(name << ": key '" << key << "' must map object ids to counts");
               o.adapter.find_objects.clear();
               for (const auto& entry : n) {
                 const std::string id = entry.first.as<std::string>();
                 o.adapter.find_objects[id] = As<int>(entry.second, name, key + "." + id);
               }
             }},
            {"label_map_file",
             [&](const YAML::Node& n, const std::string& key) {
               o.adapter.label_objects = LoadLabelMapYaml(As<std::string>(n, name, key));
             }},
            {"camera_id", string_field(&o.adapter.camera_id)},
            {"publish_rigid_transforms", bool_field(&o.publish_rigid_transforms)},
            {"rigid_transform_prefix", string_field(&o.rigid_transform_prefix)},
            {"debug_images", string_field(&o.debug_images.channel)},
            {"debug_images_hz", double_field(&o.debug_images.max_rate_hz)},
            {"debug_images_jpeg_quality", int_field(&o.debug_images.jpeg_quality)},
            {"debug_images_type",
             [&](const YAML::Node& n, const std::string& key) {
               try {
                 o.debug_images.type = ParseDebugImageType(As<std::string>(n, name, key));
               } catch (const Error& e) {
                 G6D_THROW(name << ": key '" << key << "': " << e.what());
               }
             }},
            {"limits",
             [&](const YAML::Node& n, const std::string& key) {
               ApplyMap(n, name, key,
                        {{"max_width", int_field(&o.limits.max_width)},
                         {"max_height", int_field(&o.limits.max_height)},
                         {"max_raw_bytes",
                          [&](const YAML::Node& v, const std::string& k) {
                            o.limits.max_raw_bytes = As<int64_t>(v, name, k);
                          }},
                         {"max_instances", int_field(&o.limits.max_instances)}});
             }},
            {"solver",
             [&](const YAML::Node& n, const std::string& key) {
               ApplyMap(n, name, key,
                        {{"max_sets", int_field(&o.solver.match.max_sets)},
                         {"hamming_threshold", int_field(&o.solver.match.hamming_threshold)},
                         {"min_correspondences", int_field(&o.solver.match.min_correspondences)},
                         {"query_features", int_field(&o.solver.query_orb.max_features)},
                         {"run_icp", bool_field(&o.solver.run_icp)},
                         {"run_mhpo", bool_field(&o.solver.run_mhpo)},
                         {"mhpo_max_rounds", int_field(&o.solver.mhpo.max_rounds)},
                         {"early_stop_score", double_field(&o.solver.mhpo.early_stop_score)},
                         {"reject_border_masks", bool_field(&o.solver.reject_border_masks)},
                         {"min_valid_depth_pixels", int_field(&o.solver.min_valid_depth_pixels)},
                         {"use_silhouettes", bool_field(&o.solver.use_silhouettes)},
                         {"silhouette_hypotheses", int_field(&o.solver.silhouette_hypotheses)},
                         {"ppf_skip_agreement", int_field(&o.solver.ppf_skip_agreement)},
                         {"silhouette_skip_agreement", int_field(&o.solver.silhouette_skip_agreement)},
                         {"check_flips", bool_field(&o.solver.check_flips)}});
             }},
            {"tracking", [&](const YAML::Node& n, const std::string& key) {
               ApplyMap(n, name, key,
                        {{"enabled", bool_field(&o.tracking.enabled)},
                         {"max_age_s", double_field(&o.tracking.max_age_s)},
                         {"min_overlap", double_field(&o.tracking.min_overlap)},
                         {"loss_score", double_field(&o.tracking.loss_score)},
                         {"min_iou", double_field(&o.tracking.min_iou)},
                         {"appearance_drop", double_field(&o.tracking.appearance_drop)},
                         {"redetect_every", int_field(&o.tracking.redetect_every)},
                         {"max_periodic_per_frame", int_field(&o.tracking.max_periodic_per_frame)},
                         {"constant_velocity", bool_field(&o.tracking.constant_velocity)},
                         {"background_redetect", bool_field(&o.tracking.background_redetect)}});
             }},
            {"detect", [&](const YAML::Node& n, const std::string& key) {
               ApplyMap(n, name, key,
                        {{"extra_candidates", int_field(&o.detect.extra_candidates)},
                         {"colour_weight", double_field(&o.detect.colour_weight)},
                         {"max_score", double_field(&o.detect.max_score)},
                         {"explain_away_passes", int_field(&o.detect.explain_away_passes)},
                         {"found_object_passes", int_field(&o.detect.found_object_passes)},
                         {"refuse_behind_support", bool_field(&o.detect.refuse_behind_support)},
                         {"sure_first_confidence", double_field(&o.detect.sure_first_confidence)},
                         {"support_limit_from_frame", bool_field(&o.detect.support_limit_from_frame)},
                         {"max_solve_hypotheses", int_field(&o.detect.max_solve_hypotheses)},
                         {"solve_pnp_min_quality", double_field(&o.detect.solve_pnp_min_quality)},
                         {"solve_silhouettes", bool_field(&o.detect.solve_silhouettes)},
                         {"solve_check_flips", bool_field(&o.detect.solve_check_flips)},
                         {"area_weight", double_field(&o.detect.area_weight)},
                         {"identity_check_below", double_field(&o.detect.identity_check_below)},
                         {"max_planes", int_field(&o.detect.max_planes)},
                         {"support_extent_factor", double_field(&o.detect.support_extent_factor)},
                         {"raised_sigmas", double_field(&o.detect.raised_sigmas)},
                         {"raised_outline_edge", double_field(&o.detect.raised_outline_edge)},
                         {"island_open_px", int_field(&o.detect.island_open_px)},
                         {"island_split_core", double_field(&o.detect.island_split_core)},
                         {"island_silhouettes", bool_field(&o.detect.island_silhouettes)},
                         {"min_confidence", double_field(&o.detect.min_confidence)},
                         {"rank_uncoloured_by_shape", bool_field(&o.detect.rank_uncoloured_by_shape)}});
             }}});
}

void LoadServiceOptionsYaml(const std::string& path, ServiceOptions* options) {
  std::ifstream file(path);
  if (!file) G6D_THROW(path << ": cannot open the options file");
  std::stringstream text;
  text << file.rdbuf();
  ParseServiceOptionsYaml(text.str(), path, options);
}

}  // namespace g6d
