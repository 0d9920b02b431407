// What a frame costs the render worker, learnt from the frames just drawn, so a frame's tet
// budget can come from a time (after Callahan, Comba, Shirley, Silva, "Interactive rendering
// of large unstructured grids using dynamic level-of-detail", Vis 2005: a budget per frame
// from a per-tet and per-fragment cost measured while rendering).
//
// The model: ms = fixed + per_tet · tets + per_pixel · covered_pixels, fitted by least
// squares over the last kWindow frames, pulled towards priors measured on a 2-core llvmpipe
// host so the first frames (and a window of alike frames, which cannot separate the terms)
// get sensible answers. Thread-safe: every session's frames teach the one model of the pool.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <mutex>
#include <vector>

#include "tetrascope/view/camera.h"
#include "tetrascope/view/transfer_function.h"
#include "tetrascope/storage/mesh.h"

namespace tetrascope::server {

class FrameCostModel {
 public:
  static constexpr size_t kWindow = 64;           // frames the fit looks at
  static constexpr size_t kErrorSamples = 4096;   // prediction errors kept for the quantiles

  // Predicted ms of a frame of `tets` tets covering `covered_pixels` pixels.
  double predict(double tets, double covered_pixels) const;
  // A frame drawn: its tets, covered pixels and measured ms (render + encode). `predicted_ms`
  // > 0: what predict() said before it was drawn (its error goes into the quantiles).
  void observe(double tets, double covered_pixels, double measured_ms, double predicted_ms = 0);
  // The most tets whose predicted time is within `target_ms` at `covered_pixels`, in
  // [floor, cap]; floor when even that is predicted over the target.
  uint64_t tets_for(double target_ms, double covered_pixels, uint64_t floor, uint64_t cap) const;
  // The most covered pixels within `target_ms` at `tets` (0 when the tets alone exceed it).
  double pixels_for(double target_ms, double tets) const;

  struct ErrorQuantiles {
    double p50 = 0, p90 = 0;  // |measured - predicted| / measured, in percent
    uint64_t samples = 0;
    double signed_p50 = 0;    // (measured - predicted) / measured: > 0 when frames take longer than predicted
  };
  ErrorQuantiles prediction_error() const;
  std::array<double, 3> coefficients() const;  // fixed ms, ms per tet, ms per pixel

 private:
  void refit();  // under mutex_
  mutable std::mutex mutex_;
  struct Sample {
    double tets, pixels, ms;
  };
  std::deque<Sample> window_;
  // priors (fixed ms, ms per tet, ms per covered pixel): a 2-core llvmpipe host, two workers
  static constexpr std::array<double, 3> kPrior{5.0, 3e-3, 2e-5};
  std::array<double, 3> coefficients_{kPrior};
  std::deque<double> errors_, signed_errors_;
};

// The time an interaction frame aims at when `waiting` interaction frames wait for `workers`
// render workers: frame_ms / (1 + waiting / workers), at least a quarter of frame_ms. With
// many sessions moving at once each gets coarser frames sooner rather than all getting
// frames slowly.
double shared_frame_ms(double frame_ms, size_t waiting, size_t workers);

// The share of a width x height view that the box covers on screen (its corners' projected
// bounding rectangle, clipped to the view), in pixels; the whole view when the eye is inside
// the box or a corner lies behind the eye.
double covered_pixels(const view::Camera& camera, const storage::Bounds& bounds, uint32_t width, uint32_t height);

}  // namespace tetrascope::server
