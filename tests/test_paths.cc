#include "test_paths.h"

namespace g6d::test {

std::string SourceDir() { return G6D_SOURCE_DIR; }
std::string BinaryDir() { return G6D_BINARY_DIR; }
std::string SharedDataRoot() { return G6D_SHARED_DATA_DIR; }

}  // namespace g6d::test
