// Jobs run side by side, one thread each, where a thread whose jobs are done
// lends itself to the jobs still running.
//
// Each job runs on a thread of its own as an OpenMP initial thread (the
// calling thread or a std::thread) whose parallel loops run on that thread
// alone, so the jobs do not compete for cores. Once no job is left to start,
// a thread that finishes is lent: each job still running widens its parallel
// loops to its share of the lent threads at its next TakeLentThreads(), on
// its thread's own OpenMP pool (no nested teams, which libgomp would start
// and join a thread for at every loop). Two restarts side by side on two
// cores finish 0.05-0.7 s apart (balanced, stop 62); the one left ran alone
// on one core.
//
// The solver's parallel loops cut their work into pieces that do not depend
// on the thread count, so a job's result does not depend on when threads are
// lent to it: only its time does.
#pragma once

#include <functional>

namespace shadowsg {

// Runs job(0), ..., job(jobs - 1), in that order of starting, on `threads`
// threads at most; returns when all are done, rethrowing the first job's
// (lowest index) exception if any threw. The caller's OpenMP thread count is
// restored.
void RunSideBySide(int jobs, int threads, const std::function<void(int)>& job);

// Inside a job of RunSideBySide: its parallel loops from here on run on its
// thread and its share of the lent threads. Elsewhere it does nothing. Call
// it between pieces of work of a few milliseconds or more.
void TakeLentThreads();

}  // namespace shadowsg
