// RunSideBySide: every job once, one thread each, the caller's thread count
// back afterwards, failures rethrown; a finished thread is lent to the job
// still running.
#include "solver/side_by_side.h"

#include <omp.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace shadowsg {
namespace {

TEST(SideBySide, RunsEveryJobOnceOnOneThreadEach) {
  const int saved = omp_get_max_threads();
  omp_set_num_threads(3);
  for (int jobs : {1, 2, 5}) {
    for (int threads : {1, 2, 4}) {
      std::vector<std::atomic<int>> runs(static_cast<size_t>(jobs));
      std::mutex mutex;
      std::set<std::thread::id> ids;
      std::vector<int> team(static_cast<size_t>(jobs), 0);
      RunSideBySide(jobs, threads, [&](int j) {
        ++runs[static_cast<size_t>(j)];
        team[static_cast<size_t>(j)] = omp_get_max_threads();
        std::lock_guard<std::mutex> lock(mutex);
        ids.insert(std::this_thread::get_id());
      });
      for (int j = 0; j < jobs; ++j) EXPECT_EQ(runs[static_cast<size_t>(j)], 1) << jobs << " jobs, job " << j;
      EXPECT_LE(static_cast<int>(ids.size()), std::min(jobs, threads));
      // A job alone has every thread; side by side, its share.
      if (jobs == 1) EXPECT_EQ(team[0], threads);
      for (int t : team) {
        EXPECT_GE(t, 1);
        EXPECT_LE(t, threads);
      }
      EXPECT_EQ(omp_get_max_threads(), 3) << "the caller's thread count is restored";
    }
  }
  omp_set_num_threads(saved);
}

TEST(SideBySide, AFinishedThreadIsLentToTheJobStillRunning) {
  std::atomic<bool> first_done{false};
  int before = 0, after = 0;
  bool widened = false;
  RunSideBySide(2, 2, [&](int j) {
    if (j == 0) {
      // Job 0 waits for job 1 to have started on the other thread.
      while (!first_done.load()) std::this_thread::yield();
      return;
    }
    TakeLentThreads();
    before = omp_get_max_threads();
    first_done = true;
    // The other thread is lent once job 0 has returned: poll for it.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (!widened && std::chrono::steady_clock::now() < deadline) {
      TakeLentThreads();
      widened = omp_get_max_threads() == 2;
      std::this_thread::yield();
    }
    after = omp_get_max_threads();
    // The job's parallel loops now run on two threads.
    int team = 0;
#pragma omp parallel
    {
#pragma omp single
      team = omp_get_num_threads();
    }
    EXPECT_EQ(team, 2);
  });
  EXPECT_EQ(before, 1);
  EXPECT_TRUE(widened);
  EXPECT_EQ(after, 2);
}

TEST(SideBySide, OutsideAJobTakingLentThreadsChangesNothing) {
  const int saved = omp_get_max_threads();
  omp_set_num_threads(3);
  TakeLentThreads();
  EXPECT_EQ(omp_get_max_threads(), 3);
  omp_set_num_threads(saved);
}

TEST(SideBySide, AFailedJobIsRethrownAfterTheOthersRan) {
  std::atomic<int> ran{0};
  EXPECT_THROW(RunSideBySide(4, 2,
                             [&](int j) {
                               ++ran;
                               if (j == 1) throw std::runtime_error("job 1");
                             }),
               std::runtime_error);
  EXPECT_EQ(ran, 4);
}

}  // namespace
}  // namespace shadowsg
