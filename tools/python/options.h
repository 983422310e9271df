#pragma once
/// @file options.h
/// The options structs of lib/ as classes of the Python module (options.cc).

#include <pybind11/pybind11.h>

namespace g6d::python {

/// Adds SolverOptions, DetectOptions, IdentifyOptions, TrackSolveOptions,
/// TemplateBuildOptions, their nested structs and the enums MaskTrust and PnpMinimalSolver
/// to `module`.
void BindOptions(pybind11::module_& module);

}  // namespace g6d::python
