#pragma once
// Tasks run side by side on the one pool, each timed: the pipeline's way of
// running map encoders, the solve and the fabric measurement together.
//
// OpenCV's pool runs one parallel region at a time: a parallel loop inside
// a task (or on another thread while tasks run) runs on its own thread, one
// chunk after another. So a stage is either tasks side by side, each serial
// inside, or one task whose loops use every thread; never both at once.

#include <functional>
#include <string>
#include <vector>

#include "psrig/base/error.h"
#include "psrig/base/log.h"

namespace psrig::processing {

struct StageTask {
  std::string name;
  std::function<Status()> run;
  double* ms = nullptr;  // where its time is added, when given
};

// Every task on the pool, the first (in the list) taken first; the first
// failure in the list's order is the error. Each task's time is logged
// (debug) and added to its `ms`.
[[nodiscard]] Status run_tasks(const std::vector<StageTask>& tasks, spdlog::logger& log);

}  // namespace psrig::processing
