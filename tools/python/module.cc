// g6d._core: the solver of lib/ for Python (issue 32). numpy arrays in, the same calls as
// g6d-solve (tools/solve_main.cc) and the service, dictionaries of numpy fields out; the
// public functions, their keyword options and docstrings are in g6d/__init__.py.
//
// Every check of an argument happens here, with the GIL held, before the solve; the solve
// itself runs with the GIL released on copies the call owns, so Python threads solve at
// once. Bad arguments raise ValueError naming the argument; g6d::Error (a bad file, a
// refused cache) raises g6d.Error, a RuntimeError.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/camera.h"
#include "core/error.h"
#include "core/executor.h"
#include "core/frame.h"
#include "core/hash.h"
#include "mesh/mesh.h"
#include "render/overlay.h"
#include "solver/detect.h"
#include "solver/identify.h"
#include "solver/pipeline.h"
#include "templates/cache.h"
#include "templates/template_bank.h"
#include "types.h"

namespace g6d::python {
namespace {

namespace py = pybind11;
using FramePtr = std::shared_ptr<Frame>;

[[noreturn]] void BadArgument(const std::string& message) { throw py::value_error(message); }

// "uint8 array of shape (480, 640, 3)".
std::string Describe(const py::array& array) {
  std::ostringstream text;
  text << py::str(array.dtype()).cast<std::string>() << " array of shape (";
  for (py::ssize_t i = 0; i < array.ndim(); ++i) text << (i > 0 ? ", " : "") << array.shape(i);
  text << (array.ndim() == 1 ? ",)" : ")");
  return text.str();
}

// `object` as a numpy array (numpy.asarray), or a ValueError naming the argument.
py::array AsArray(const py::handle& object, const std::string& name, const std::string& expected) {
  if (py::isinstance<py::array>(object)) return py::reinterpret_borrow<py::array>(object);
  py::array array = py::array::ensure(object);
  if (!array) {
    BadArgument(name + ": expected " + expected + ", got " + py::str(py::type::of(object)).cast<std::string>());
  }
  return array;
}

template <typename Scalar>
bool HasDtype(const py::array& array) {
  return array.dtype().is(py::dtype::of<Scalar>());
}

// A C-contiguous view (or copy) of an array whose dtype is already Scalar.
template <typename Scalar>
py::array_t<Scalar, py::array::c_style> Contiguous(const py::array& array) {
  return py::array_t<Scalar, py::array::c_style>::ensure(array);
}

// Copies a C-contiguous 2D or HxWxC array into a new cv::Mat of `type`.
template <typename Scalar>
cv::Mat CopyToMat(const py::array_t<Scalar, py::array::c_style>& array, int type) {
  const int rows = static_cast<int>(array.shape(0)), cols = static_cast<int>(array.shape(1));
  cv::Mat wrapped(rows, cols, type, const_cast<Scalar*>(array.data()));
  return wrapped.clone();
}

// A 4x4 rigid transform from Python (e.g. a result's cam_from_object), or a ValueError.
Eigen::Isometry3d PoseFromArray(const py::handle& object, const std::string& name) {
  const py::array array = AsArray(object, name, "a 4x4 rigid transform (numpy float64)");
  if (array.ndim() != 2 || array.shape(0) != 4 || array.shape(1) != 4) {
    BadArgument(name + ": expected a 4x4 rigid transform, got a " + Describe(array));
  }
  const auto values = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(array);
  if (!values) BadArgument(name + ": expected real numbers, got a " + Describe(array));
  Eigen::Matrix4d matrix;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) matrix(r, c) = values.at(r, c);
  }
  const Eigen::Matrix3d rotation = matrix.topLeftCorner<3, 3>();
  const bool finite = matrix.allFinite();
  const bool last_row = matrix(3, 0) == 0.0 && matrix(3, 1) == 0.0 && matrix(3, 2) == 0.0 && matrix(3, 3) == 1.0;
  const bool orthonormal = finite && (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm() < 1e-6 &&
                           rotation.determinant() > 0.0;
  if (!finite || !last_row || !orthonormal) {
    BadArgument(name + ": not a rigid transform (expected a finite 4x4 [R t; 0 0 0 1] with R a rotation, "
                       "metres)");
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.matrix() = matrix;
  return pose;
}

// ---------------------------------------------------------------------------------------
// Frame

// The pinhole camera of K (3x3, pixels, BOP convention: pixel (u, v) centred at
// (u + 0.5, v + 0.5)) for an image of width x height.
Camera CameraFromK(const py::handle& object, int width, int height) {
  const py::array array = AsArray(object, "K", "a 3x3 intrinsics matrix");
  if (array.ndim() != 2 || array.shape(0) != 3 || array.shape(1) != 3) {
    BadArgument("K: expected a 3x3 intrinsics matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (pixels), got a " +
                Describe(array));
  }
  const auto k = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(array);
  if (!k) BadArgument("K: expected real numbers, got a " + Describe(array));
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(k.at(r, c))) {
        BadArgument("K: K[" + std::to_string(r) + ", " + std::to_string(c) + "] is not finite");
      }
    }
  }
  if (k.at(0, 1) != 0.0) BadArgument("K: K[0, 1] (skew) must be 0, got " + std::to_string(k.at(0, 1)));
  if (k.at(1, 0) != 0.0 || k.at(2, 0) != 0.0 || k.at(2, 1) != 0.0 || k.at(2, 2) != 1.0) {
    BadArgument("K: expected [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]: the rows below the focal lengths must be "
                "[0, fy, cy] and [0, 0, 1]");
  }
  Camera camera{k.at(0, 0), k.at(1, 1), k.at(0, 2), k.at(1, 2), width, height};
  if (const std::string bad = camera.Check(); !bad.empty()) BadArgument("K: " + bad);
  return camera;
}

cv::Mat DepthFromArray(const py::handle& object, const py::object& depth_scale, bool nan_as_missing, int width,
                       int height) {
  const py::array array = AsArray(object, "depth", "a numpy array");
  const std::string expected =
      "uint16 with depth_scale (metres per unit) or float32 metres, of shape (" + std::to_string(height) + ", " +
      std::to_string(width) + ") like rgb";
  if (array.ndim() != 2 || array.shape(0) != height || array.shape(1) != width) {
    BadArgument("depth: expected " + expected + ", got a " + Describe(array));
  }
  cv::Mat depth_m;
  if (HasDtype<uint16_t>(array)) {
    if (depth_scale.is_none()) {
      BadArgument("depth: a uint16 depth image needs depth_scale, metres per unit (0.001 for millimetres; BOP: "
                  "scene_camera's depth_scale / 1000)");
    }
    const double scale = depth_scale.cast<double>();
    if (!(std::isfinite(scale) && scale > 0.0)) {
      BadArgument("depth_scale: expected a finite number > 0 (metres per depth unit), got " + std::to_string(scale));
    }
    const cv::Mat raw = CopyToMat(Contiguous<uint16_t>(array), CV_16U);
    // As g6d-solve and the service convert a uint16 image (bit for bit the same floats).
    raw.convertTo(depth_m, CV_32F, scale);
    return depth_m;
  }
  if (!HasDtype<float>(array)) {
    BadArgument("depth: expected " + expected + ", got a " + Describe(array) +
                (HasDtype<double>(array) ? " (convert with depth.astype(numpy.float32))" : ""));
  }
  if (!depth_scale.is_none() && depth_scale.cast<double>() != 1.0) {
    BadArgument("depth_scale: a float32 depth image is in metres; give depth_scale only with uint16 depth");
  }
  depth_m = CopyToMat(Contiguous<float>(array), CV_32F);
  int bad_count = 0, first_row = -1, first_column = -1;
  for (int v = 0; v < depth_m.rows; ++v) {
    float* row = depth_m.ptr<float>(v);
    for (int u = 0; u < depth_m.cols; ++u) {
      // 0 is "no measurement"; NaN, infinities and negative values are not depths.
      if (row[u] >= 0.0f && row[u] < std::numeric_limits<float>::infinity()) continue;
      if (nan_as_missing) {
        row[u] = 0.0f;  // the service reads a float image's NaNs this way (wire/frame_codec.cc)
        continue;
      }
      if (bad_count++ == 0) first_row = v, first_column = u;
    }
  }
  if (bad_count > 0) {
    BadArgument("depth: " + std::to_string(bad_count) + " pixels are NaN, infinite or negative (the first at row " +
                std::to_string(first_row) + ", column " + std::to_string(first_column) +
                "); expected metres >= 0 with 0 = no measurement, or pass nan_as_missing=True to read them as no "
                "measurement");
  }
  return depth_m;
}

FramePtr MakeFrame(const py::handle& rgb_object, const py::handle& depth_object, const py::handle& k_object,
                   const py::object& depth_scale, bool nan_as_missing) {
  const py::array rgb = AsArray(rgb_object, "rgb", "a numpy array");
  if (rgb.ndim() != 3 || rgb.shape(2) != 3 || !HasDtype<uint8_t>(rgb)) {
    BadArgument("rgb: expected a uint8 array of shape (H, W, 3) in RGB order, got a " + Describe(rgb));
  }
  if (rgb.shape(0) < 1 || rgb.shape(1) < 1 || rgb.shape(0) > (1 << 15) || rgb.shape(1) > (1 << 15)) {
    BadArgument("rgb: expected 1 to 32768 rows and columns, got a " + Describe(rgb));
  }
  const int height = static_cast<int>(rgb.shape(0)), width = static_cast<int>(rgb.shape(1));
  auto frame = std::make_shared<Frame>();
  frame->camera = CameraFromK(k_object, width, height);
  frame->depth = DepthFromArray(depth_object, depth_scale, nan_as_missing, width, height);
  frame->rgb = CopyToMat(Contiguous<uint8_t>(rgb), CV_8UC3);
  return frame;
}

// ---------------------------------------------------------------------------------------
// Where the object is: a mask or a box (as the service reads a box: wire/frame_codec.cc).

cv::Mat MaskFromArguments(const Frame& frame, const py::object& mask_object, const py::object& box_object) {
  const int width = frame.camera.width, height = frame.camera.height;
  if (!mask_object.is_none() && !box_object.is_none()) {
    BadArgument("give mask or box, not both (a mask is the object's pixels, a box a detector's x, y, width, height)");
  }
  if (mask_object.is_none() && box_object.is_none()) {
    BadArgument("no mask and no box: give mask= (the object's pixels) or box= (x, y, width, height); to find the "
                "object without either, use find_objects");
  }
  if (!mask_object.is_none()) {
    const py::array array = AsArray(mask_object, "mask", "a numpy array");
    const std::string expected = "a bool or uint8 array of shape (" + std::to_string(height) + ", " +
                                 std::to_string(width) + ") like the frame, non-zero = the object's pixels";
    const bool is_bool = HasDtype<bool>(array);
    if (array.ndim() != 2 || array.shape(0) != height || array.shape(1) != width ||
        !(is_bool || HasDtype<uint8_t>(array))) {
      BadArgument("mask: expected " + expected + ", got a " + Describe(array));
    }
    cv::Mat mask = is_bool ? CopyToMat(Contiguous<bool>(array), CV_8U) : CopyToMat(Contiguous<uint8_t>(array), CV_8U);
    if (is_bool) mask *= 255;  // non-zero = object either way; 0/255 as a mask file holds
    if (cv::countNonZero(mask) == 0) {
      BadArgument("mask: no non-zero pixel; expected the object's visible pixels (to find the object without a "
                  "mask, use find_objects)");
    }
    return mask;
  }
  const py::array array = AsArray(box_object, "box", "(x, y, width, height) in pixels");
  if (array.ndim() != 1 || array.shape(0) != 4) {
    BadArgument("box: expected (x, y, width, height) in pixels, got a " + Describe(array));
  }
  const auto values = py::array_t<double, py::array::forcecast>::ensure(array);
  if (!values) BadArgument("box: expected 4 numbers (x, y, width, height) in pixels, got a " + Describe(array));
  double box[4];
  for (int i = 0; i < 4; ++i) {
    box[i] = values.at(i);
    if (!std::isfinite(box[i]) || box[i] != std::floor(box[i]) || std::abs(box[i]) > 1e9) {
      BadArgument("box: expected whole numbers of pixels (x, y, width, height), got " + std::to_string(box[i]));
    }
  }
  const int64_t x = static_cast<int64_t>(box[0]), y = static_cast<int64_t>(box[1]);
  const int64_t box_width = static_cast<int64_t>(box[2]), box_height = static_cast<int64_t>(box[3]);
  if (box_width <= 0 || box_height <= 0) {
    BadArgument("box: width and height must be > 0 (got " + std::to_string(box_width) + " x " +
                std::to_string(box_height) + ")");
  }
  if (x >= width || y >= height || x + box_width <= 0 || y + box_height <= 0) {
    std::ostringstream text;
    text << "box: (x " << x << ", y " << y << ", width " << box_width << ", height " << box_height
         << ") lies outside the " << width << "x" << height << " image";
    BadArgument(text.str());
  }
  const int x0 = static_cast<int>(std::max<int64_t>(x, 0)), y0 = static_cast<int>(std::max<int64_t>(y, 0));
  const int x1 = static_cast<int>(std::min<int64_t>(x + box_width, width));
  const int y1 = static_cast<int>(std::min<int64_t>(y + box_height, height));
  cv::Mat mask = cv::Mat::zeros(height, width, CV_8U);
  mask(cv::Rect(x0, y0, x1 - x0, y1 - y0)).setTo(255);
  return mask;
}

// The executor of one call: `threads` >= 1 in all, the calling thread included.
std::unique_ptr<Executor> MakeExecutor(int threads) {
  if (threads < 1) BadArgument("threads: expected >= 1, got " + std::to_string(threads));
  if (threads == 1) return std::make_unique<InlineExecutor>();
  return std::make_unique<ThreadPool>(threads);
}

template <typename Options>
void CheckOptions(const Options& options, const char* name) {
  if (const std::string bad = options.Check(); !bad.empty()) BadArgument(std::string(name) + ": " + bad);
}

// ---------------------------------------------------------------------------------------
// Calls. Each converts and checks its arguments with the GIL held, solves without it, and
// converts the answer with it again.

py::dict EstimatePoseCall(const FramePtr& frame, const BankPtr& bank, const py::object& mask_object,
                          const py::object& box_object, const SolverOptions& options, int threads) {
  CheckOptions(options, "options");
  Instance instance{bank->object_id, MaskFromArguments(*frame, mask_object, box_object)};
  const std::unique_ptr<Executor> executor = MakeExecutor(threads);
  PoseResult result;
  {
    py::gil_scoped_release release;
    result = EstimatePose(*frame, instance, *bank, options, executor.get());
  }
  return ResultDict(std::move(result), bank);
}

py::dict TrackPoseCall(const FramePtr& frame, const BankPtr& bank, const py::list& start_objects,
                       const py::object& mask_object, const py::object& box_object, const SolverOptions& options,
                       const TrackSolveOptions& track_options, int threads) {
  CheckOptions(options, "options");
  CheckOptions(track_options, "track");
  if (start_objects.empty()) BadArgument("starts: expected at least one 4x4 cam_from_object pose to start from");
  std::vector<Eigen::Isometry3d> starts;
  for (size_t i = 0; i < start_objects.size(); ++i) {
    starts.push_back(PoseFromArray(start_objects[i], "starts[" + std::to_string(i) + "]"));
  }
  Instance instance{bank->object_id, MaskFromArguments(*frame, mask_object, box_object)};
  const std::unique_ptr<Executor> executor = MakeExecutor(threads);
  PoseResult result;
  {
    py::gil_scoped_release release;
    result = TrackPose(*frame, instance, *bank, options, track_options, starts, executor.get());
  }
  return ResultDict(std::move(result), bank);
}

py::dict UnknownObjectCall(const FramePtr& frame, const std::vector<BankPtr>& banks, const py::object& mask_object,
                           const py::object& box_object, const SolverOptions& options,
                           const IdentifyOptions& identify_options, int threads) {
  CheckOptions(options, "options");
  CheckOptions(identify_options, "identify");
  if (banks.empty()) BadArgument("banks: expected at least one TemplateBank (the candidate objects)");
  std::vector<const TemplateBank*> candidates;
  for (size_t i = 0; i < banks.size(); ++i) {
    if (!banks[i]) BadArgument("banks[" + std::to_string(i) + "]: expected a TemplateBank, got None");
    for (size_t j = 0; j < i; ++j) {
      if (banks[j]->object_id == banks[i]->object_id) {
        BadArgument("banks: object '" + banks[i]->object_id + "' is given twice (banks[" + std::to_string(j) +
                    "] and banks[" + std::to_string(i) + "])");
      }
    }
    candidates.push_back(banks[i].get());
  }
  const cv::Mat mask = MaskFromArguments(*frame, mask_object, box_object);
  const std::unique_ptr<Executor> executor = MakeExecutor(threads);
  IdentifiedPose identified;
  {
    py::gil_scoped_release release;
    identified = EstimatePoseOfUnknownObject(*frame, mask, candidates, options, identify_options, executor.get());
  }
  BankPtr chosen;
  for (const BankPtr& bank : banks) {
    if (bank->object_id == identified.object_id) chosen = bank;
  }
  py::dict d = ResultDict(std::move(identified.result), chosen);
  py::list tried;
  for (const IdentityCandidate& candidate : identified.candidates) {
    py::dict entry;
    entry["object_id"] = candidate.object_id;
    entry["success"] = candidate.success;
    entry["screened_out"] = candidate.screened_out;
    entry["score"] = candidate.score;
    entry["diameter_m"] = candidate.diameter_m;
    entry["extent_m"] = candidate.extent_m;
    entry["extent_allowance_m"] = candidate.extent_allowance_m;
    entry["ms"] = candidate.ms;
    entry["message"] = candidate.message;
    tried.append(entry);
  }
  py::dict identity;
  identity["chosen"] = identified.object_id;
  identity["runner_up_object_id"] = identified.runner_up_id;
  identity["runner_up_object_score"] =
      identified.runner_up_id.empty() ? py::object(py::none()) : py::object(py::float_(identified.runner_up_score));
  identity["ambiguous"] = identified.ambiguous;
  identity["screened_out"] = identified.screened_out;
  identity["total_ms"] = identified.total_ms;
  identity["candidates"] = tried;
  d["identity"] = identity;
  return d;
}

py::tuple FindObjectsCall(const FramePtr& frame, const py::list& request_objects, const SolverOptions& options,
                          const DetectOptions& detect_options, int threads) {
  CheckOptions(options, "options");
  CheckOptions(detect_options, "detect");
  if (request_objects.empty()) BadArgument("objects: expected a list of (TemplateBank, count) pairs, got none");
  std::vector<BankPtr> banks;
  std::vector<DetectRequest> requests;
  for (size_t i = 0; i < request_objects.size(); ++i) {
    const std::string name = "objects[" + std::to_string(i) + "]";
    const py::handle item = request_objects[i];
    BankPtr bank;
    int count = 1;
    if (py::isinstance<TemplateBank>(item)) {
      bank = item.cast<BankPtr>();
    } else if (py::isinstance<py::tuple>(item) && py::len(item) == 2 &&
               py::isinstance<TemplateBank>(item.cast<py::tuple>()[0])) {
      const py::tuple pair = item.cast<py::tuple>();
      bank = pair[0].cast<BankPtr>();
      if (!py::isinstance<py::int_>(pair[1])) {
        BadArgument(name + ": the count must be a whole number >= 1, got " + py::repr(pair[1]).cast<std::string>());
      }
      count = pair[1].cast<int>();
      if (count < 1) BadArgument(name + ": the count must be >= 1, got " + std::to_string(count));
    } else {
      BadArgument(name + ": expected (TemplateBank, count) or a TemplateBank, got " +
                  py::repr(item).cast<std::string>());
    }
    for (size_t j = 0; j < banks.size(); ++j) {
      if (banks[j]->object_id == bank->object_id) {
        BadArgument(name + ": object '" + bank->object_id + "' is asked for twice (ask once, with its count)");
      }
    }
    banks.push_back(bank);
    DetectRequest request;
    request.bank = bank.get();
    request.count = count;
    requests.push_back(request);
  }
  const std::unique_ptr<Executor> executor = MakeExecutor(threads);
  DetectionReport report;
  std::vector<Detection> detections;
  {
    py::gil_scoped_release release;
    detections = DetectObjects(*frame, requests, options, detect_options, executor.get(), &report);
  }
  py::list answers;
  for (Detection& detection : detections) {
    const Proposal& proposal = report.proposals[static_cast<size_t>(detection.proposal)];
    py::dict d = ResultDict(std::move(detection.result), banks[static_cast<size_t>(detection.request)]);
    d["request"] = detection.request;
    d["region"] = MatToArray(std::move(detection.region));
    d["region_box"] = py::make_tuple(proposal.box.x, proposal.box.y, proposal.box.width, proposal.box.height);
    d["region_pixels"] = proposal.pixels;
    answers.append(d);
  }
  py::list trials;
  for (const CandidateTrial& trial : report.trials) {
    py::dict t;
    t["object_id"] = banks[static_cast<size_t>(trial.request)]->object_id;
    t["request"] = trial.request;
    t["region"] = trial.proposal;
    t["pass"] = trial.pass;
    t["size_term"] = trial.size_term;
    t["colour_term"] = trial.colour_term;
    t["shape_term"] = trial.shape_term;
    t["area_ratio"] = trial.area_ratio;
    t["area_term"] = trial.area_term;
    t["rank"] = trial.rank;
    t["solved"] = trial.solved;
    t["success"] = trial.success;
    t["score"] = trial.score;
    t["region_iou"] = trial.region_iou;
    t["confidence"] = trial.confidence;
    t["ms"] = trial.ms;
    trials.append(t);
  }
  py::dict r;
  r["success"] = report.success;
  r["message"] = report.message;
  r["support_planes"] = report.support_planes;
  r["support_pixels"] = report.support.empty() ? 0 : cv::countNonZero(report.support);
  r["segments"] = report.segmentation.segments.size();
  r["explain_away_passes"] = report.explain_away_passes;
  r["regions"] = report.proposals.size();
  r["solves"] = report.solves;
  r["answers"] = report.answers;
  r["suppressed"] = report.suppressed;
  r["trials"] = trials;
  py::dict times;
  times["support"] = report.support_ms;
  times["segment"] = report.segment_ms;
  times["propose"] = report.propose_ms;
  times["rank"] = report.rank_ms;
  times["solve"] = report.solve_ms;
  times["select"] = report.select_ms;
  times["total"] = report.total_ms;
  r["time_ms"] = times;
  return py::make_tuple(answers, r);
}

// ---------------------------------------------------------------------------------------
// Templates

BankPtr BuildTemplatesCall(const std::string& mesh_path, const std::string& object_id, const std::string& units_text,
                           const TemplateBuildOptions& options, int threads, const py::object& progress) {
  if (object_id.empty()) BadArgument("object_id: expected a non-empty id, e.g. 'obj_000001'");
  if (units_text != "mm" && units_text != "m") {
    BadArgument("units: expected 'mm' or 'm' (the units of the mesh file's coordinates), got '" + units_text + "'");
  }
  CheckOptions(options, "options");
  if (!progress.is_none() && !PyCallable_Check(progress.ptr())) {
    BadArgument("progress: expected a callable progress(done, total), got " + py::repr(progress).cast<std::string>());
  }
  const std::unique_ptr<Executor> executor = MakeExecutor(threads);
  // A progress callback that raises stops calling Python; the build then fails and the
  // callback's exception is raised here (the views already started finish first).
  py::object callback_error;
  bool callback_failed = false;
  ProgressCallback callback;
  if (!progress.is_none()) {
    callback = [&](int done, int total) {
      py::gil_scoped_acquire acquire;
      if (callback_failed) throw Error("progress callback raised");
      try {
        progress(done, total);
      } catch (py::error_already_set& error) {
        callback_failed = true;
        callback_error = error.value();
        throw Error("progress callback raised");
      }
    };
  }
  TemplateBank bank;
  try {
    py::gil_scoped_release release;
    const Units units = ParseUnits(units_text);
    // As g6d-build-templates: the mesh first (its errors name the file), then its hash.
    const Mesh mesh = LoadMesh(mesh_path, units);
    const uint64_t mesh_hash = HashFile(mesh_path);
    // Our threads do the fan-out; OpenCV's own pool would only oversubscribe (as the tool).
    const int opencv_threads = cv::getNumThreads();
    cv::setNumThreads(1);
    try {
      bank = BuildTemplateBank(mesh, object_id, options, executor.get(), callback);
    } catch (...) {
      cv::setNumThreads(opencv_threads);
      throw;
    }
    cv::setNumThreads(opencv_threads);
    bank.mesh_hash = mesh_hash;
    bank.mesh_path = mesh_path;
    bank.mesh_units = units;
  } catch (...) {
    if (callback_failed) {
      PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(callback_error.ptr())), callback_error.ptr());
      throw py::error_already_set();
    }
    throw;
  }
  return std::make_shared<TemplateBank>(std::move(bank));
}

BankPtr LoadCacheCall(const std::string& path, const std::string& mesh_path) {
  py::gil_scoped_release release;
  return std::make_shared<TemplateBank>(mesh_path.empty() ? ReadTemplateCache(path)
                                                          : ReadTemplateCacheChecked(path, mesh_path));
}

// ---------------------------------------------------------------------------------------
// Pictures and image files

py::object DrawOverlayCall(const FramePtr& frame, const std::vector<std::pair<BankPtr, py::object>>& poses,
                          const std::vector<std::string>& labels) {
  std::vector<std::pair<BankPtr, Eigen::Isometry3d>> drawn;
  for (size_t i = 0; i < poses.size(); ++i) {
    drawn.emplace_back(poses[i].first, PoseFromArray(poses[i].second, "results[" + std::to_string(i) + "]"));
  }
  cv::Mat canvas = frame->rgb.clone();
  {
    py::gil_scoped_release release;
    RasterImage raster;
    const OverlayStyle style;
    for (size_t i = 0; i < drawn.size(); ++i) {
      const TemplateBank& bank = *drawn[i].first;
      const OverlayModel model{&bank.online_mesh, bank.bounding_box.center(), bank.diameter_m};
      const PoseOverlayReport report = DrawPoseOverlay(model, frame->camera, drawn[i].second, style, &canvas, &raster);
      if (i < labels.size() && !labels[i].empty() && report.silhouette_pixels > 0) {
        DrawLabel(labels[i], report.silhouette_box.tl(), style.contour_color, style.label_scale, &canvas);
      }
    }
  }
  return MatToArray(std::move(canvas));
}

py::object ReadImageCall(const std::string& path, const std::string& mode) {
  int flags = cv::IMREAD_UNCHANGED;
  if (mode == "rgb") {
    flags = cv::IMREAD_COLOR;  // as g6d-solve reads --rgb
  } else if (mode == "gray") {
    flags = cv::IMREAD_GRAYSCALE;  // as g6d-solve reads --mask
  } else if (mode != "unchanged") {
    BadArgument("mode: expected 'unchanged', 'rgb' or 'gray', got '" + mode + "'");
  }
  cv::Mat image;
  {
    py::gil_scoped_release release;
    image = cv::imread(path, flags);
    if (image.empty()) G6D_THROW("read_image: cannot read an image from '" << path << "'");
    if (image.channels() == 3) cv::cvtColor(image, image, cv::COLOR_BGR2RGB);
    if (image.channels() == 4) cv::cvtColor(image, image, cv::COLOR_BGRA2RGB);
  }
  return MatToArray(std::move(image));
}

void WriteImageCall(const std::string& path, const py::handle& object) {
  const py::array array = AsArray(object, "image", "a numpy array");
  const bool colour = array.ndim() == 3 && array.shape(2) == 3;
  if (!(array.ndim() == 2 || colour) || !(HasDtype<uint8_t>(array) || HasDtype<uint16_t>(array))) {
    BadArgument("image: expected a uint8 or uint16 array of shape (H, W) or (H, W, 3) in RGB order, got a " +
                Describe(array));
  }
  const bool wide = HasDtype<uint16_t>(array);
  const int type = CV_MAKETYPE(wide ? CV_16U : CV_8U, colour ? 3 : 1);
  cv::Mat image = wide ? CopyToMat(Contiguous<uint16_t>(array), type) : CopyToMat(Contiguous<uint8_t>(array), type);
  py::gil_scoped_release release;
  if (colour) cv::cvtColor(image, image, cv::COLOR_RGB2BGR);
  bool written = false;
  try {
    written = cv::imwrite(path, image);
  } catch (const cv::Exception& e) {
    G6D_THROW("write_image: cannot write '" << path << "': " << e.what());
  }
  if (!written) G6D_THROW("write_image: cannot write '" << path << "' (a known image extension, a writable folder?)");
}

// The C++ side of bench/python_overhead.py: `repeats` EstimatePose calls in a C++ loop on
// the same frame, mask and options, as a C++ caller makes them (the executor made per call,
// as the Python call makes it); per call (wall time, the solve's own total_ms), ms.
std::vector<std::pair<double, double>> BenchEstimatePose(const FramePtr& frame, const BankPtr& bank,
                                                         const py::object& mask_object, const SolverOptions& options,
                                                         int threads, int repeats) {
  CheckOptions(options, "options");
  const Instance instance{bank->object_id, MaskFromArguments(*frame, mask_object, py::none())};
  std::vector<std::pair<double, double>> ms;
  py::gil_scoped_release release;
  for (int i = 0; i < repeats; ++i) {
    const auto start = std::chrono::steady_clock::now();
    const std::unique_ptr<Executor> executor =
        threads > 1 ? std::unique_ptr<Executor>(new ThreadPool(threads)) : std::make_unique<InlineExecutor>();
    const PoseResult result = EstimatePose(*frame, instance, *bank, options, executor.get());
    ms.emplace_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count(),
                    result.stages.total_ms);
  }
  return ms;
}

}  // namespace
}  // namespace g6d::python

PYBIND11_MODULE(_core, module) {
  using namespace g6d;          // NOLINT: the module's body names lib/'s types
  using namespace g6d::python;  // NOLINT: and this file's calls
  module.doc() = "The compiled core of g6d; use the package g6d (its functions document frames and units).";
  py::register_exception<Error>(module, "Error", PyExc_RuntimeError);
  BindOptions(module);

  py::class_<Frame, FramePtr>(module, "Frame",
                              "One RGB-D frame as the solver sees it (built by g6d.Frame; immutable).")
      .def(py::init(&MakeFrame), py::arg("rgb"), py::arg("depth"), py::arg("K"), py::arg("depth_scale") = py::none(),
           py::arg("nan_as_missing") = false)
      .def_property_readonly("width", [](const Frame& f) { return f.camera.width; }, "image width, pixels")
      .def_property_readonly("height", [](const Frame& f) { return f.camera.height; }, "image height, pixels")
      .def_property_readonly("K", [](const Frame& f) {
        py::array_t<double> k({3, 3});
        auto out = k.mutable_unchecked<2>();
        const Eigen::Matrix3d matrix = f.camera.K();
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 3; ++c) out(r, c) = matrix(r, c);
        }
        return k;
      }, "intrinsics 3x3, pixels (pixel (u, v) centred at (u + 0.5, v + 0.5))")
      .def_property_readonly("rgb", [](py::object self) { return ReadOnlyView(self.cast<const Frame&>().rgb, self); },
                             "the colour image, uint8 (H, W, 3), RGB, read-only")
      .def_property_readonly("depth",
                             [](py::object self) { return ReadOnlyView(self.cast<const Frame&>().depth, self); },
                             "depth along the optical axis, float32 (H, W), metres, 0 = no measurement, read-only");

  py::class_<TemplateBank, BankPtr>(module, "TemplateBank",
                                    "One object's template bank (g6d.build_templates, g6d.load_cache).")
      .def_readonly("object_id", &TemplateBank::object_id, "the object's id, e.g. 'obj_000005'")
      .def_readonly("diameter_m", &TemplateBank::diameter_m, "the object's diameter, metres")
      .def_readonly("mesh_path", &TemplateBank::mesh_path, "the mesh the bank was built from (informational)")
      .def_readonly("mesh_hash", &TemplateBank::mesh_hash, "FNV-1a 64 hash of the mesh file's bytes")
      .def_property_readonly("mesh_units", [](const TemplateBank& b) { return std::string(UnitsName(b.mesh_units)); },
                             "units of the mesh file, 'mm' or 'm'")
      .def_property_readonly("num_templates", [](const TemplateBank& b) { return b.templates.size(); },
                             "N_T, the number of templates")
      .def_property_readonly("num_keypoints", &TemplateBank::NumKeypoints, "keypoints over all templates")
      .def_property_readonly("bounding_box_m", [](const TemplateBank& b) {
        py::array_t<double> box({2, 3});
        auto out = box.mutable_unchecked<2>();
        for (int i = 0; i < 3; ++i) out(0, i) = b.bounding_box.min()[i], out(1, i) = b.bounding_box.max()[i];
        return box;
      }, "the mesh's axis-aligned box in the object frame, metres: [min xyz, max xyz]")
      .def_property_readonly("has_appearance", [](const TemplateBank& b) { return !b.appearance.Empty(); },
                             "the bank holds coloured appearance samples (appearance tie-break)")
      .def_property_readonly("options", [](const TemplateBank& b) { return b.options; },
                             "the TemplateBuildOptions it was built with (a copy)")
      .def("save", [](const TemplateBank& bank, const std::string& path, int zstd_level) {
        py::gil_scoped_release release;
        WriteTemplateCache(bank, path, zstd_level);
      }, py::arg("path"), py::arg("zstd_level") = 9,
           "Writes the bank to a cache file (atomically: a temporary file, then a rename), as "
           "g6d-build-templates does. Raises g6d.Error when it cannot write.")
      .def("__repr__", [](const TemplateBank& b) {
        std::ostringstream text;
        text << "<g6d.TemplateBank " << b.object_id << ": " << b.templates.size() << " templates, diameter "
             << b.diameter_m * 1000.0 << " mm>";
        return text.str();
      });

  module.def("build_templates", &BuildTemplatesCall, py::arg("mesh_path"), py::arg("object_id"), py::arg("units"),
             py::arg("options"), py::arg("threads"), py::arg("progress"));
  module.def("load_cache", &LoadCacheCall, py::arg("path"), py::arg("mesh_path") = std::string());
  module.def("estimate_pose", &EstimatePoseCall, py::arg("frame"), py::arg("bank"), py::arg("mask"), py::arg("box"),
             py::arg("options"), py::arg("threads"));
  module.def("track_pose", &TrackPoseCall, py::arg("frame"), py::arg("bank"), py::arg("starts"), py::arg("mask"),
             py::arg("box"), py::arg("options"), py::arg("track"), py::arg("threads"));
  module.def("estimate_pose_of_unknown_object", &UnknownObjectCall, py::arg("frame"), py::arg("banks"),
             py::arg("mask"), py::arg("box"), py::arg("options"), py::arg("identify"), py::arg("threads"));
  module.def("find_objects", &FindObjectsCall, py::arg("frame"), py::arg("objects"), py::arg("options"),
             py::arg("detect"), py::arg("threads"));
  module.def("draw_overlay", &DrawOverlayCall, py::arg("frame"), py::arg("poses"), py::arg("labels"));
  module.def("read_image", &ReadImageCall, py::arg("path"), py::arg("mode"));
  module.def("write_image", &WriteImageCall, py::arg("path"), py::arg("image"));
  module.def("_bench_estimate_pose", &BenchEstimatePose, py::arg("frame"), py::arg("bank"), py::arg("mask"),
             py::arg("options"), py::arg("threads"), py::arg("repeats"));
}
