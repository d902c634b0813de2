// Tests for MetricsRegistry: exact exposition text, escaping, histogram
// buckets, concurrent updates and callback gauges.
#include "common/metrics.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <thread>
#include <vector>

namespace pf {
namespace {

TEST(MetricsRegistry, RendersAllTypesInTheExpositionFormat) {
  MetricsRegistry registry;
  registry.Counter("pf_tasks_completed_total", "Tasks completed.", {{"kind", "render"}}).Inc(3);
  registry.Gauge("pf_jobs_running", "Jobs running now.").Set(2);
  registry.Counter("pf_tasks_completed_total", "Tasks completed.", {{"kind", "recon"}}).Inc();
  pf::Histogram& duration = registry.Histogram("pf_job_duration_seconds", "Job duration.",
                                               {0.5, 1, 2.5}, {{"kind", "render"}});
  duration.Observe(0.25);
  duration.Observe(2);

  EXPECT_EQ(registry.Render(),
            "# HELP pf_tasks_completed_total Tasks completed.\n"
            "# TYPE pf_tasks_completed_total counter\n"
            "pf_tasks_completed_total{kind=\"render\"} 3\n"
            "pf_tasks_completed_total{kind=\"recon\"} 1\n"
            "# HELP pf_jobs_running Jobs running now.\n"
            "# TYPE pf_jobs_running gauge\n"
            "pf_jobs_running 2\n"
            "# HELP pf_job_duration_seconds Job duration.\n"
            "# TYPE pf_job_duration_seconds histogram\n"
            "pf_job_duration_seconds_bucket{kind=\"render\",le=\"0.5\"} 1\n"
            "pf_job_duration_seconds_bucket{kind=\"render\",le=\"1\"} 1\n"
            "pf_job_duration_seconds_bucket{kind=\"render\",le=\"2.5\"} 2\n"
            "pf_job_duration_seconds_bucket{kind=\"render\",le=\"+Inf\"} 2\n"
            "pf_job_duration_seconds_sum{kind=\"render\"} 2.25\n"
            "pf_job_duration_seconds_count{kind=\"render\"} 2\n");
}

TEST(MetricsRegistry, EmptyRegistryRendersNothing) {
  MetricsRegistry registry;
  EXPECT_EQ(registry.Render(), "");
}

TEST(MetricsRegistry, SameNameAndLabelsReturnTheSameMetric) {
  MetricsRegistry registry;
  pf::Counter& a = registry.Counter("hits_total", "Hits.", {{"cache", "scene"}});
  pf::Counter& b = registry.Counter("hits_total", "Hits.", {{"cache", "scene"}});
  pf::Counter& c = registry.Counter("hits_total", "Hits.", {{"cache", "blob"}});
  EXPECT_EQ(&a, &b);
  EXPECT_NE(&a, &c);
  a.Inc();
  b.Inc(2);
  EXPECT_EQ(a.Value(), 3);
  EXPECT_EQ(c.Value(), 0);
}

TEST(MetricsRegistry, CounterIgnoresNegativeIncrements) {
  MetricsRegistry registry;
  pf::Counter& counter = registry.Counter("bytes_total", "Bytes.");
  counter.Inc(10);
  counter.Inc(-4);
  EXPECT_EQ(counter.Value(), 10);
}

TEST(MetricsRegistry, GaugeSetsIncrementsAndDecrements) {
  MetricsRegistry registry;
  pf::Gauge& gauge = registry.Gauge("scene_bytes", "Scene memory in use.");
  gauge.Set(100);
  gauge.Inc(5);
  gauge.Dec(25);
  gauge.Dec();
  EXPECT_EQ(registry.Render(),
            "# HELP scene_bytes Scene memory in use.\n"
            "# TYPE scene_bytes gauge\n"
            "scene_bytes 79\n");
}

TEST(MetricsRegistry, EscapesLabelValuesAndHelpText) {
  MetricsRegistry registry;
  registry
      .Gauge("odd", "Help with \\ and\nnewline \"quoted\".",
             {{"path", "C:\\dir\\"}, {"text", "say \"hi\"\nbye"}})
      .Set(1);
  EXPECT_EQ(registry.Render(),
            "# HELP odd Help with \\\\ and\\nnewline \"quoted\".\n"
            "# TYPE odd gauge\n"
            "odd{path=\"C:\\\\dir\\\\\",text=\"say \\\"hi\\\"\\nbye\"} 1\n");
  EXPECT_EQ(EscapeLabelValue("a\\b\"c\nd"), "a\\\\b\\\"c\\nd");
}

TEST(MetricsRegistry, HistogramBucketsAreCumulativeAndEndInInf) {
  MetricsRegistry registry;
  pf::Histogram& histogram = registry.Histogram("latency_seconds", "Latency.", {0.25, 1, 10});
  // A value equal to a bound falls in that bound's bucket (le is <=).
  for (double v : {0.125, 0.25, 0.5, 0.75, 100.0}) histogram.Observe(v);

  const pf::Histogram::Counts counts = histogram.Snapshot();
  EXPECT_EQ(counts.bucket_counts, (std::vector<uint64_t>{2, 4, 4, 5}));
  EXPECT_EQ(counts.count, 5u);
  EXPECT_EQ(counts.sum, 101.625);
  EXPECT_EQ(registry.Render(),
            "# HELP latency_seconds Latency.\n"
            "# TYPE latency_seconds histogram\n"
            "latency_seconds_bucket{le=\"0.25\"} 2\n"
            "latency_seconds_bucket{le=\"1\"} 4\n"
            "latency_seconds_bucket{le=\"10\"} 4\n"
            "latency_seconds_bucket{le=\"+Inf\"} 5\n"
            "latency_seconds_sum 101.625\n"
            "latency_seconds_count 5\n");
}

TEST(MetricsRegistry, HistogramChildrenShareTheFamilyBuckets) {
  MetricsRegistry registry;
  registry.Histogram("d", "D.", {1, 2}, {{"kind", "a"}});
  pf::Histogram& b = registry.Histogram("d", "D.", {5}, {{"kind", "b"}});
  EXPECT_EQ(b.bounds(), (std::vector<double>{1, 2}));
}

TEST(MetricsRegistry, ConcurrentIncrementsAreNotLost) {
  MetricsRegistry registry;
  constexpr int kThreads = 8;
  constexpr int kIncrements = 10000;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&registry, t] {
      // Every thread looks the metrics up itself, racing on creation too.
      pf::Counter& counter = registry.Counter("events_total", "Events.");
      pf::Gauge& gauge = registry.Gauge("in_flight", "In flight.");
      pf::Histogram& histogram = registry.Histogram("sizes", "Sizes.", {1, 100});
      for (int i = 0; i < kIncrements; ++i) {
        counter.Inc();
        gauge.Inc();
        gauge.Dec();
        histogram.Observe(t % 2 == 0 ? 0.5 : 50);
      }
    });
  }
  for (std::thread& thread : threads) thread.join();

  EXPECT_EQ(registry.Counter("events_total", "Events.").Value(), kThreads * kIncrements);
  EXPECT_EQ(registry.Gauge("in_flight", "In flight.").Value(), 0);
  const pf::Histogram::Counts counts = registry.Histogram("sizes", "Sizes.", {}).Snapshot();
  EXPECT_EQ(counts.bucket_counts, (std::vector<uint64_t>{40000, 80000, 80000}));
  EXPECT_NE(registry.Render().find("\nevents_total 80000\n"), std::string::npos);
}

TEST(MetricsRegistry, CallbackGaugeIsReadAtScrapeTime) {
  MetricsRegistry registry;
  std::atomic<int> render_depth{3};
  std::atomic<int> calls{0};
  registry.CallbackGauge("pf_queue_depth", "Jobs waiting.", {{"kind", "render"}}, [&] {
    ++calls;
    return static_cast<double>(render_depth.load());
  });
  registry.CallbackGauge("pf_queue_depth", "Jobs waiting.", {{"kind", "recon"}},
                         [] { return 0.0; });
  EXPECT_EQ(calls.load(), 0);

  const std::string expected_head =
      "# HELP pf_queue_depth Jobs waiting.\n"
      "# TYPE pf_queue_depth gauge\n";
  EXPECT_EQ(registry.Render(), expected_head +
                                   "pf_queue_depth{kind=\"render\"} 3\n"
                                   "pf_queue_depth{kind=\"recon\"} 0\n");
  render_depth = 12;
  EXPECT_EQ(registry.Render(), expected_head +
                                   "pf_queue_depth{kind=\"render\"} 12\n"
                                   "pf_queue_depth{kind=\"recon\"} 0\n");
  EXPECT_EQ(calls.load(), 2);

  // Registering again replaces the function.
  registry.CallbackGauge("pf_queue_depth", "Jobs waiting.", {{"kind", "render"}},
                         [] { return 5.0; });
  EXPECT_EQ(registry.Render(), expected_head +
                                   "pf_queue_depth{kind=\"render\"} 5\n"
                                   "pf_queue_depth{kind=\"recon\"} 0\n");
}

TEST(MetricsRegistry, FormatsValuesLikeTheExpositionFormat) {
  EXPECT_EQ(FormatMetricValue(0), "0");
  EXPECT_EQ(FormatMetricValue(42), "42");
  EXPECT_EQ(FormatMetricValue(-1.5), "-1.5");
  EXPECT_EQ(FormatMetricValue(0.1), "0.1");
  EXPECT_EQ(FormatMetricValue(1e21), "1e+21");
  EXPECT_EQ(FormatMetricValue(std::numeric_limits<double>::infinity()), "+Inf");
  EXPECT_EQ(FormatMetricValue(-std::numeric_limits<double>::infinity()), "-Inf");
  EXPECT_EQ(FormatMetricValue(std::nan("")), "NaN");
}

TEST(MetricsRegistry, DefaultMetricsIsOneRegistry) {
  EXPECT_EQ(&DefaultMetrics(), &DefaultMetrics());
}

TEST(MetricsRegistryDeathTest, RejectsProgrammerErrors) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(
      {
        MetricsRegistry registry;
        registry.Counter("x", "X.");
        registry.Gauge("x", "X.");
      },
      "another type");
  EXPECT_DEATH(
      {
        MetricsRegistry registry;
        registry.Counter("x", "X.", {{"a", "1"}});
        registry.Counter("x", "X.", {{"b", "1"}});
      },
      "other label names");
  EXPECT_DEATH(MetricsRegistry().Counter("bad-name", "X."), "invalid metric name");
  EXPECT_DEATH(MetricsRegistry().Histogram("h", "H.", {1}, {{"le", "1"}}), "label name 'le'");
  EXPECT_DEATH(MetricsRegistry().Histogram("h", "H.", {2, 1}), "strictly increasing");
}

}  // namespace
}  // namespace pf
