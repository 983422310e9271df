// g6d-eval: BOP'19 evaluation of a BOP results CSV on a BOP dataset.
//
//   g6d-eval --dataset DIR --results CSV [--targets FILE] [--json OUT.json]
//       [--plot OUT.png] [--threads N] [--adds-ids 21,...] [--estimated-only] [--per-instance]
//
// Prints, per object and over all targets, the number of targets, ADD(-S)@0.1d recall
// (the g6d-bench-dataset criterion) and the BOP'19 average recalls AR_VSD, AR_MSSD,
// AR_MSPD and AR (lib/eval/bop_eval.h describes the protocol). Targets without an
// estimate count as failures. --json writes every number, the per-threshold recalls and
// one entry per target; --plot draws a bar chart of ADD(-S) and AR per object.
// --estimated-only keeps only the targets whose (image, object) has an estimate: for
// comparing partial runs (g6d-bench-dataset --limit); that is not a BOP score.
// --per-instance also prints one line per target: its image, object, GT index, visible
// fraction, the score and time of the image's best-scored estimate of that object, and
// the smallest ADD(-S) error of the image's kept estimates of that object (mm and
// diameters) with the matched verdict.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "core/error.h"
#include "core/executor.h"
#include "eval/bop.h"
#include "eval/bop_csv.h"
#include "eval/bop_eval.h"

namespace {

using Json = nlohmann::json;

std::string ObjectLabel(const g6d::BopObjectReport& object) {
  return object.name + (object.uses_adds ? " (ADD-S)" : "");
}

void PrintRow(const std::string& label, const g6d::BopRecall& r) {
  std::printf("| %-20s | %7d | %7d | %8.3f | %6.3f | %7.3f | %7.3f | %6.3f |\n", label.c_str(),
              r.targets, r.with_estimate, r.add_recall, r.ar_vsd, r.ar_mssd, r.ar_mspd, r.ar);
}

void PrintTable(const g6d::BopEvalReport& report) {
  std::printf("| %-20s | %7s | %7s | %8s | %6s | %7s | %7s | %6s |\n", "object", "targets",
              "w/ est.", "ADD(-S)", "AR_VSD", "AR_MSSD", "AR_MSPD", "AR");
  std::printf(
      "|%s|%s|%s|%s|%s|%s|%s|%s|\n", std::string(22, '-').c_str(), std::string(9, '-').c_str(),
      std::string(9, '-').c_str(), std::string(10, '-').c_str(), std::string(8, '-').c_str(),
      std::string(9, '-').c_str(), std::string(9, '-').c_str(), std::string(8, '-').c_str());
  for (const g6d::BopObjectReport& object : report.objects) {
    PrintRow(ObjectLabel(object), object.recall);
  }
  PrintRow("all", report.overall);
}

// One line per target (BopTargetReport), with the score and time of the image's
// best-scored estimate of the object.
void PrintPerInstance(const g6d::BopDataset& dataset, const g6d::BopEvalReport& report,
                      const std::vector<g6d::BopEstimate>& estimates) {
  std::map<std::tuple<int, int, int>, const g6d::BopEstimate*> best;
  for (const g6d::BopEstimate& e : estimates) {
    const g6d::BopEstimate*& slot = best[{e.scene_id, e.im_id, e.obj_id}];
    if (slot == nullptr || e.score > slot->score) slot = &e;
  }
  std::printf(
      "\nper instance (score and time of the image's best-scored estimate of the object; error: "
      "smallest ADD(-S) of its kept estimates):\n");
  std::printf("| %5s | %6s | %-12s | %3s | %5s | %6s | %8s | %10s | %6s | %-7s |\n", "scene",
              "image", "object", "gt", "visib", "score", "time (s)", "error (mm)", "/ d",
              "correct");
  std::printf(
      "|-------|--------|--------------|-----|-------|--------|----------|------------|--------|---"
      "------|\n");
  for (const g6d::BopTargetReport& t : report.targets) {
    const g6d::BopObjectInfo& info = dataset.Object(t.obj_id);
    const auto it = best.find({t.scene_id, t.im_id, t.obj_id});
    if (it == best.end() || !std::isfinite(t.add_m)) {
      std::printf("| %5d | %6d | %-12s | %3d | %5.2f | %6s | %8s | %10s | %6s | %-7s |\n",
                  t.scene_id, t.im_id, info.name.c_str(), t.gt_idx, t.visib_fract, "-", "-", "-",
                  "-", "no est.");
      continue;
    }
    std::printf("| %5d | %6d | %-12s | %3d | %5.2f | %6.3f | %8.3f | %10.1f | %6.3f | %-7s |\n",
                t.scene_id, t.im_id, info.name.c_str(), t.gt_idx, t.visib_fract, it->second->score,
                it->second->time_s, t.add_m * 1000.0,
                info.diameter_m > 0.0 ? t.add_m / info.diameter_m : 0.0,
                t.add_correct ? "yes" : "no");
  }
}

Json RecallJson(const g6d::BopRecall& r) {
  Json json;
  json["targets"] = r.targets;
  json["targets_with_estimate"] = r.with_estimate;
  json["add_correct"] = r.add_correct;
  json["add_recall"] = r.add_recall;
  json["ar_vsd"] = r.ar_vsd;
  json["ar_mssd"] = r.ar_mssd;
  json["ar_mspd"] = r.ar_mspd;
  json["ar"] = r.ar;
  auto recall = [&](int correct) { return r.targets > 0 ? double(correct) / r.targets : 0.0; };
  Json vsd = Json::array();
  for (const std::vector<int>& per_threshold : r.vsd_correct) {
    Json row = Json::array();
    for (int correct : per_threshold) row.push_back(recall(correct));
    vsd.push_back(row);
  }
  json["vsd_recall_by_tau_and_threshold"] = vsd;
  Json mssd = Json::array(), mspd = Json::array();
  for (int correct : r.mssd_correct) mssd.push_back(recall(correct));
  for (int correct : r.mspd_correct) mspd.push_back(recall(correct));
  json["mssd_recall_by_threshold"] = mssd;
  json["mspd_recall_by_threshold"] = mspd;
  return json;
}

// The last path component, also for "dir/" ("dir").
std::string BaseName(const std::string& path) {
  std::filesystem::path p(path);
  if (p.filename().empty()) p = p.parent_path();
  return p.filename().string();
}

// Infinity (no estimate) becomes null.
Json Number(double value) { return std::isfinite(value) ? Json(value) : Json(nullptr); }

Json ReportJson(const g6d::BopEvalReport& report, const std::string& dataset,
                const std::string& results, const std::string& targets_file, bool estimated_only,
                const g6d::BopEvalOptions& options, int threads) {
  Json json;
  json["dataset"] = dataset;
  json["results"] = results;
  json["targets_file"] = targets_file;
  json["estimated_only"] = estimated_only;
  json["protocol"] = {{"name", "BOP19"},
                      {"vsd_delta_mm", options.vsd.delta_m * 1000.0},
                      {"vsd_taus_fraction_of_diameter", report.vsd_taus},
                      {"vsd_thresholds", report.vsd_thresholds},
                      {"mssd_thresholds_fraction_of_diameter", report.mssd_thresholds},
                      {"mspd_thresholds_px_at_640", report.mspd_thresholds_px},
                      {"mspd_reference_width_px", options.mspd_reference_width_px},
                      {"add_threshold_fraction_of_diameter", options.add_threshold},
                      {"adds_obj_ids", options.adds_obj_ids}};
  json["overall"] = RecallJson(report.overall);
  Json objects = Json::array();
  for (const g6d::BopObjectReport& object : report.objects) {
    Json entry = RecallJson(object.recall);
    entry["obj_id"] = object.obj_id;
    entry["name"] = object.name;
    entry["add_kind"] = object.uses_adds ? "ADD-S" : "ADD";
    objects.push_back(entry);
  }
  json["objects"] = objects;
  Json targets = Json::array();
  for (const g6d::BopTargetReport& t : report.targets) {
    targets.push_back({{"scene_id", t.scene_id},
                       {"im_id", t.im_id},
                       {"obj_id", t.obj_id},
                       {"gt_idx", t.gt_idx},
                       {"visib_fract", t.visib_fract},
                       {"estimates", t.estimates},
                       {"best_add_mm", Number(t.add_m * 1000.0)},
                       {"best_mssd_mm", Number(t.mssd_m * 1000.0)},
                       {"best_mspd_px", Number(t.mspd_px)},
                       {"best_vsd_mean", Number(t.vsd_mean)},
                       {"add_correct", t.add_correct}});
  }
  json["targets"] = targets;
  json["counts"] = {{"target_entries", report.num_target_entries},
                    {"images", report.num_images},
                    {"estimates", report.num_estimates},
                    {"estimates_evaluated", report.num_estimates_evaluated},
                    {"estimates_ignored_not_target", report.num_estimates_ignored},
                    {"estimates_beyond_inst_count", report.num_estimates_beyond_count}};
  json["time_s"] = {{"load", report.load_ms / 1000.0},
                    {"errors", report.errors_ms / 1000.0},
                    {"total", report.total_ms / 1000.0},
                    {"threads", threads}};
  return json;
}

// A bar chart: per object (and "all") one bar for ADD(-S) recall and one for AR, values on
// top, a 0..1 axis with grid lines, a legend.
cv::Mat DrawChart(const g6d::BopEvalReport& report, const std::string& title) {
  struct Group {
    std::string label;
    double add = 0.0;
    double ar = 0.0;
    int targets = 0;
  };
  std::vector<Group> groups;
  for (const g6d::BopObjectReport& object : report.objects) {
    groups.push_back(
        {object.name, object.recall.add_recall, object.recall.ar, object.recall.targets});
  }
  groups.push_back({"all", report.overall.add_recall, report.overall.ar, report.overall.targets});

  const int group_width = 130, left = 70, right = 30, top = 100, bottom = 80, plot_height = 400;
  const int width = left + right + group_width * static_cast<int>(groups.size());
  const int height = top + plot_height + bottom;
  cv::Mat image(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  const cv::Scalar black(0, 0, 0), grid(220, 220, 220);
  const cv::Scalar add_color(180, 119, 31);  // BGR: blue
  const cv::Scalar ar_color(14, 127, 255);   // BGR: orange
  auto y_of = [&](double value) {
    return top + plot_height - static_cast<int>(std::lround(value * plot_height));
  };
  auto centred_text = [&](const std::string& text, int x_centre, int y, double scale,
                          const cv::Scalar& color, int thickness) {
    int baseline = 0;
    const cv::Size size = cv::getTextSize(text, font, scale, thickness, &baseline);
    cv::putText(image, text, {x_centre - size.width / 2, y}, font, scale, color, thickness,
                cv::LINE_AA);
  };

  centred_text(title, width / 2, 30, 0.65, black, 2);
  for (int tick = 0; tick <= 10; ++tick) {
    const int y = y_of(tick / 10.0);
    cv::line(image, {left, y}, {width - right, y}, tick == 0 ? black : grid, 1);
    char text[16];
    std::snprintf(text, sizeof(text), "%.1f", tick / 10.0);
    cv::putText(image, text, {left - 40, y + 5}, font, 0.45, black, 1, cv::LINE_AA);
  }
  cv::line(image, {left, top}, {left, top + plot_height}, black, 1);

  const int bar_width = 44;
  for (size_t i = 0; i < groups.size(); ++i) {
    const int x0 = left + static_cast<int>(i) * group_width + (group_width - 2 * bar_width) / 2;
    const double values[2] = {groups[i].add, groups[i].ar};
    const cv::Scalar colors[2] = {add_color, ar_color};
    for (int b = 0; b < 2; ++b) {
      const int x = x0 + b * bar_width;
      const int y = y_of(std::clamp(values[b], 0.0, 1.0));
      cv::rectangle(image, {x + 2, y}, {x + bar_width - 2, y_of(0.0)}, colors[b], cv::FILLED);
      char text[16];
      std::snprintf(text, sizeof(text), "%.2f", values[b]);
      centred_text(text, x + bar_width / 2, y - 6, 0.42, black, 1);
    }
    const int x_centre = x0 + bar_width;
    centred_text(groups[i].label, x_centre, top + plot_height + 24, 0.48, black,
                 groups[i].label == "all" ? 2 : 1);
    centred_text("n=" + std::to_string(groups[i].targets), x_centre, top + plot_height + 46, 0.42,
                 cv::Scalar(90, 90, 90), 1);
  }

  // Legend, top right.
  const int legend_x = width - right - 250, legend_y = 60;
  cv::rectangle(image, {legend_x, legend_y - 12}, {legend_x + 16, legend_y + 2}, add_color,
                cv::FILLED);
  cv::putText(image, "ADD(-S)@0.1d", {legend_x + 22, legend_y}, font, 0.45, black, 1, cv::LINE_AA);
  cv::rectangle(image, {legend_x + 140, legend_y - 12}, {legend_x + 156, legend_y + 2}, ar_color,
                cv::FILLED);
  cv::putText(image, "BOP AR", {legend_x + 162, legend_y}, font, 0.45, black, 1, cv::LINE_AA);
  return image;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"g6d-eval: ADD(-S)@0.1d recall and BOP'19 AR (VSD, MSSD, MSPD) of a results CSV"};
  std::string dataset_dir, results_path, targets_path, json_path, plot_path, split = "test";
  std::vector<int> adds_ids;
  int threads = 2;
  app.add_option("--dataset", dataset_dir, "BOP dataset folder (models/, test/, ...)")->required();
  app.add_option("--results", results_path,
                 "BOP results CSV (scene_id,im_id,obj_id,score,R,t,time; mm)")
      ->required();
  app.add_option("--targets", targets_path,
                 "targets JSON (default: <dataset>/test_targets_bop19.json)");
  app.add_option("--json", json_path, "write all numbers and per-target errors as JSON");
  app.add_option("--plot", plot_path, "write a PNG bar chart of ADD(-S) and AR per object");
  app.add_option("--threads", threads, "threads, including the main one")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));
  app.add_option("--adds-ids", adds_ids,
                 "object ids to evaluate with ADD-S even without symmetry annotations")
      ->delimiter(',');
  app.add_option("--split", split, "dataset split folder")->capture_default_str();
  bool estimated_only = false;
  bool per_instance = false;
  app.add_flag(
      "--per-instance", per_instance,
      "also print one line per target: score, time, ADD(-S) error in mm and diameters, correct");
  app.add_flag("--estimated-only", estimated_only,
               "evaluate only targets whose image and object have an estimate (partial runs; "
               "not a BOP score)");
  CLI11_PARSE(app, argc, argv);

  try {
    if (!std::filesystem::is_directory(dataset_dir)) {
      G6D_THROW("dataset folder '" << dataset_dir << "' does not exist");
    }
    const g6d::BopDataset dataset = g6d::LoadBopDataset(dataset_dir, split);
    if (targets_path.empty()) {
      targets_path = (std::filesystem::path(dataset_dir) / "test_targets_bop19.json").string();
      if (!dataset.has_targets) {
        G6D_THROW("'" << dataset_dir
                      << "' has no test_targets_bop19.json; pass the targets with --targets");
      }
    }
    std::vector<g6d::BopTarget> targets = g6d::LoadBopTargets(targets_path);
    if (!std::filesystem::is_regular_file(results_path)) {
      G6D_THROW("results file '" << results_path << "' does not exist");
    }
    const std::vector<g6d::BopEstimate> estimates = g6d::ReadBopCsv(results_path);
    if (estimated_only) {
      std::set<std::tuple<int, int, int>> estimated;
      for (const g6d::BopEstimate& e : estimates) estimated.insert({e.scene_id, e.im_id, e.obj_id});
      targets.erase(std::remove_if(targets.begin(), targets.end(),
                                   [&](const g6d::BopTarget& t) {
                                     return !estimated.count({t.scene_id, t.im_id, t.obj_id});
                                   }),
                    targets.end());
    }

    g6d::BopEvalOptions options;
    options.adds_obj_ids = adds_ids;
    g6d::ThreadPool pool(threads);
    const g6d::BopEvalReport report = g6d::EvaluateBop(dataset, targets, estimates, options, &pool);
    if (!report.success) G6D_THROW("evaluation failed: " << report.message);

    std::printf(
        "g6d-eval: %s on %s%s\n%d targets (%d target entries, %d images); %d estimates: %d "
        "evaluated, %d not targets, %d beyond inst_count\n\n",
        results_path.c_str(), dataset_dir.c_str(),
        estimated_only ? " (--estimated-only: targets with an estimate only, not a BOP score)" : "",
        report.overall.targets, report.num_target_entries, report.num_images, report.num_estimates,
        report.num_estimates_evaluated, report.num_estimates_ignored,
        report.num_estimates_beyond_count);
    PrintTable(report);
    std::printf(
        "\nrecalls are fractions of the targets; missing estimates count as failures.\n"
        "time: load %.2f s, errors %.2f s, total %.2f s (%d threads)\n",
        report.load_ms / 1000.0, report.errors_ms / 1000.0, report.total_ms / 1000.0, threads);
    if (per_instance) PrintPerInstance(dataset, report, estimates);

    if (!json_path.empty()) {
      std::ofstream out(json_path);
      if (!out) G6D_THROW("cannot write " << json_path);
      out << ReportJson(report, dataset_dir, results_path, targets_path, estimated_only, options,
                        threads)
                 .dump(1)
          << "\n";
      if (!out) G6D_THROW("cannot write " << json_path);
      std::printf("wrote %s\n", json_path.c_str());
    }
    if (!plot_path.empty()) {
      const std::string title = BaseName(results_path) + " on " + BaseName(dataset_dir) +
                                (estimated_only ? " (estimated targets only)" : "") +
                                ": ADD(-S)@0.1d and BOP'19 AR";
      if (!cv::imwrite(plot_path, DrawChart(report, title))) {
        G6D_THROW("cannot write " << plot_path);
      }
      std::printf("wrote %s\n", plot_path.c_str());
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "g6d-eval: error: %s\n", e.what());
    return 1;
  }
}
