#pragma once
/// @file soak_runner.h
/// g6d-bench-soak's run: the service started, the load sent at a fixed rate while the
/// process is sampled, the drain, SIGTERM, the report.

#include <csignal>

#include "soak_options.h"

namespace g6d::soak {

/// Runs the soak and writes its outputs. `interrupted` (set by a signal handler) ends the
/// load early; the service is still stopped and the summary written. Returns the exit
/// code: 0 pass, 1 a criterion failed or the service died while starting, 2 the service
/// never became ready. Throws g6d::Error when the run cannot be set up.
int RunSoak(const SoakOptions& options, const volatile std::sig_atomic_t* interrupted);

}  // namespace g6d::soak
