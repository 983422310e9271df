#pragma once
/// @file synthetic_scene.h
/// The synthetic scene generator now lives in lib/synthetic (the benchmarks use it too);
/// this header keeps the tests' test:: names for it.

#include "synthetic/synthetic_scene.h"

namespace g6d::test {
using namespace g6d::synthetic;  // NOLINT(build/namespaces)
}  // namespace g6d::test
