// A fixed pool of worker threads and a blocking parallel-for on it.
//
// The pool is the one place the engine gets threads from: hot loops call
// ParallelFor() on DefaultThreadPool() rather than starting threads. Work is
// split into contiguous chunks whose boundaries depend only on the range and
// the grain, so a loop whose chunks write disjoint outputs is deterministic.
#ifndef POINTFORWARD_COMMON_THREAD_POOL_H_
#define POINTFORWARD_COMMON_THREAD_POOL_H_

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace pf {

class ThreadPool {
 public:
  // Starts `num_threads` workers (0: every task runs on the thread that
  // schedules it, every ParallelFor on its caller).
  explicit ThreadPool(int num_threads);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int num_threads() const { return static_cast<int>(workers_.size()); }

  // Queues `task` to run on a worker.
  void Schedule(std::function<void()> task);

  // Calls `body(chunk_begin, chunk_end)` over [begin, end) split into chunks of
  // `grain` items (the last may be shorter), on the workers and the calling
  // thread, and returns when all chunks are done. Chunk boundaries are fixed by
  // (begin, end, grain). Calls from inside a pool task run serially.
  void ParallelFor(int64_t begin, int64_t end, int64_t grain,
                   const std::function<void(int64_t, int64_t)>& body);

 private:
  void WorkerLoop();

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> queue_;
  bool stopping_ = false;
};

// Returns the process-wide pool. N threads work in a ParallelFor on it (N - 1
// workers and the caller), N set by SetDefaultThreadCount() or, if that was
// never called, by the PF_THREADS environment variable or the number of
// hardware threads.
ThreadPool& DefaultThreadPool();

// Sets the size of the pool DefaultThreadPool() creates. Has no effect once the
// pool exists; returns false then.
bool SetDefaultThreadCount(int num_threads);

}  // namespace pf

#endif  // POINTFORWARD_COMMON_THREAD_POOL_H_
