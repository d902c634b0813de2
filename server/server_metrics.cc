// pf-server's metrics: see server_metrics.h.
#include "server/server_metrics.h"

#include <string>

namespace pf {
namespace {

ServerMetrics MakeMetrics(MetricsRegistry& registry) {
  ServerMetrics m;
  m.cache_hits = &registry.Counter("pf_scene_cache_hits_total",
                                   "CreateScene calls answered by a scene already built.");
  m.cache_misses = &registry.Counter("pf_scene_cache_misses_total",
                                     "CreateScene calls that started a reconstruction.");
  m.heartbeats =
      &registry.Counter("pf_worker_heartbeats_total", "Heartbeats received from workers.");
  m.leases_expired = &registry.Counter("pf_leases_expired_total",
                                       "Task leases that expired (worker died or hung).");
  for (JobKind kind : {JobKind::kReconstruct, JobKind::kRender}) {
    const int k = static_cast<int>(kind);
    const MetricLabels labels = {{"kind", JobKindName(kind)}};
    m.tasks_completed[k] = &registry.Counter(
        "pf_tasks_completed_total", "Tasks (reconstructions, render chunks) completed.", labels);
    m.tasks_failed[k] = &registry.Counter(
        "pf_tasks_failed_total", "Task attempts that failed (reported by a worker).", labels);
    m.job_seconds[k] = &registry.Histogram("pf_job_duration_seconds",
                                           "Wall time of jobs from creation to success.",
                                           DurationBuckets(), labels);
  }
  return m;
}

ServerMetrics* g_metrics = nullptr;

}  // namespace

ServerMetrics& RegisterServerMetrics(JobStore* store) {
  MetricsRegistry& registry = DefaultMetrics();
  static ServerMetrics metrics = MakeMetrics(registry);
  g_metrics = &metrics;
  for (JobKind kind : {JobKind::kReconstruct, JobKind::kRender}) {
    const MetricLabels labels = {{"kind", JobKindName(kind)}};
    registry.CallbackGauge("pf_queue_depth",
                           "Tasks waiting for a worker, by kind (what autoscaling reads).", labels,
                           [store, kind] {
                             absl::StatusOr<int> n = store->CountQueuedTasks(kind);
                             return n.ok() ? static_cast<double>(*n) : -1.0;
                           });
    registry.CallbackGauge("pf_jobs_running", "Jobs with a task leased or done, not yet ended.",
                           labels, [store, kind] {
                             absl::StatusOr<int> n = store->CountJobs(kind, JobState::kRunning);
                             return n.ok() ? static_cast<double>(*n) : -1.0;
                           });
  }
  return metrics;
}

ServerMetrics& GetServerMetrics() {
  if (g_metrics != nullptr) return *g_metrics;
  static MetricsRegistry* unused = new MetricsRegistry();
  static ServerMetrics metrics = MakeMetrics(*unused);
  return metrics;
}

}  // namespace pf
