#pragma once
/// @file stats.h
/// Small summary statistics shared by the service, the replay tool and the benchmarks.

#include <vector>

namespace g6d {

/// Percentile `q` in [0, 1] of `values` by nearest rank (the smallest value with at least
/// q of the values at or below it); 0 for an empty set.
double Percentile(std::vector<double> values, double q);

}  // namespace g6d
