#pragma once
/// @file types.h
/// What crosses the Python boundary as data (types.cc): the options structs of lib/ as
/// classes, OpenCV images and Eigen poses as numpy arrays, PoseResult as a dictionary.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <initializer_list>
#include <memory>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "solver/pipeline.h"
#include "templates/template_bank.h"

namespace g6d::python {

using BankPtr = std::shared_ptr<TemplateBank>;

/// Adds SolverOptions, DetectOptions, IdentifyOptions, TrackSolveOptions,
/// TemplateBuildOptions, their nested structs and the enums MaskTrust and PnpMinimalSolver
/// to `module`.
void BindOptions(pybind11::module_& module);

/// A numpy array that owns `mat` (moved to the heap; no copy of the pixels): (rows, cols)
/// or (rows, cols, channels); None for an empty mat.
pybind11::object MatToArray(cv::Mat mat);

/// A read-only numpy view of `mat` (CV_8U or CV_32F) that keeps `owner`, the Python object
/// holding it, alive.
pybind11::array ReadOnlyView(const cv::Mat& mat, const pybind11::handle& owner);

/// A 4x4 float64 array of `matrix`.
pybind11::array_t<double> MatrixToArray(const Eigen::Matrix4d& matrix);

/// A 1D float64 array of `values`.
pybind11::array_t<double> VectorToArray(std::initializer_list<double> values);

/// The fields of g6d.PoseResult: pose (4x4 and position / quaternion as g6d-solve writes
/// them), S_A, confidence, flags, runner-up, corrected mask, the stage report with its
/// times; `bank` answered (null: none, object_id '').
pybind11::dict ResultDict(PoseResult result, const BankPtr& bank);

}  // namespace g6d::python
