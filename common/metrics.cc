// Metrics registry and its Prometheus text rendering.
#include "common/metrics.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace pf {
namespace {

// Aborts on a programmer error (the CHECK of this file). Writes to stderr
// directly, as CHECK does, whatever the logger is configured to.
[[noreturn]] void Die(const std::string& message) {
  std::fprintf(stderr, "metrics: %s\n", message.c_str());
  std::abort();
}

// Returns whether `name` matches [a-zA-Z_:][a-zA-Z0-9_:]* (colons only when
// `allow_colon`, as in metric names but not label names).
bool IsValidName(std::string_view name, bool allow_colon) {
  if (name.empty()) return false;
  for (size_t i = 0; i < name.size(); ++i) {
    const char c = name[i];
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_' ||
                    (allow_colon && c == ':') || (i > 0 && c >= '0' && c <= '9');
    if (!ok) return false;
  }
  return true;
}

// Returns `text` with backslash and newline escaped, as HELP lines need.
std::string EscapeHelp(std::string_view text) {
  std::string out;
  for (char c : text) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

// Appends `{a="x",b="y"}` for `labels` plus an optional `le` bound; nothing
// when both are empty.
void AppendLabels(const MetricLabels& labels, const std::string* le, std::string& out) {
  if (labels.empty() && le == nullptr) return;
  out += '{';
  bool first = true;
  for (const auto& [name, value] : labels) {
    if (!first) out += ',';
    first = false;
    out += name;
    out += "=\"";
    out += EscapeLabelValue(value);
    out += '"';
  }
  if (le != nullptr) {
    if (!first) out += ',';
    out += "le=\"";
    out += *le;
    out += '"';
  }
  out += '}';
}

// Appends one sample line: `name{labels} value`.
void AppendSample(std::string_view name, const MetricLabels& labels, const std::string* le,
                  std::string_view value, std::string& out) {
  out += name;
  AppendLabels(labels, le, out);
  out += ' ';
  out += value;
  out += '\n';
}

}  // namespace

std::string FormatMetricValue(double value) {
  if (std::isnan(value)) return "NaN";
  if (std::isinf(value)) return value > 0 ? "+Inf" : "-Inf";
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string EscapeLabelValue(std::string_view value) {
  std::string out;
  for (char c : value) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '"') {
      out += "\\\"";
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

void Counter::Inc(double n) {
  if (n > 0) value_.fetch_add(n, std::memory_order_relaxed);
}

Histogram::Histogram(std::vector<double> bounds)
    : bounds_(std::move(bounds)), bucket_counts_(bounds_.size() + 1, 0) {
  for (size_t i = 0; i < bounds_.size(); ++i) {
    if (!std::isfinite(bounds_[i]) || (i > 0 && bounds_[i] <= bounds_[i - 1])) {
      Die("histogram bounds must be finite and strictly increasing");
    }
  }
}

void Histogram::Observe(double value) {
  // First bucket whose upper bound is >= value; past the end (and NaN) is +Inf.
  const size_t bucket =
      std::isnan(value) ? bounds_.size()
                        : std::lower_bound(bounds_.begin(), bounds_.end(), value) - bounds_.begin();
  std::lock_guard<std::mutex> lock(mutex_);
  ++bucket_counts_[bucket];
  sum_ += value;
  ++count_;
}

Histogram::Counts Histogram::Snapshot() const {
  Counts counts;
  std::lock_guard<std::mutex> lock(mutex_);
  counts.bucket_counts.reserve(bucket_counts_.size());
  uint64_t running = 0;
  for (uint64_t n : bucket_counts_) {
    running += n;
    counts.bucket_counts.push_back(running);
  }
  counts.sum = sum_;
  counts.count = count_;
  return counts;
}

std::vector<double> DurationBuckets() {
  return {0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 120, 300, 600};
}

std::pair<MetricsRegistry::Child*, bool> MetricsRegistry::FindOrAdd(
    std::string_view name, std::string_view help, Type type, const std::vector<double>& bounds,
    const MetricLabels& labels) {
  std::vector<std::string> label_names;
  std::vector<std::string> label_values;
  for (const auto& [label, value] : labels) {
    label_names.push_back(label);
    label_values.push_back(value);
  }

  Family* family = nullptr;
  if (auto it = by_name_.find(name); it != by_name_.end()) {
    family = it->second;
    if (family->type != type) {
      Die("metric " + std::string(name) + " registered again with another type");
    }
    if (family->label_names != label_names) {
      Die("metric " + std::string(name) + " registered again with other label names");
    }
  } else {
    if (!IsValidName(name, /*allow_colon=*/true)) {
      Die("invalid metric name '" + std::string(name) + "'");
    }
    for (size_t i = 0; i < label_names.size(); ++i) {
      const std::string& label = label_names[i];
      if (!IsValidName(label, /*allow_colon=*/false) || label.rfind("__", 0) == 0 ||
          (type == Type::kHistogram && label == "le") ||
          std::find(label_names.begin(), label_names.begin() + i, label) !=
              label_names.begin() + i) {
        Die("invalid or repeated label name '" + label + "' on metric " + std::string(name));
      }
    }
    auto created = std::make_unique<Family>();
    created->name = std::string(name);
    created->help = std::string(help);
    created->type = type;
    created->label_names = label_names;
    created->bounds = bounds;
    family = created.get();
    families_.push_back(std::move(created));
    by_name_.emplace(family->name, family);
  }

  if (auto it = family->by_values.find(label_values); it != family->by_values.end()) {
    return {it->second, false};
  }
  auto child = std::make_unique<Child>();
  child->labels = labels;
  Child* raw = child.get();
  family->children.push_back(std::move(child));
  family->by_values.emplace(std::move(label_values), raw);
  return {raw, true};
}

Counter& MetricsRegistry::Counter(std::string_view name, std::string_view help,
                                  const MetricLabels& labels) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto [child, created] = FindOrAdd(name, help, Type::kCounter, {}, labels);
  if (created) child->counter = std::make_unique<pf::Counter>();
  return *child->counter;
}

Gauge& MetricsRegistry::Gauge(std::string_view name, std::string_view help,
                              const MetricLabels& labels) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto [child, created] = FindOrAdd(name, help, Type::kGauge, {}, labels);
  if (created) {
    child->gauge = std::make_unique<pf::Gauge>();
  } else if (child->gauge == nullptr) {
    Die("gauge " + std::string(name) + " is already registered as a callback gauge");
  }
  return *child->gauge;
}

Histogram& MetricsRegistry::Histogram(std::string_view name, std::string_view help,
                                      const std::vector<double>& bounds,
                                      const MetricLabels& labels) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto [child, created] = FindOrAdd(name, help, Type::kHistogram, bounds, labels);
  if (created) {
    // The family's bounds, so every child of a family has the same buckets.
    child->histogram = std::make_unique<pf::Histogram>(by_name_.find(name)->second->bounds);
  }
  return *child->histogram;
}

void MetricsRegistry::CallbackGauge(std::string_view name, std::string_view help,
                                    const MetricLabels& labels, std::function<double()> read) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto [child, created] = FindOrAdd(name, help, Type::kGauge, {}, labels);
  if (!created && child->gauge != nullptr) {
    Die("gauge " + std::string(name) + " is already registered as a plain gauge");
  }
  child->read = std::move(read);
}

std::string MetricsRegistry::Render() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string out;
  for (const auto& family : families_) {
    const std::string& name = family->name;
    out += "# HELP " + name + " " + EscapeHelp(family->help) + "\n";
    switch (family->type) {
      case Type::kCounter:
        out += "# TYPE " + name + " counter\n";
        break;
      case Type::kGauge:
        out += "# TYPE " + name + " gauge\n";
        break;
      case Type::kHistogram:
        out += "# TYPE " + name + " histogram\n";
        break;
    }
    for (const auto& child : family->children) {
      if (child->counter != nullptr) {
        AppendSample(name, child->labels, nullptr, FormatMetricValue(child->counter->Value()), out);
      } else if (child->gauge != nullptr) {
        AppendSample(name, child->labels, nullptr, FormatMetricValue(child->gauge->Value()), out);
      } else if (child->read) {
        AppendSample(name, child->labels, nullptr, FormatMetricValue(child->read()), out);
      } else if (child->histogram != nullptr) {
        const pf::Histogram::Counts counts = child->histogram->Snapshot();
        const std::vector<double>& bounds = child->histogram->bounds();
        const std::string bucket_name = name + "_bucket";
        for (size_t i = 0; i < counts.bucket_counts.size(); ++i) {
          const std::string le = i < bounds.size() ? FormatMetricValue(bounds[i]) : "+Inf";
          AppendSample(bucket_name, child->labels, &le, std::to_string(counts.bucket_counts[i]),
                       out);
        }
        AppendSample(name + "_sum", child->labels, nullptr, FormatMetricValue(counts.sum), out);
        AppendSample(name + "_count", child->labels, nullptr, std::to_string(counts.count), out);
      }
    }
  }
  return out;
}

MetricsRegistry& DefaultMetrics() {
  static MetricsRegistry* const registry = new MetricsRegistry();
  return *registry;
}

}  // namespace pf
