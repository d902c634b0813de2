// ThreadPool implementation.
#include "common/thread_pool.h"

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <exception>
#include <memory>

namespace pf {
namespace {

thread_local bool t_in_pool_task = false;

std::mutex g_default_mutex;
std::unique_ptr<ThreadPool> g_default_pool;
int g_default_threads = 0;

}  // namespace

ThreadPool::ThreadPool(int num_threads) {
  num_threads = std::max(0, num_threads);
  workers_.reserve(num_threads);
  for (int i = 0; i < num_threads; ++i) {
    workers_.emplace_back([this] { WorkerLoop(); });
  }
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  for (std::thread& worker : workers_) worker.join();
}

void ThreadPool::Schedule(std::function<void()> task) {
  if (workers_.empty()) {  // No workers: the scheduling thread runs it.
    const bool was_in_task = t_in_pool_task;
    t_in_pool_task = true;
    task();
    t_in_pool_task = was_in_task;
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.push_back(std::move(task));
  }
  cv_.notify_one();
}

void ThreadPool::WorkerLoop() {
  t_in_pool_task = true;
  while (true) {
    std::function<void()> task;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping_ and drained.
      task = std::move(queue_.front());
      queue_.pop_front();
    }
    task();
  }
}

void ThreadPool::ParallelFor(int64_t begin, int64_t end, int64_t grain,
                             const std::function<void(int64_t, int64_t)>& body) {
  if (end <= begin) return;
  grain = std::max<int64_t>(1, grain);
  const int64_t num_chunks = (end - begin + grain - 1) / grain;
  if (num_chunks == 1 || t_in_pool_task) {
    for (int64_t c = 0; c < num_chunks; ++c) {
      body(begin + c * grain, std::min(end, begin + (c + 1) * grain));
    }
    return;
  }
  // Shared state lives on this stack frame; we wait for every helper to finish.
  struct Shared {
    std::atomic<int64_t> next{0};
    std::mutex mutex;
    std::condition_variable done_cv;
    int active = 0;
    std::exception_ptr error;
  } shared;
  auto run_chunks = [&] {
    while (true) {
      const int64_t c = shared.next.fetch_add(1);
      if (c >= num_chunks) return;
      try {
        body(begin + c * grain, std::min(end, begin + (c + 1) * grain));
      } catch (...) {
        std::lock_guard<std::mutex> lock(shared.mutex);
        if (!shared.error) shared.error = std::current_exception();
      }
    }
  };
  const int helpers = static_cast<int>(std::min<int64_t>(num_threads(), num_chunks - 1));
  shared.active = helpers;
  for (int i = 0; i < helpers; ++i) {
    Schedule([&] {
      run_chunks();
      std::lock_guard<std::mutex> lock(shared.mutex);
      if (--shared.active == 0) shared.done_cv.notify_all();
    });
  }
  const bool was_in_task = t_in_pool_task;
  t_in_pool_task = true;  // Nested loops inside `body` run serially.
  run_chunks();
  t_in_pool_task = was_in_task;
  std::unique_lock<std::mutex> lock(shared.mutex);
  shared.done_cv.wait(lock, [&] { return shared.active == 0; });
  if (shared.error) std::rethrow_exception(shared.error);
}

ThreadPool& DefaultThreadPool() {
  std::lock_guard<std::mutex> lock(g_default_mutex);
  if (!g_default_pool) {
    int n = g_default_threads;
    if (n <= 0) {
      const char* env = std::getenv("PF_THREADS");
      n = env != nullptr ? std::atoi(env) : 0;
    }
    if (n <= 0) n = static_cast<int>(std::thread::hardware_concurrency());
    // The caller of ParallelFor also works, so the pool holds one fewer: n
    // threads work in all.
    g_default_pool = std::make_unique<ThreadPool>(n - 1);
  }
  return *g_default_pool;
}

bool SetDefaultThreadCount(int num_threads) {
  std::lock_guard<std::mutex> lock(g_default_mutex);
  if (g_default_pool) return false;
  g_default_threads = num_threads;
  return true;
}

}  // namespace pf
