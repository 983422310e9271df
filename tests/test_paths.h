#pragma once
/// @file test_paths.h
/// Where the tests find the checkout, the build tree and the shared data. The paths are
/// compiled into one small file (test_paths.cc) instead of every test, so that a checkout
/// in another folder still reuses ccache's objects for the tests themselves.

#include <string>

namespace g6d::test {

std::string SourceDir();       ///< the checkout (CMake's PROJECT_SOURCE_DIR)
std::string BinaryDir();       ///< the build tree (PROJECT_BINARY_DIR)
std::string SharedDataRoot();  ///< ../shared/data beside the checkout, whether it exists or not

}  // namespace g6d::test
