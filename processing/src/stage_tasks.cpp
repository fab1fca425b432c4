#include "stage_tasks.h"

#include <chrono>
#include <exception>
#include <optional>

#include "psrig/base/parallel.h"

namespace psrig::processing {

Status run_tasks(const std::vector<StageTask>& tasks, spdlog::logger& log) {
  std::vector<std::optional<Error>> errors(tasks.size());
  parallel_chunks(static_cast<int>(tasks.size()), 1, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const auto start = std::chrono::steady_clock::now();
      try {
        if (auto ok = tasks[i].run(); !ok) errors[i] = ok.error();
      } catch (const std::exception& e) {
        errors[i] = internal_error(tasks[i].name + ": " + e.what());
      }
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
      if (tasks[i].ms != nullptr) *tasks[i].ms += ms;
      log.trace("{}: {:.0f} ms", tasks[i].name, ms);
    }
  });
  for (const auto& error : errors)
    if (error) return std::unexpected(*error);
  return {};
}

}  // namespace psrig::processing
