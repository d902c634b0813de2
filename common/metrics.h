// Process metrics: counters, gauges and histograms in a registry that renders
// the Prometheus text exposition format (version 0.0.4).
//
//   pf::Counter& done = pf::DefaultMetrics().Counter(
//       "pf_tasks_completed_total", "Tasks completed.", {{"kind", "render"}});
//   done.Inc();
//   std::string text = pf::DefaultMetrics().Render();
//
// A registry hands out references to metrics that live as long as the
// registry, so hot code looks a metric up once and keeps the reference;
// updating a counter or gauge is one atomic operation. Asking again for the
// same name and label values returns the same metric. All methods are
// thread-safe.
//
// Misuse is a programmer error and aborts with a message: an invalid metric or
// label name, one name registered with two types, label names that differ
// between two calls for the same name, histogram bounds not increasing.
#ifndef POINTFORWARD_COMMON_METRICS_H_
#define POINTFORWARD_COMMON_METRICS_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace pf {

// Label name/value pairs of one metric, in the order they are rendered. Every
// metric of a family has the same label names in the same order.
using MetricLabels = std::vector<std::pair<std::string, std::string>>;

// A value that only goes up (events, bytes, seconds spent).
class Counter {
 public:
  // Adds `n`; a negative `n` is ignored (counters never go down).
  void Inc(double n = 1);
  double Value() const { return value_.load(std::memory_order_relaxed); }

 private:
  std::atomic<double> value_{0};
};

// A value that goes up and down (jobs running, bytes in use).
class Gauge {
 public:
  void Set(double value) { value_.store(value, std::memory_order_relaxed); }
  void Inc(double n = 1) { value_.fetch_add(n, std::memory_order_relaxed); }
  void Dec(double n = 1) { value_.fetch_sub(n, std::memory_order_relaxed); }
  double Value() const { return value_.load(std::memory_order_relaxed); }

 private:
  std::atomic<double> value_{0};
};

// Counts observations into buckets with fixed upper bounds, plus their sum.
class Histogram {
 public:
  // What Snapshot() returns; `bucket_counts[i]` counts observations
  // <= bounds[i] (cumulative), the last entry is the +Inf bucket (== count).
  struct Counts {
    std::vector<uint64_t> bucket_counts;
    double sum = 0;
    uint64_t count = 0;
  };

  // `bounds` must be strictly increasing and finite; +Inf is implicit.
  explicit Histogram(std::vector<double> bounds);

  // Records one observation of `value`.
  void Observe(double value);
  const std::vector<double>& bounds() const { return bounds_; }
  // Returns a consistent copy of the counts (count == the +Inf bucket).
  Counts Snapshot() const;

 private:
  const std::vector<double> bounds_;
  mutable std::mutex mutex_;
  std::vector<uint64_t> bucket_counts_;  // [bounds_.size() + 1], not cumulative
  double sum_ = 0;
  uint64_t count_ = 0;
};

// Default histogram bounds for durations in seconds, 5 ms to 10 minutes.
std::vector<double> DurationBuckets();

class MetricsRegistry {
 public:
  MetricsRegistry() = default;
  MetricsRegistry(const MetricsRegistry&) = delete;
  MetricsRegistry& operator=(const MetricsRegistry&) = delete;

  // Return the metric `name` with `labels`, creating it (and its family, with
  // `help`) on first use. The reference stays valid for the registry's life.
  pf::Counter& Counter(std::string_view name, std::string_view help,
                       const MetricLabels& labels = {});
  pf::Gauge& Gauge(std::string_view name, std::string_view help, const MetricLabels& labels = {});
  // `bounds` is used when the family is created (later calls' are ignored).
  pf::Histogram& Histogram(std::string_view name, std::string_view help,
                           const std::vector<double>& bounds, const MetricLabels& labels = {});

  // Registers a gauge whose value is `read()`, called at every Render() (so a
  // queue depth can be read from the store at scrape time). Registering the
  // same name and labels again replaces the function. `read` runs with the
  // registry locked: it must not call this registry.
  void CallbackGauge(std::string_view name, std::string_view help, const MetricLabels& labels,
                     std::function<double()> read);

  // Returns all metrics in the Prometheus text format 0.0.4: families in
  // registration order, each with one # HELP and one # TYPE line, then its
  // samples in creation order.
  std::string Render() const;

 private:
  enum class Type { kCounter, kGauge, kHistogram };
  // One metric of a family: exactly one of the pointers is set.
  struct Child {
    MetricLabels labels;
    std::unique_ptr<pf::Counter> counter;
    std::unique_ptr<pf::Gauge> gauge;
    std::unique_ptr<pf::Histogram> histogram;
    std::function<double()> read;
  };
  struct Family {
    std::string name;
    std::string help;
    Type type;
    std::vector<std::string> label_names;
    std::vector<double> bounds;  // histograms only
    std::vector<std::unique_ptr<Child>> children;
    std::map<std::vector<std::string>, Child*> by_values;
  };

  // Returns the child of family `name` for `labels`, creating either; the
  // second member is true when the child is new. Requires mutex_ held.
  std::pair<Child*, bool> FindOrAdd(std::string_view name, std::string_view help, Type type,
                                    const std::vector<double>& bounds, const MetricLabels& labels);

  mutable std::mutex mutex_;
  std::vector<std::unique_ptr<Family>> families_;
  std::map<std::string, Family*, std::less<>> by_name_;
};

// Returns the process-wide registry.
MetricsRegistry& DefaultMetrics();

// Formats `value` as the exposition format writes it: shortest round-trip
// decimal ("12", "0.25", "1e+21"), "+Inf", "-Inf" or "NaN".
std::string FormatMetricValue(double value);

// Returns `value` with backslash, double quote and newline escaped for use in
// a label value.
std::string EscapeLabelValue(std::string_view value);

}  // namespace pf

#endif  // POINTFORWARD_COMMON_METRICS_H_
