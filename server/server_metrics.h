// pf-server's Prometheus metrics (docs/DEPLOY.md lists them): queue depth
// and running jobs read from the store at each scrape, and counters the RPC
// handlers bump. Every replica reports the whole store's queue, so any one
// of them can drive autoscaling.
#ifndef POINTFORWARD_SERVER_SERVER_METRICS_H_
#define POINTFORWARD_SERVER_SERVER_METRICS_H_

#include "common/metrics.h"
#include "server/store/job_store.h"

namespace pf {

struct ServerMetrics {
  pf::Counter* cache_hits;
  pf::Counter* cache_misses;
  pf::Counter* heartbeats;
  pf::Counter* leases_expired;
  pf::Counter* tasks_completed[2];  // By JobKind.
  pf::Counter* tasks_failed[2];
  pf::Histogram* job_seconds[2];
};

// Registers the metrics on DefaultMetrics(), the store-backed gauges reading
// `store` (which must outlive every scrape), and returns them.
ServerMetrics& RegisterServerMetrics(JobStore* store);

// The metrics registered by RegisterServerMetrics, or metrics on a private
// registry when it was not called (tests hosting the services in-process).
ServerMetrics& GetServerMetrics();

}  // namespace pf

#endif  // POINTFORWARD_SERVER_SERVER_METRICS_H_
