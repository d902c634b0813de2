#include "engine/recon/ego_body.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <string>

#include "common/thread_pool.h"
#include "engine/recon/scene_graph.h"

namespace pf {
namespace {

constexpr float kNoEvidence = -1.f;  // A difference that could not be measured.
constexpr int kBoxRadius = 2;        // The 5x5 mean, in blocks.
constexpr int kCloseBlocks = 2;
constexpr int kDenseRadius = 3;  // 7x7 blocks.
constexpr float kDenseShare = 0.5f;
constexpr float kSaturated = 0.9f;
constexpr double kHiddenRatio = 0.9;  // A surface nearer than this share hides the point.
constexpr int kPatchRadius = 3;       // The patch test's 7x7 blocks.
constexpr double kPatchMinShift = 3;  // Blocks the depth must move a patch.
constexpr double kPatchTexture = 0.03;
constexpr double kPatchMinDifference = 0.03;
constexpr double kPatchRatio = 3;
constexpr double kPatchMinScale = 0.67;  // The other frame's scale of the patch, at least.
constexpr int kPatchOutlineParts = 4;    // A run of still patches: a quarter of the width.
constexpr int kMovedOutlineParts = 2;    // A run of moved blocks: half of it.

// A view reduced to blocks of `step` x `step` pixels (their mean colour).
struct Reduced {
  int width = 0, height = 0, step = 1;
  std::vector<float> rgb;  // [h, w, 3]

  // Bilinear colour at continuous block coordinates; false outside (or NaN).
  bool Sample(double x, double y, float out[3]) const {
    x -= 0.5;
    y -= 0.5;
    if (!(x >= 0 && y >= 0 && x <= width - 1 && y <= height - 1)) return false;
    const int x0 = std::min(static_cast<int>(x), width - 2 < 0 ? 0 : width - 2);
    const int y0 = std::min(static_cast<int>(y), height - 2 < 0 ? 0 : height - 2);
    const int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
    const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
    for (int c = 0; c < 3; ++c) {
      const float top = rgb[(size_t(y0) * width + x0) * 3 + c] * (1 - fx) +
                        rgb[(size_t(y0) * width + x1) * 3 + c] * fx;
      const float bottom = rgb[(size_t(y1) * width + x0) * 3 + c] * (1 - fx) +
                           rgb[(size_t(y1) * width + x1) * 3 + c] * fx;
      out[c] = top * (1 - fy) + bottom * fy;
    }
    return true;
  }
};

Reduced Reduce(const ImageF& image, int step) {
  Reduced r;
  r.step = step;
  r.width = image.width / step;
  r.height = image.height / step;
  r.rgb.assign(size_t(r.width) * r.height * 3, 0.f);
  const float norm = 1.f / float(step * step);
  for (int y = 0; y < r.height; ++y) {
    for (int x = 0; x < r.width; ++x) {
      for (int dy = 0; dy < step; ++dy) {
        for (int dx = 0; dx < step; ++dx) {
          for (int c = 0; c < 3; ++c) {
            r.rgb[(size_t(y) * r.width + x) * 3 + c] +=
                image.at(x * step + dx, y * step + dy, c) * norm;
          }
        }
      }
    }
  }
  return r;
}

// Every channel of block `i` near the top of the range: a clipped surface
// (an overexposed road) looks the same from anywhere and says nothing (nor
// does a white body).
bool Saturated(const Reduced& r, size_t i) {
  return r.rgb[i * 3] >= kSaturated && r.rgb[i * 3 + 1] >= kSaturated &&
         r.rgb[i * 3 + 2] >= kSaturated;
}

float MeanAbs(const float* a, const float* b) {
  return (std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2])) / 3.f;
}

// The mean of the measured (>= 0) values in the (2r+1)^2 window; kNoEvidence
// where the window has none.
std::vector<float> BoxMean(const std::vector<float>& v, int w, int h, int r) {
  std::vector<float> out(v.size(), kNoEvidence);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float sum = 0;
      int n = 0;
      for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy) {
        for (int xx = std::max(0, x - r); xx <= std::min(w - 1, x + r); ++xx) {
          const float d = v[size_t(yy) * w + xx];
          if (d >= 0) sum += d, ++n;
        }
      }
      if (n > 0) out[size_t(y) * w + x] = sum / float(n);
    }
  }
  return out;
}

// One frame of a pair: its view, depth, box mask and reduced image.
struct PairFrame {
  const ContextView* view;
  const ViewDepth* depth;
  const std::vector<uint8_t>* dynamic;
  const Reduced* reduced;
};

// |colour of `from` at each block - colour of `to` where the block's centre,
// lifted with `from`'s depth, lands|; kNoEvidence on the far layer or in a
// box (in either frame), outside `to`, where `to` sees a nearer surface there
// (hidden), or on a block that is the same in both frames (`still`, the same
// grid) and not near-white: the body may hide the point there.
std::vector<float> MovedDifference(const PairFrame& f, const PairFrame& t,
                                   const std::vector<uint8_t>& still) {
  const ContextView& from = *f.view;
  const ViewDepth& depth = *f.depth;
  const std::vector<uint8_t>& dynamic = *f.dynamic;
  const Reduced& rf = *f.reduced;
  const ContextView& to = *t.view;
  const Reduced& rt = *t.reduced;
  std::vector<float> diff(size_t(rf.width) * rf.height, kNoEvidence);
  const LinePoses from_lines = from.lines();
  const LinePoses to_lines = to.lines();
  DefaultThreadPool().ParallelFor(0, rf.height, 8, [&](int64_t y0, int64_t y1) {
    for (int y = static_cast<int>(y0); y < y1; ++y) {
      for (int x = 0; x < rf.width; ++x) {
        const int px = x * rf.step + rf.step / 2, py = y * rf.step + rf.step / 2;
        const size_t i = size_t(py) * from.width() + px;
        if (depth.is_far(i) || (!dynamic.empty() && dynamic[i] != 0)) continue;
        Vec3 world;
        if (!from_lines.Lift(px + 0.5, py + 0.5, depth.depth[i], &world)) continue;
        double u, v;
        Vec3 in_to;
        if (!to_lines.Project(world, &u, &v, &in_to)) continue;
        float seen[3];
        if (!rt.Sample(u / rt.step, v / rt.step, seen)) continue;
        const int tx = std::clamp(static_cast<int>(u), 0, to.width() - 1);
        const int ty = std::clamp(static_cast<int>(v), 0, to.height() - 1);
        const size_t j = size_t(ty) * to.width() + tx;
        if (!t.dynamic->empty() && (*t.dynamic)[j] != 0) continue;
        if (!t.depth->is_far(j) && t.depth->depth[j] < kHiddenRatio * in_to.z) continue;
        const size_t landing =
            size_t(std::clamp(static_cast<int>(v / rt.step), 0, rt.height - 1)) * rt.width +
            std::clamp(static_cast<int>(u / rt.step), 0, rt.width - 1);
        if (still[landing] && !Saturated(rt, landing)) continue;
        diff[size_t(y) * rf.width + x] = MeanAbs(&rf.rgb[(size_t(y) * rf.width + x) * 3], seen);
      }
    }
  });
  return diff;
}

// The cells of the bottom row of a w x h grid.
std::vector<size_t> BottomRow(int w, int h) {
  std::vector<size_t> row;
  for (int x = 0; x < w; ++x) row.push_back(size_t(h - 1) * w + x);
  return row;
}

// 4-connected flood over `open` cells from `seeds`; returns the cells reached.
std::vector<uint8_t> Flood(const std::vector<uint8_t>& open, const std::vector<size_t>& seeds,
                           int w, int h) {
  std::vector<uint8_t> reached(open.size(), 0);
  std::deque<size_t> queue;
  for (size_t s : seeds) {
    if (open[s] && !reached[s]) reached[s] = 1, queue.push_back(s);
  }
  while (!queue.empty()) {
    const size_t i = queue.front();
    queue.pop_front();
    const int x = static_cast<int>(i % w), y = static_cast<int>(i / w);
    const size_t next[4] = {x > 0 ? i - 1 : i, x + 1 < w ? i + 1 : i, y > 0 ? i - w : i,
                            y + 1 < h ? i + w : i};
    for (size_t n : next) {
      if (open[n] && !reached[n]) reached[n] = 1, queue.push_back(n);
    }
  }
  return reached;
}

// Dilation (grow) or erosion (!grow) by a square of radius r.
std::vector<uint8_t> Morph(const std::vector<uint8_t>& m, int w, int h, int r, bool grow) {
  std::vector<uint8_t> out(m.size());
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      bool any = false, all = true;
      for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy) {
        for (int xx = std::max(0, x - r); xx <= std::min(w - 1, x + r); ++xx) {
          const bool on = m[size_t(yy) * w + xx] != 0;
          any |= on;
          all &= on;
        }
      }
      out[size_t(y) * w + x] = grow ? any : all;
    }
  }
  return out;
}

// Where each block of `f` lands in `t` (block coordinates), lifted with
// its depth (the far layer's too); NaN where it does not.
std::vector<std::array<float, 2>> Landings(const PairFrame& f, const PairFrame& t) {
  const ContextView& from = *f.view;
  const Reduced& rf = *f.reduced;
  const Reduced& rt = *t.reduced;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<std::array<float, 2>> landing(size_t(rf.width) * rf.height, {nan, nan});
  const LinePoses from_lines = from.lines();
  const LinePoses to_lines = t.view->lines();
  DefaultThreadPool().ParallelFor(0, rf.height, 8, [&](int64_t y0, int64_t y1) {
    for (int y = static_cast<int>(y0); y < y1; ++y) {
      for (int x = 0; x < rf.width; ++x) {
        const int px = x * rf.step + rf.step / 2, py = y * rf.step + rf.step / 2;
        Vec3 world, in_to;
        double u, v;
        if (!from_lines.Lift(px + 0.5, py + 0.5, f.depth->depth[size_t(py) * from.width() + px],
                             &world) ||
            !to_lines.Project(world, &u, &v, &in_to)) {
          continue;
        }
        landing[size_t(y) * rf.width + x] = {float(u / rt.step), float(v / rt.step)};
      }
    }
  });
  return landing;
}

// Blocks of `f` whose 7x7-block patch stays where it was in `t` while its
// depth says it should have moved: textured (grey std-dev >= kPatchTexture),
// its centre moved by the depth at least kPatchMinShift blocks, each of its
// blocks landing in `t` (Landings), `t` seeing it at least kPatchMinScale
// of its size across and down (seen much smaller, a sharp line is a blur
// of blocks there, and a lane line along the road, which the motion leaves
// where it was, would pass), and the patch's mean difference from `t` at
// the same place under 1/kPatchRatio of that where its blocks land (itself
// at least kPatchMinDifference). Finds edges of a body that looks like what
// it hides, where MovedDifference's colour bar cannot. Says nothing on the
// far layer, in a box, or off `reached` (the still blocks connected to the
// bottom row).
std::vector<uint8_t> StillPatches(const PairFrame& f, const PairFrame& t,
                                  const std::vector<uint8_t>& reached) {
  const ContextView& from = *f.view;
  const ViewDepth& depth = *f.depth;
  const std::vector<uint8_t>& dynamic = *f.dynamic;
  const Reduced& rf = *f.reduced;
  const Reduced& rt = *t.reduced;
  std::vector<uint8_t> still(size_t(rf.width) * rf.height, 0);
  if (rt.width != rf.width || rt.height != rf.height) return still;
  const std::vector<std::array<float, 2>> landing = Landings(f, t);
  const int r = kPatchRadius;
  DefaultThreadPool().ParallelFor(r, std::max(r, rf.height - r), 8, [&](int64_t y0, int64_t y1) {
    for (int y = static_cast<int>(y0); y < y1; ++y) {
      for (int x = r; x < rf.width - r; ++x) {
        const int px = x * rf.step + rf.step / 2, py = y * rf.step + rf.step / 2;
        const size_t i = size_t(py) * from.width() + px;
        if (!reached[size_t(y) * rf.width + x] || depth.is_far(i) ||
            (!dynamic.empty() && dynamic[i] != 0)) {
          continue;
        }
        const std::array<float, 2>& centre = landing[size_t(y) * rf.width + x];
        const double bx = centre[0] - (x + 0.5), by = centre[1] - (y + 0.5);
        if (!(bx * bx + by * by >= kPatchMinShift * kPatchMinShift)) continue;
        // The patch's scale in `t`, across and down.
        const auto span = [&](int dx, int dy) {
          const std::array<float, 2>& p = landing[size_t(y + dy) * rf.width + x + dx];
          const std::array<float, 2>& q = landing[size_t(y - dy) * rf.width + x - dx];
          return std::hypot(p[0] - q[0], p[1] - q[1]) / (2.0 * r);
        };
        const double sx = span(r, 0), sy = span(0, r);
        if (!(std::min(sx, sy) >= kPatchMinScale)) continue;
        double sum = 0, sum_sq = 0, here = 0, there = 0;
        bool inside = true;
        for (int dy = -r; dy <= r && inside; ++dy) {
          for (int dx = -r; dx <= r; ++dx) {
            const size_t j = size_t(y + dy) * rf.width + x + dx;
            float seen[3];
            if (!rt.Sample(landing[j][0], landing[j][1], seen)) {
              inside = false;
              break;
            }
            const float* a = &rf.rgb[j * 3];
            const double grey = (a[0] + a[1] + a[2]) / 3.0;
            sum += grey;
            sum_sq += grey * grey;
            here += MeanAbs(a, &rt.rgb[j * 3]);
            there += MeanAbs(a, seen);
          }
        }
        if (!inside) continue;
        const double n = double((2 * r + 1) * (2 * r + 1));
        const double mean = sum / n;
        const double texture = std::sqrt(std::max(0.0, sum_sq / n - mean * mean));
        here /= n;
        there /= n;
        if (texture >= kPatchTexture && there >= kPatchMinDifference &&
            here * kPatchRatio < there) {
          still[size_t(y) * rf.width + x] = 1;
        }
      }
    }
  });
  return still;
}

// The row of column `x` where the edge a still patch at row `top` holds
// lies: of the rows top..top + 2 kPatchRadius, the first whose step in grey
// from the row above is at least half the largest such step.
int EdgeBelow(const Reduced& image, int x, int top) {
  auto grey = [&](int y) {
    const float* p = &image.rgb[(size_t(y) * image.width + x) * 3];
    return (p[0] + p[1] + p[2]) / 3.f;
  };
  const int first = std::max(1, top), last = std::min(image.height - 1, top + 2 * kPatchRadius);
  float largest = 0;
  for (int y = first; y <= last; ++y) largest = std::max(largest, std::abs(grey(y) - grey(y - 1)));
  for (int y = first; y <= last; ++y) {
    if (std::abs(grey(y) - grey(y - 1)) >= 0.5f * largest) return y;
  }
  return top;
}

// Evidence of a body below long runs of `edges` (still patches, or blocks
// the world's motion does not explain): each 8-connected group of them
// (joined across gaps of up to kCloseBlocks) that lies in the lower half of
// the image and spans at least 1/`min_span_parts` of its width marks, in
// every column it covers, the blocks from the edge below its topmost block
// there (EdgeBelow) down to the bottom row. A body's outline crosses the
// image; a lone edge given a wrong depth does not.
std::vector<uint8_t> BelowLongEdges(const std::vector<uint8_t>& edges, const Reduced& image,
                                    int min_span_parts) {
  const int w = image.width, h = image.height;
  const std::vector<uint8_t> joined = Morph(edges, w, h, kCloseBlocks, true);
  std::vector<uint8_t> grouped(edges.size(), 0), below(edges.size(), 0);
  for (size_t start = 0; start < edges.size(); ++start) {
    if (!joined[start] || grouped[start]) continue;
    std::vector<size_t> group{start};
    grouped[start] = 1;
    for (size_t k = 0; k < group.size(); ++k) {
      const int x = static_cast<int>(group[k] % w), y = static_cast<int>(group[k] / w);
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
          const size_t n = size_t(yy) * w + xx;
          if (joined[n] && !grouped[n]) grouped[n] = 1, group.push_back(n);
        }
      }
    }
    std::vector<int> top(w, h);
    int min_x = w, max_x = -1, min_y = h;
    for (size_t c : group) {
      if (!edges[c]) continue;  // The joining blocks only connect.
      const int x = static_cast<int>(c % w), y = static_cast<int>(c / w);
      top[x] = std::min(top[x], y);
      min_x = std::min(min_x, x), max_x = std::max(max_x, x), min_y = std::min(min_y, y);
    }
    if (max_x < 0 || (max_x - min_x + 1) * min_span_parts < w || min_y * 2 < h) continue;
    for (int x = 0; x < w; ++x) {
      if (top[x] >= h) continue;
      for (int y = EdgeBelow(image, x, top[x]); y < h; ++y) below[size_t(y) * w + x] = 1;
    }
  }
  return below;
}

// Evidence of a body that mirrors the street: what it shows changes between
// frames, so it is not still (nor reached), but the motion explains none of
// its outline. The blocks below a run of `moved` blocks across at least half
// of the image's width (BelowLongEdges) that are not still (5x5 mean), where
// most of the 7x7 blocks around are too.
std::vector<uint8_t> BelowMovedOutline(const std::vector<uint8_t>& moved,
                                       const std::vector<uint8_t>& still, const Reduced& image) {
  const int w = image.width, h = image.height;
  std::vector<uint8_t> outlined = BelowLongEdges(moved, image, kMovedOutlineParts);
  std::vector<float> share(outlined.size());
  for (size_t i = 0; i < outlined.size(); ++i) {
    outlined[i] = outlined[i] && !still[i];
    share[i] = outlined[i];
  }
  share = BoxMean(share, w, h, kDenseRadius);
  for (size_t i = 0; i < outlined.size(); ++i) outlined[i] = outlined[i] && share[i] >= kDenseShare;
  return outlined;
}

// The body continues from its side edges along its rows across `open`
// blocks (in a box and still): a box takes the evidence away, so a body in
// front of a moving car would end at the box's edge.
void ContinueIntoBoxes(const std::vector<uint8_t>& open, int w, int h, std::vector<uint8_t>* body) {
  std::vector<uint8_t>& b = *body;
  for (int y = 0; y < h; ++y) {
    uint8_t* row = &b[size_t(y) * w];
    const uint8_t* free = &open[size_t(y) * w];
    for (int x = 1; x < w; ++x) {
      if (!row[x] || row[x - 1]) continue;
      for (int g = x - 1; g >= 0 && free[g] && !row[g]; --g) row[g] = 1;
    }
    for (int x = w - 2; x >= 0; --x) {
      if (!row[x] || row[x + 1]) continue;
      for (int g = x + 1; g < w && free[g] && !row[g]; ++g) row[g] = 1;
    }
  }
}

// The body from the still blocks connected to the bottom row (`reached`)
// and the blocks the world's motion does not explain (`moved`), and the
// blocks below a moved outline (`outlined`, BelowMovedOutline), continued
// into the still `boxed` blocks (ContinueIntoBoxes).
std::vector<uint8_t> BodyShape(const std::vector<uint8_t>& reached,
                               const std::vector<uint8_t>& moved,
                               const std::vector<uint8_t>& outlined,
                               const std::vector<uint8_t>& still_here,
                               const std::vector<uint8_t>& boxed, int w, int h) {
  // Evidence counts where it is dense: most blocks of the 7x7 around.
  std::vector<float> evidence(size_t(w) * h);
  for (size_t i = 0; i < evidence.size(); ++i) evidence[i] = reached[i] && moved[i] ? 1.f : 0.f;
  evidence = BoxMean(evidence, w, h, kDenseRadius);
  std::vector<uint8_t> body(size_t(w) * h);
  for (size_t i = 0; i < body.size(); ++i) {
    body[i] = (reached[i] && moved[i] && evidence[i] >= kDenseShare) || outlined[i];
  }
  body = Morph(Morph(body, w, h, kCloseBlocks, true), w, h, kCloseBlocks, false);
  // The 5x5 mean stops short of the body's edge: grow into blocks still alone.
  const std::vector<uint8_t> grown = Morph(body, w, h, kBoxRadius, true);
  for (size_t i = 0; i < body.size(); ++i) body[i] = body[i] || (grown[i] && still_here[i]);
  // Still: by the 5x5 mean and connected to the bottom row, or on its own.
  std::vector<uint8_t> still(body.size()), silent(body.size());
  for (size_t i = 0; i < still.size(); ++i) {
    still[i] = reached[i] || still_here[i];
    silent[i] = boxed[i] && still[i];
  }
  ContinueIntoBoxes(silent, w, h, &body);
  // Below the body there is only body: still blocks under a body block are.
  for (size_t i = size_t(w); i < body.size(); ++i) {
    if (!body[i] && body[i - w] && still[i]) body[i] = 1;
  }
  // The body rises from the bottom: a column whose span below its topmost
  // body block is three quarters body is body all the way down.
  for (int x = 0; x < w; ++x) {
    int top = -1, on = 0;
    for (int y = 0; y < h; ++y) {
      if (body[size_t(y) * w + x]) {
        if (top < 0) top = y;
        ++on;
      }
    }
    if (top >= 0 && on * 4 >= 3 * (h - top)) {
      for (int y = top; y < h; ++y) body[size_t(y) * w + x] = 1;
    }
  }
  // A gap in a row between two stretches of body, narrower than a fifth of
  // the image, is body too (a window of reflections in a hood); so is one
  // between the body and the image's side narrower than a twentieth (a
  // curved corner that mirrors the street).
  for (int y = 0; y < h; ++y) {
    int first = -1, last = -1;
    for (int x = 0; x < w; ++x) {
      if (!body[size_t(y) * w + x]) continue;
      if (first < 0) first = x;
      if (last >= 0 && x - last > 1 && (x - last - 1) * 5 <= w) {
        for (int g = last + 1; g < x; ++g) body[size_t(y) * w + g] = 1;
      }
      last = x;
    }
    if (first > 0 && first * 20 <= w) {
      for (int g = 0; g < first; ++g) body[size_t(y) * w + g] = 1;
    }
    if (last >= 0 && last < w - 1 && (w - 1 - last) * 20 <= w) {
      for (int g = last + 1; g < w; ++g) body[size_t(y) * w + g] = 1;
    }
  }
  // Holes: what the top, left and right borders cannot reach.
  std::vector<uint8_t> open(body.size());
  for (size_t i = 0; i < body.size(); ++i) open[i] = !body[i];
  std::vector<size_t> border;
  for (int x = 0; x < w; ++x) border.push_back(size_t(x));
  for (int y = 0; y < h; ++y)
    border.push_back(size_t(y) * w), border.push_back(size_t(y) * w + w - 1);
  const std::vector<uint8_t> outside = Flood(open, border, w, h);
  for (size_t i = 0; i < body.size(); ++i) body[i] = !outside[i];
  // Only what reaches the bottom row: the body is where the car is.
  return Flood(body, BottomRow(w, h), w, h);
}

// Whether `body` (one value per block) covers at least `min_area` of them.
bool CoversMinArea(const std::vector<uint8_t>& body, double min_area) {
  size_t area = 0;
  for (uint8_t b : body) area += b;
  return double(area) >= min_area * double(body.size());
}

// The body's blocks of one camera's views (indices into `views`).
std::vector<uint8_t> BodyBlocks(const std::vector<ContextView>& views,
                                const std::vector<ViewDepth>& depths,
                                const std::vector<InstanceTrack>& tracks,
                                const std::vector<size_t>& members, const EgoBodyOptions& options,
                                int* w_out, int* h_out, int* step_out) {
  const ContextView& first = views[members[0]];
  const int step = std::max(1, (first.width() + options.work_width - 1) / options.work_width);
  std::map<size_t, Reduced> reduced;
  std::map<size_t, std::vector<uint8_t>> dynamic;
  auto prepare = [&](size_t v) {
    if (reduced.count(v)) return;
    reduced[v] = Reduce(views[v].rgb, step);
    dynamic[v] = DynamicMask(views[v].camera, views[v].lines().MiddleWorldFromCamera(), tracks,
                             views[v].middle_time_us(), 0.5);
  };
  // Each frame with the one farthest from it, when far enough.
  std::vector<std::pair<size_t, size_t>> pairs;
  for (size_t a : members) {
    size_t best = a;
    double best_d = options.min_travel_m;
    for (size_t b : members) {
      const double d =
          Norm(views[a].world_from_camera.translation - views[b].world_from_camera.translation);
      if (d >= best_d) best = b, best_d = d;
    }
    if (best == a) continue;
    const std::pair<size_t, size_t> pair{std::min(a, best), std::max(a, best)};
    if (std::find(pairs.begin(), pairs.end(), pair) == pairs.end()) pairs.push_back(pair);
  }
  if (pairs.empty()) return {};
  prepare(members[0]);
  const int w = reduced[members[0]].width, h = reduced[members[0]].height;
  *w_out = w, *h_out = h, *step_out = step;
  // still: by the 5x5 mean; still_here: the block alone.
  std::vector<uint8_t> still(size_t(w) * h, 1), still_here(size_t(w) * h, 1);
  std::vector<std::vector<float>> same(pairs.size());
  std::vector<std::vector<uint8_t>> still_pair(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    const auto [a, b] = pairs[k];
    prepare(a);
    prepare(b);
    same[k].resize(size_t(w) * h);
    still_pair[k].resize(size_t(w) * h);
    for (size_t i = 0; i < same[k].size(); ++i) {
      same[k][i] = MeanAbs(&reduced[a].rgb[i * 3], &reduced[b].rgb[i * 3]);
      still_pair[k][i] = same[k][i] < options.still_threshold;
      if (!still_pair[k][i]) still_here[i] = 0;
    }
    same[k] = BoxMean(same[k], w, h, kBoxRadius);
    for (size_t i = 0; i < same[k].size(); ++i) {
      if (!(same[k][i] < options.still_threshold)) still[i] = 0;
    }
  }
  const std::vector<uint8_t> reached = Flood(still, BottomRow(w, h), w, h);
  std::vector<uint8_t> moved(size_t(w) * h, 0), edges(size_t(w) * h, 0);
  for (size_t k = 0; k < pairs.size(); ++k) {
    const auto [a, b] = pairs[k];
    const PairFrame fa{&views[a], &depths[a], &dynamic[a], &reduced[a]};
    const PairFrame fb{&views[b], &depths[b], &dynamic[b], &reduced[b]};
    const std::vector<float> ab = BoxMean(MovedDifference(fa, fb, still_pair[k]), w, h, kBoxRadius);
    const std::vector<float> ba = BoxMean(MovedDifference(fb, fa, still_pair[k]), w, h, kBoxRadius);
    for (size_t i = 0; i < moved.size(); ++i) {
      const float bar = std::max(options.moved_threshold, options.moved_ratio * same[k][i]);
      if ((ab[i] > bar || ba[i] > bar) && !Saturated(reduced[a], i) && !Saturated(reduced[b], i)) {
        moved[i] = 1;
      }
    }
    const std::vector<uint8_t> still_ab = StillPatches(fa, fb, reached);
    const std::vector<uint8_t> still_ba = StillPatches(fb, fa, reached);
    for (size_t i = 0; i < edges.size(); ++i) edges[i] |= still_ab[i] | still_ba[i];
  }
  const std::vector<uint8_t> outlined = BelowMovedOutline(moved, still, reduced[members[0]]);
  const std::vector<uint8_t> below = BelowLongEdges(edges, reduced[members[0]], kPatchOutlineParts);
  for (size_t i = 0; i < moved.size(); ++i) moved[i] |= below[i];
  std::vector<uint8_t> boxed(size_t(w) * h, 0);
  for (const auto& [a, b] : pairs) {
    for (size_t v : {a, b}) {
      const std::vector<uint8_t>& in_box = dynamic[v];
      if (in_box.empty()) continue;
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          const size_t px = size_t(y * step + step / 2) * views[v].width() + x * step + step / 2;
          if (in_box[px] != 0) boxed[size_t(y) * w + x] = 1;
        }
      }
    }
  }
  const std::vector<uint8_t> body = BodyShape(reached, moved, outlined, still_here, boxed, w, h);
  if (!CoversMinArea(body, options.min_area)) return {};
  return body;
}

// The body's blocks of one camera's views, searched in runs of
// `options.run_frames` consecutive frames (by time; a short last run joins
// the one before it): a block is body where at least half of the runs that
// had a pair find it. Fewer than two runs' frames: one search over them all.
std::vector<uint8_t> BodyBlocksByRuns(const std::vector<ContextView>& views,
                                      const std::vector<ViewDepth>& depths,
                                      const std::vector<InstanceTrack>& tracks,
                                      std::vector<size_t> members, const EgoBodyOptions& options,
                                      int* w_out, int* h_out, int* step_out) {
  const size_t run = size_t(std::max(0, options.run_frames));
  if (run == 0 || members.size() < 2 * run) {
    return BodyBlocks(views, depths, tracks, members, options, w_out, h_out, step_out);
  }
  std::stable_sort(members.begin(), members.end(), [&](size_t a, size_t b) {
    return views[a].middle_time_us() < views[b].middle_time_us();
  });
  std::vector<int> votes;
  int voters = 0;
  for (size_t begin = 0; begin < members.size();) {
    size_t end = begin + run;
    if (members.size() - end < run) end = members.size();
    const std::vector<size_t> part(members.begin() + long(begin), members.begin() + long(end));
    int w = 0, h = 0, step = 1;
    const std::vector<uint8_t> blocks =
        BodyBlocks(views, depths, tracks, part, options, &w, &h, &step);
    if (w > 0) {  // The run had a pair: it votes.
      ++voters;
      *w_out = w, *h_out = h, *step_out = step;
      votes.resize(size_t(w) * h, 0);
      for (size_t i = 0; i < blocks.size(); ++i) votes[i] += blocks[i];
    }
    begin = end;
  }
  if (voters == 0) return {};
  std::vector<uint8_t> body(votes.size(), 0);
  for (size_t i = 0; i < votes.size(); ++i) body[i] = 2 * votes[i] >= voters;
  if (!CoversMinArea(body, options.min_area)) return {};
  return body;
}

// The body pixels' colours in each of the camera's CONTEXT times (views of
// the layer's size; views at one time averaged), by time.
std::vector<EgoLayer::Frame> BodyFrames(const std::vector<ContextView>& views,
                                        const std::vector<size_t>& members, const EgoLayer& layer) {
  std::map<int64_t, std::vector<size_t>> by_time;
  for (size_t v : members) {
    if (views[v].width() == layer.width && views[v].height() == layer.height) {
      by_time[views[v].timestamp_us].push_back(v);
    }
  }
  std::vector<EgoLayer::Frame> frames;
  for (const auto& [time, at] : by_time) {
    EgoLayer::Frame frame;
    frame.timestamp_us = time;
    frame.rgb.reserve(layer.body_pixels() * 3);
    for (size_t i = 0; i < layer.mask.size(); ++i) {
      if (!layer.on_body(i)) continue;
      for (int c = 0; c < 3; ++c) {
        float sum = 0.f;
        for (size_t v : at) sum += views[v].rgb.pixels[i * 3 + c];
        frame.rgb.push_back(sum / float(at.size()));
      }
    }
    frames.push_back(std::move(frame));
  }
  return frames;
}

}  // namespace

std::vector<EgoLayer> DetectEgoBodies(const std::vector<ContextView>& views,
                                      const std::vector<ViewDepth>& depths,
                                      const std::vector<InstanceTrack>& tracks,
                                      const EgoBodyOptions& options) {
  std::vector<std::string> order;
  std::map<std::string, std::vector<size_t>> by_camera;
  for (size_t v = 0; v < views.size(); ++v) {
    if (!by_camera.count(views[v].camera_id)) order.push_back(views[v].camera_id);
    by_camera[views[v].camera_id].push_back(v);
  }
  std::vector<EgoLayer> layers;
  for (const std::string& id : order) {
    const std::vector<size_t>& members = by_camera[id];
    const ContextView& first = views[members[0]];
    EgoLayer layer;
    layer.camera_id = id;
    layer.width = first.width();
    layer.height = first.height();
    const size_t pixels = size_t(layer.width) * layer.height;
    if (!first.ego.empty()) {
      layer.mask = first.ego;
    } else {
      int w = 0, h = 0, step = 1;
      const std::vector<uint8_t> blocks =
          BodyBlocksByRuns(views, depths, tracks, members, options, &w, &h, &step);
      if (blocks.empty()) continue;
      layer.mask.assign(pixels, 0);
      for (int y = 0; y < layer.height; ++y) {
        const int by = std::min(y / step, h - 1);
        for (int x = 0; x < layer.width; ++x) {
          layer.mask[size_t(y) * layer.width + x] =
              blocks[size_t(by) * w + std::min(x / step, w - 1)];
        }
      }
    }
    layer.rgb.assign(pixels * 3, 0.f);
    const float norm = 1.f / float(members.size());
    for (size_t v : members) {
      if (views[v].width() != layer.width || views[v].height() != layer.height) continue;
      const std::vector<float>& rgb = views[v].rgb.pixels;
      for (size_t i = 0; i < pixels; ++i) {
        if (!layer.on_body(i)) continue;
        for (int c = 0; c < 3; ++c) layer.rgb[i * 3 + c] += rgb[i * 3 + c] * norm;
      }
    }
    layer.frames = BodyFrames(views, members, layer);
    layers.push_back(std::move(layer));
  }
  return layers;
}

void SetEgoMasks(const std::vector<EgoLayer>& layers, std::vector<ContextView>* views) {
  for (const EgoLayer& layer : layers) {
    for (ContextView& view : *views) {
      if (view.camera_id == layer.camera_id && view.width() == layer.width &&
          view.height() == layer.height) {
        view.ego = layer.mask;
      }
    }
  }
}

}  // namespace pf
