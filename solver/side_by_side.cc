#include "solver/side_by_side.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <exception>
#include <system_error>
#include <thread>
#include <vector>

namespace shadowsg {
namespace {

struct Lending {
  int threads = 1;              // in all
  std::atomic<int> workers{1};  // threads that run jobs: at most one a job
  std::atomic<int> done{0};     // workers with no job left
};

// The lending of the job running on this thread (none outside a job).
thread_local Lending* current = nullptr;

}  // namespace

void TakeLentThreads() {
  if (current == nullptr) return;
  const int running =
      std::max(1, current->workers.load(std::memory_order_relaxed) - current->done.load(std::memory_order_relaxed));
  const int want = std::max(1, current->threads / running);
  if (omp_get_max_threads() != want) omp_set_num_threads(want);
}

void RunSideBySide(int jobs, int threads, const std::function<void(int)>& job) {
  if (jobs <= 0) return;
  Lending lending;
  lending.threads = std::max(1, threads);
  const int workers = std::min(lending.threads, jobs);
  lending.workers = workers;
  std::atomic<int> next{0};
  std::vector<std::exception_ptr> failed(static_cast<size_t>(jobs));
  Lending* const outer = current;  // a caller that is itself a job
  auto work = [&] {
    current = &lending;
    for (int j; (j = next.fetch_add(1)) < jobs;) {
      TakeLentThreads();
      try {
        job(j);
      } catch (...) {
        failed[static_cast<size_t>(j)] = std::current_exception();
      }
    }
    current = nullptr;
    lending.done.fetch_add(1, std::memory_order_relaxed);
  };
  const int caller_threads = omp_get_max_threads();
  std::vector<std::thread> helpers;
  for (int t = 1; t < workers; ++t) {
    try {
      helpers.emplace_back(work);
    } catch (const std::system_error&) {  // no thread to be had: the others share its jobs
      lending.workers.fetch_sub(1);
    }
  }
  work();
  for (std::thread& t : helpers) t.join();
  current = outer;
  omp_set_num_threads(caller_threads);
  for (const std::exception_ptr& e : failed)
    if (e) std::rethrow_exception(e);
}

}  // namespace shadowsg
