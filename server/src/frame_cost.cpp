// Frame-time model after Callahan et al., Vis 2005 (per-tet and per-fragment costs measured
// online); here a ridge least-squares fit of three terms over a sliding window.
#include "tetrascope/server/frame_cost.h"

#include <algorithm>
#include <cmath>

#include "tetrascope/core/vec3.h"

namespace tetrascope::server {
namespace {

// The terms in units that keep the normal equations well conditioned.
constexpr double kTetUnit = 1e4, kPixelUnit = 1e5;
// How strongly the priors hold (per term, in the scaled units: about a twentieth of one
// frame's evidence), enough to keep a window of alike frames solvable.
constexpr double kPriorWeight = 0.05;
// A sample above this many times the model's expectation is clipped to it (see observe).
constexpr double kMaxStep = 2.5;
// Least-squares passes of the fit, the later ones reweighted (Huber) by the earlier residuals.
constexpr int kRobustPasses = 3;

double quantile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(std::lround(p * (v.size() - 1)))];
}

}  // namespace

double FrameCostModel::predict(double tets, double pixels) const {
  std::lock_guard lock(mutex_);
  return coefficients_[0] + coefficients_[1] * tets + coefficients_[2] * pixels;
}

uint64_t FrameCostModel::tets_for(double target_ms, double pixels, uint64_t floor, uint64_t cap) const {
  std::lock_guard lock(mutex_);
  const double left = target_ms - coefficients_[0] - coefficients_[2] * pixels;
  if (left <= 0) return floor;
  const double tets = left / coefficients_[1];
  return std::clamp<uint64_t>(static_cast<uint64_t>(std::min(tets, 1e18)), floor, std::max(floor, cap));
}

double FrameCostModel::pixels_for(double target_ms, double tets) const {
  std::lock_guard lock(mutex_);
  const double left = target_ms - coefficients_[0] - coefficients_[1] * tets;
  return left <= 0 ? 0 : left / std::max(coefficients_[2], 1e-12);
}

void FrameCostModel::observe(double tets, double pixels, double ms, double predicted_ms) {
  std::lock_guard lock(mutex_);
  // One slow frame (a context's first draw compiling its shaders, a page-in, a busy host)
  // must not make every later budget tiny: a sample counts for at most kMaxStep times what
  // the model expected, so a real change of cost is learnt over a few frames instead.
  const double expected = coefficients_[0] + coefficients_[1] * tets + coefficients_[2] * pixels;
  window_.push_back({tets, pixels, std::min(ms, kMaxStep * expected)});
  if (window_.size() > kWindow) window_.pop_front();
  if (predicted_ms > 0 && ms > 0) {
    errors_.push_back(std::abs(ms - predicted_ms) / ms * 100);
    signed_errors_.push_back((ms - predicted_ms) / ms * 100);
    if (errors_.size() > kErrorSamples) {
      errors_.pop_front();
      signed_errors_.pop_front();
    }
  }
  refit();
}

// Minimises Σ w_i (ms_i - c·x_i)^2 + p Σ_k (c_k - prior_k)^2 (x, c in the scaled units) by the
// 3x3 normal equations, with Huber weights from the last pass's residuals (kRobustPasses
// passes): frames far off the fit (a context compiling its shaders, a host busy with other
// work) count less, so the model follows the typical frame. A coefficient the data drives
// below a tenth of its prior is held there and the others fitted again (a frame never gets
// cheaper with more tets or pixels).
void FrameCostModel::refit() {
  const std::array<double, 3> unit{1, kTetUnit, kPixelUnit};
  std::array<double, 3> prior, floor;
  for (int k = 0; k < 3; ++k) prior[k] = kPrior[k] * unit[k];
  for (int k = 0; k < 3; ++k) floor[k] = prior[k] * 0.1;
  std::array<double, 3> scaled_fit;
  for (int k = 0; k < 3; ++k) scaled_fit[k] = coefficients_[k] * unit[k];
  std::vector<double> weight(window_.size(), 1.0), residual(window_.size());
  for (int pass = 0; pass < kRobustPasses; ++pass) {
    if (pass > 0) {  // Huber weights: residuals past 1.5x the median residual count as that
      for (size_t i = 0; i < window_.size(); ++i) {
        const Sample& s = window_[i];
        residual[i] = std::abs(s.ms - (scaled_fit[0] + scaled_fit[1] * s.tets / kTetUnit + scaled_fit[2] * s.pixels / kPixelUnit));
      }
      std::vector<double> sorted = residual;
      std::nth_element(sorted.begin(), sorted.begin() + long(sorted.size() / 2), sorted.end());
      const double limit = std::max(1.5 * sorted[sorted.size() / 2], 0.5);  // ms
      for (size_t i = 0; i < window_.size(); ++i) weight[i] = residual[i] > limit ? limit / residual[i] : 1.0;
    }
    // bounded least squares by active sets: a coefficient the unbounded fit drives below its
    // floor is held at the floor and the others are fitted again with it fixed. (Clamping it
    // alone, as before, over-predicted alike frames 2-5x: with tets and pixels nearly the same
    // in every frame the terms trade off, the fit made one negative, and the clamp added it back.)
    std::array<bool, 3> held{};
    for (int round = 0; round < 3; ++round) {
      double a[3][4] = {};
      for (size_t i = 0; i < window_.size(); ++i) {
        const Sample& s = window_[i];
        const double x[3] = {1, s.tets / kTetUnit, s.pixels / kPixelUnit};
        double target = s.ms;
        for (int k = 0; k < 3; ++k)
          if (held[k]) target -= floor[k] * x[k];
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 3; ++c) a[r][c] += weight[i] * x[r] * x[c];
          a[r][3] += weight[i] * x[r] * target;
        }
      }
      for (int k = 0; k < 3; ++k) {
        a[k][k] += kPriorWeight;
        a[k][3] += kPriorWeight * prior[k];
      }
      for (int k = 0; k < 3; ++k) {  // a held coefficient: the row says c_k = floor_k (solved for as 0 here)
        if (!held[k]) continue;
        for (int c = 0; c < 4; ++c) a[k][c] = c == k ? 1 : 0;
        for (int r = 0; r < 3; ++r)
          if (r != k) a[r][k] = 0;
      }
      for (int col = 0; col < 3; ++col) {  // Gauss-Jordan with partial pivoting
        int pivot = col;
        for (int r = col + 1; r < 3; ++r)
          if (std::abs(a[r][col]) > std::abs(a[pivot][col])) pivot = r;
        std::swap(a[col], a[pivot]);
        if (std::abs(a[col][col]) < 1e-12) return;  // keep the last fit
        for (int r = 0; r < 3; ++r) {
          if (r == col) continue;
          const double f = a[r][col] / a[col][col];
          for (int c = col; c < 4; ++c) a[r][c] -= f * a[col][c];
        }
      }
      bool more = false;
      for (int k = 0; k < 3; ++k) {
        scaled_fit[k] = held[k] ? floor[k] : a[k][3] / a[k][k];
        if (!held[k] && scaled_fit[k] < floor[k]) held[k] = more = true;
      }
      if (!more) break;
    }
    for (int k = 0; k < 3; ++k) scaled_fit[k] = std::max(scaled_fit[k], floor[k]);
    if (window_.size() < 3) break;
  }
  for (int k = 0; k < 3; ++k) coefficients_[k] = scaled_fit[k] / unit[k];
}

FrameCostModel::ErrorQuantiles FrameCostModel::prediction_error() const {
  std::lock_guard lock(mutex_);
  ErrorQuantiles q;
  const std::vector<double> e(errors_.begin(), errors_.end()), s(signed_errors_.begin(), signed_errors_.end());
  q.p50 = quantile(e, 0.5);
  q.p90 = quantile(e, 0.9);
  q.signed_p50 = quantile(s, 0.5);
  q.samples = e.size();
  return q;
}

std::array<double, 3> FrameCostModel::coefficients() const {
  std::lock_guard lock(mutex_);
  return coefficients_;
}

double shared_frame_ms(double frame_ms, size_t waiting, size_t workers) {
  const double per_worker = double(waiting) / double(std::max<size_t>(workers, 1));
  return frame_ms / std::clamp(1.0 + per_worker, 1.0, 4.0);
}

double covered_pixels(const view::Camera& camera, const storage::Bounds& bounds, uint32_t width, uint32_t height) {
  const view::ViewFrame frame = view::ViewFrame::of(camera, width, height);
  return double(width) * height * (frame.valid ? frame.box_share(bounds) : 1.0);
}

}  // namespace tetrascope::server
